"""Launching simulators: context managers that start one on a free loopback address (in this process or as a
`python -m sim_ursim` subprocess) and wait until it serves. Used by the tests and by ur3dq's `sim` CLI commands.

UR clients cannot change the robot's ports, so parallel simulators differ by address: every one gets its own
random 127.a.b.c (all of 127.0.0.0/8 is loopback on Linux) where every standard port is free.
ur_rtde's RTDE interfaces hold the GIL in their constructors and deadlock against an in-process simulator: give
them `simulator_process` (DashboardClient, urx and raw sockets are fine with `running_simulator`).
"""
import contextlib
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator, Sequence

from .simulator import STANDARD_PORTS, Simulator

ADDRESS_ATTEMPTS = 50
SERVE_TIMEOUT = 20.0
_RNG = random.Random()


def random_loopback_address(rng: random.Random | None = None) -> str:
    """A random 127.a.b.c address, avoiding 127.0.0.1 and the .0 / .255 host parts (`rng`: default, the module's)."""
    rng = rng or _RNG
    return f"127.{rng.randrange(0, 256)}.{rng.randrange(0, 256)}.{rng.randrange(2, 255)}"


def ports_bindable(host: str, ports: Iterable[int] = STANDARD_PORTS) -> bool:
    """True when every port in `ports` can be bound on `host` right now."""
    for port in ports:
        probe = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host, port))
        except OSError:
            return False
        finally:
            probe.close()
    return True


def free_loopback_address(ports: Iterable[int] = STANDARD_PORTS, attempts: int = ADDRESS_ATTEMPTS) -> str:
    """A loopback address on which all `ports` are bindable; RuntimeError after `attempts` tries."""
    for _ in range(attempts):
        host = random_loopback_address()
        if ports_bindable(host, ports):
            return host
    raise RuntimeError(f"no loopback address with ports {ports} free after {attempts} attempts")


def wait_until_serving(host: str, ports: Iterable[int] = STANDARD_PORTS, timeout: float = SERVE_TIMEOUT,
                       alive: Callable[[], bool] | None = None) -> None:
    """Block until every port on `host` accepts a TCP connection; TimeoutError naming the ports that do not."""
    deadline = time.monotonic() + timeout
    waiting = list(ports)
    while waiting:
        if alive is not None and not alive():
            raise RuntimeError(f"the simulator on {host} exited before serving ports {waiting}")
        port = waiting[0]
        try:
            with socket.create_connection((host, port), timeout=0.5):
                waiting.pop(0)
                continue
        except OSError:
            pass
        if time.monotonic() > deadline:
            raise TimeoutError(f"sim_ursim on {host} not serving ports {waiting} after {timeout} s")
        time.sleep(0.05)


@contextlib.contextmanager
def running_simulator(model: str = "ur3", version: str | None = None, **options) -> Iterator[Simulator]:
    """A started Simulator on a free loopback address (`.host`, `.controller`), stopped cleanly on exit."""
    last_error = None
    for _ in range(ADDRESS_ATTEMPTS):
        host = free_loopback_address()
        simulator = Simulator(model=model, version=version, host=host, **options)
        try:
            simulator.start()
        except OSError as error:  # another simulator took the address between the check and the bind
            last_error = error
            continue
        try:
            wait_until_serving(host)
            yield simulator
        finally:
            simulator.stop()
        return
    raise RuntimeError(f"could not start a simulator on any loopback address: {last_error}")


class SimulatorProcess:
    """A `python -m sim_ursim` child process: `.host`, `.process`, `.output()` once stopped."""

    def __init__(self, host: str, process: subprocess.Popen, log_path: str):
        self.host = host
        self.process = process
        self.log_path = log_path

    def output(self) -> str:
        """Everything the process logged so far."""
        with open(self.log_path, encoding="utf-8", errors="replace") as log_file:
            return log_file.read()


@contextlib.contextmanager
def simulator_process(model: str = "ur3", version: str | None = None, extra_args: Sequence[str] = (),
                      log_path: str | None = None, **options) -> Iterator["SimulatorProcess"]:
    """`python -m sim_ursim` on a free loopback address in a subprocess; terminated (SIGTERM) on exit.

    `options` become command-line flags (initial_q=[...] → --initial-q "a,b,..."); the log goes to `log_path`
    (a temporary file, removed on exit, by default).
    """
    host = free_loopback_address()
    arguments = [sys.executable, "-m", "sim_ursim", "--host", host, "--model", model]
    if version is not None:
        arguments += ["--version", str(version)]
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        arguments += [flag, ",".join(str(v) for v in value) if isinstance(value, (list, tuple)) else str(value)]
    arguments += list(extra_args)
    own_log = log_path is None
    if log_path is None:
        handle, log_path = tempfile.mkstemp(prefix="sim_ursim-", suffix=".log")
        os.close(handle)
    with open(log_path, "wb") as log_file:
        process = subprocess.Popen(arguments, stdout=log_file, stderr=subprocess.STDOUT)
    try:
        wait_until_serving(host, alive=lambda: process.poll() is None)
        yield SimulatorProcess(host, process, log_path)
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        if own_log:
            os.remove(log_path)
