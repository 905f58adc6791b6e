"""The embedded simulator in the background: `python -m sim_ursim` detached, remembered in a small state file.

The state file (`sim.json` in $UR3DQ_STATE_DIR, else $XDG_STATE_HOME/ur3dq, else ~/.local/state/ur3dq) holds the
pid, address, model and log path. The simulator keeps one address per user (per state directory): the one it
last served on (`address` beside the state file), else one drawn from the user's id and the directory, so an
exported UR3DQ_HOST stays right from one `sim start` to the next; only when that address is taken is another
one chosen (and `sim start` says so). A pid only counts as our simulator while its command line still runs sim_ursim,
so a stale file (reboot, kill -9, reused pid) is recognised and never leads to signalling an unrelated process.
"""
from __future__ import annotations

import ipaddress
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ur3dq.errors import UR3DQError
from ur3dq.pose import utc_now_iso
from ur3dq.store import write_atomically

if TYPE_CHECKING:
    import filelock

STATE_FILE_NAME = "sim.json"
ADDRESS_FILE_NAME = "address"
STOP_TIMEOUT_S = 10.0
START_TIMEOUT_S = 20.0


class SimulatorError(UR3DQError):
    """The embedded simulator could not be started or stopped."""


def state_directory() -> Path:
    """Where the simulator's state file lives: $UR3DQ_STATE_DIR, $XDG_STATE_HOME/ur3dq or ~/.local/state/ur3dq."""
    if os.environ.get("UR3DQ_STATE_DIR"):
        return Path(os.environ["UR3DQ_STATE_DIR"])
    base = os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state"
    return Path(base) / "ur3dq"


def process_is_simulator(pid: int) -> bool:
    """True if process `pid` exists and runs `python -m sim_ursim` (a zombie's command line is empty: not running)."""
    try:
        return b"sim_ursim" in Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except FileNotFoundError:
        return False
    except OSError:  # no /proc (macOS): fall back to "the pid exists"
        try:
            os.kill(pid, 0)
        except OSError:
            return False
        return True


def read_state(directory: Path) -> dict[str, Any] | None:
    """The recorded simulator if it is still running, else None (a stale or unreadable file counts as none)."""
    try:
        state = json.loads((directory / STATE_FILE_NAME).read_text(encoding="utf-8"))
        pid = int(state["pid"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return state if process_is_simulator(pid) else None


def running_simulator_host() -> str | None:
    """The address of the embedded simulator `ur3dq sim start` left running, or None."""
    state = read_state(state_directory())
    return state["host"] if state else None


def _lock(directory: Path) -> filelock.FileLock:
    """The lock that serialises `sim start` / `sim stop` (so two starts cannot both spawn)."""
    import filelock  # here, not with the module: every command imports this one, few start a simulator
    return filelock.FileLock(str(directory / "sim.lock"), timeout=START_TIMEOUT_S + STOP_TIMEOUT_S)


def is_loopback_ipv4(text: str) -> bool:
    """Whether `text` is an IPv4 address in 127.0.0.0/8, written as one (`127.0.0.3`, not `127.0.0.1.5`)."""
    try:
        return ipaddress.IPv4Address(text).is_loopback
    except ValueError:
        return False


def start_simulator(model: str = "ur3", host: str | None = None, version: str | None = None) -> dict[str, Any]:
    """Start the embedded simulator in the background and record where it serves.

    Start `python -m sim_ursim` detached on `host` (default: a free loopback address) and wait until it
    serves every port; returns the recorded state. SimulatorError if one runs already or it does not come up."""
    from sim_ursim.launch import ports_bindable, wait_until_serving

    directory = state_directory()
    directory.mkdir(parents=True, exist_ok=True)
    with _lock(directory):
        running = read_state(directory)
        if running:
            raise SimulatorError(f"the embedded simulator already runs on {running['host']} (pid {running['pid']}); "
                                 "`ur3dq sim stop` first")
        if host is None:
            host = _preferred_address(directory)
        elif not is_loopback_ipv4(host):
            raise ValueError(f"--address {host!r}: the embedded simulator binds loopback addresses only (127.x.y.z)")
        elif not ports_bindable(host):
            raise SimulatorError(f"the robot ports on {host} are taken: choose another --address (e.g. 127.0.0.3)")
        log_path = directory / f"sim-{host}.log"
        arguments = [sys.executable, "-m", "sim_ursim", "--host", host, "--model", model]
        if version:
            arguments += ["--version", version]
        with open(log_path, "wb") as log:
            # its own session: the simulator outlives this command and ignores the terminal's Ctrl-C
            process = subprocess.Popen(arguments, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                       start_new_session=True)
        try:
            wait_until_serving(host, timeout=START_TIMEOUT_S, alive=lambda: process.poll() is None)
        except (TimeoutError, RuntimeError) as error:
            if process.poll() is None:
                process.kill()
            process.wait()
            tail = log_path.read_text(encoding="utf-8", errors="replace").strip().splitlines()[-1:]
            detail = f" ({tail[0]})" if tail else ""
            raise SimulatorError(f"the simulator did not come up: {error}{detail}") from None
        state = {"pid": process.pid, "host": host, "model": model, "version": version, "log": str(log_path),
                 "started": utc_now_iso()}
        previous = _remembered_address(directory)
        state["address_changed_from"] = previous if previous and previous != host else None
        write_atomically(directory / STATE_FILE_NAME, json.dumps(state, indent=2) + "\n")
        write_atomically(directory / ADDRESS_FILE_NAME, host + "\n")
        return state


def _remembered_address(directory: Path) -> str | None:
    """The address the simulator of this state directory last served on, if any."""
    try:
        text = (directory / ADDRESS_FILE_NAME).read_text(encoding="utf-8").strip()
    except OSError:
        return None
    return text if text.startswith("127.") and text.count(".") == 3 else None


def _preferred_address(directory: Path) -> str:
    """This user's simulator address: the remembered one, else one drawn from the user's id and the state
    directory (the same every time), else, when those are taken, any free loopback address."""
    from sim_ursim.launch import free_loopback_address, ports_bindable, random_loopback_address

    draw = random.Random(f"{os.getuid() if hasattr(os, 'getuid') else 0}:{directory.resolve()}")
    candidates = [_remembered_address(directory), *(random_loopback_address(draw) for _ in range(3))]
    for candidate in candidates:
        if candidate and ports_bindable(candidate):
            return candidate
    return free_loopback_address()


def stop_simulator() -> dict[str, Any] | None:
    """Stop the simulator `start_simulator` started.

    Stop the recorded simulator (SIGTERM, then SIGKILL after 10 s) and forget it; returns its state, or None
    if none was running."""
    directory = state_directory()
    if not directory.is_dir():
        return None
    with _lock(directory):
        state = read_state(directory)
        if state:
            pid = int(state["pid"])
            os.kill(pid, signal.SIGTERM)
            deadline = time.monotonic() + STOP_TIMEOUT_S
            while process_is_simulator(pid) and time.monotonic() < deadline:
                time.sleep(0.05)
            if process_is_simulator(pid):
                os.kill(pid, signal.SIGKILL)
        (directory / STATE_FILE_NAME).unlink(missing_ok=True)
        return state
