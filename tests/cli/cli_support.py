"""Helpers of the CLI tests: the environment of a `ur3dq` run, error checks, and the simulated arm they drive."""
import contextlib
import fcntl
import os
import pty
import re
import signal
import struct
import subprocess
import sys
import termios
import threading
import time
from pathlib import Path

import numpy as np

UR3DQ = str(Path(sys.executable).with_name("ur3dq"))


def cli_env(tmp_path, **extra):
    """The environment of a CLI run: no inherited robot, store or state; the state dir under `tmp_path`."""
    env = {key: value for key, value in os.environ.items() if not key.startswith("UR3DQ_")}
    env["UR3DQ_STATE_DIR"] = str(tmp_path / "state")
    env["COLUMNS"] = "200"
    env.update(extra)
    return env


@contextlib.contextmanager
def cli_process(tmp_path, *args, stdin=subprocess.DEVNULL, inherited_sigint=signal.SIG_DFL):
    """A running `ur3dq args` in `tmp_path` with text stdout/stderr pipes (stdin too if stdin=PIPE), for tests that
    talk to it while it runs; on exit it is killed if still running, and its pipes are closed. It starts with
    SIGINT set to `inherited_sigint` (SIG_IGN: as a shell script's `ur3dq ... &` starts it), whatever the test
    runner's own disposition."""
    with subprocess.Popen([UR3DQ, *map(str, args)], cwd=tmp_path, env=cli_env(tmp_path), stdin=stdin,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, inherited_sigint)) as process:
        try:
            yield process
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()


def finish(process, timeout=30):
    """(stdout, stderr) of a `cli_process` once it ends; AssertionError after `timeout` s, with the stack of every
    thread it had then (ur3dq prints them on SIGQUIT: ur3dq.cli.signals), so a hang says where it hangs."""
    try:
        return process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGQUIT)
        time.sleep(1.0)
        process.kill()
        stdout, stderr = process.communicate()
        raise AssertionError(f"ur3dq {' '.join(process.args[1:])} did not end within {timeout} s; its stderr, "
                             f"with every thread's stack:\n{stderr[-12000:]}") from None


def assert_one_line_error(result, code, *fragments):
    """The run failed with exit `code` and ended with exactly one stderr line `Error: ...` (after any question it
    asked) containing every fragment."""
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == code, (result.returncode, result.stdout, result.stderr)
    errors = [line for line in lines if line.startswith("Error")]
    assert len(errors) == 1 and lines[-1] == errors[0] and errors[0].startswith("Error: "), result.stderr
    for fragment in fragments:
        assert fragment in errors[0], (fragment, errors[0])


def assert_fits_with_every_name_whole(text, width, names):
    """Every line of `text` fits `width` columns, nothing was cut with rich's ellipsis, and every name appears whole
    on one line."""
    lines = text.splitlines()
    too_long = [line for line in lines if len(line.rstrip()) > width]
    assert not too_long, "\n".join(too_long)
    assert "…" not in text, text
    for name in names:
        assert any(name in line for line in lines), (name, text)


class SimulatedArm:
    """A sim_ursim subprocess, powered on with brakes released, read and placed through independent clients:
    ur_rtde's RTDE receive interface reads it, the simulator's control channel moves it by hand."""

    def __init__(self, host):
        import rtde_receive

        self.host = host
        self.receive = rtde_receive.RTDEReceiveInterface(host)

    def joints(self):
        """Actual joints (rad) as ur_rtde reads them."""
        return np.array(self.receive.getActualQ())

    def tcp_pose(self):
        """Actual TCP pose vector as ur_rtde reads it."""
        return np.array(self.receive.getActualTCPPose())

    def joint_speeds(self):
        """Actual joint speeds (rad/s) as ur_rtde reads them."""
        return np.array(self.receive.getActualQd())

    def place(self, q):
        """Move the arm by hand to `q` (freedrive on, push, freedrive off) and wait until RTDE shows it there."""
        from sim_ursim.control_channel import send_request

        for command, arguments in (("freedrive", {"on": True}), ("move-by-hand", {"q": list(q)}),
                                   ("freedrive", {"on": False})):
            reply = send_request(self.host, command, **arguments)
            assert reply.get("ok"), reply
        self.wait_until_at(q)

    def wait_until_at(self, q, timeout=10.0, tolerance=1e-6):
        """Block until the arm rests at `q`; AssertionError with where it is after `timeout`."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if np.max(np.abs(self.joints() - q)) < tolerance and np.max(np.abs(self.joint_speeds())) < 1e-9:
                return
            time.sleep(0.02)
        raise AssertionError(f"the arm is at {self.joints()}, not {list(q)}")


@contextlib.contextmanager
def run_poses_mid_move(arm, run_cli, tmp_path, start, target, speed):
    """`ur3dq run-poses` (a process) moving the arm from `start` to a pose recorded at `target` at `speed` rad/s,
    yielded once the arm clearly moves; on exit it is killed if still running."""
    arm.place(target)
    assert run_cli("--host", arm.host, "record-pose", "--name", "target", "--yes").returncode == 0
    arm.place(start)
    with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes", "--speed", str(speed)) as process:
        deadline = time.monotonic() + 20
        while np.max(np.abs(arm.joint_speeds())) < 0.05:
            assert time.monotonic() < deadline and process.poll() is None, "the arm never started moving"
            time.sleep(0.02)
        yield process


class Terminal:
    """`ur3dq ARGS` on a pseudo-terminal of 80×24: keys in, the screen's text out (escape codes dropped)."""

    def __init__(self, tmp_path, *args):
        master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
        env = cli_env(tmp_path, COLUMNS="80", LINES="24", TERM="xterm")
        self.process = subprocess.Popen([UR3DQ, *map(str, args)], cwd=tmp_path, env=env, stdin=slave,
                                        stdout=slave, stderr=slave, close_fds=True)
        os.close(slave)
        self.master, self.text, self._lock = master, "", threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        while True:
            try:
                chunk = os.read(self.master, 4096)
            except OSError:
                return
            if not chunk:
                return
            with self._lock:
                self.text += re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", chunk.decode("utf-8", "replace"))

    def press(self, keys):
        os.write(self.master, keys.encode())

    def wait_for(self, fragment, timeout=20.0):
        """Wait until the screen has shown `fragment` since the last wait; AssertionError with the screen if not."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                at = self.text.find(fragment)
                if at >= 0:
                    self.text = self.text[at + len(fragment):]
                    return
            time.sleep(0.02)
        raise AssertionError(f"{fragment!r} never shown; the screen ends with {self.text[-600:]!r}")

    def close(self):
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(10)
        os.close(self.master)


#: Runs `ur3dq` in this process (its own, as the command is), then prints whether numba was imported.
OWN_PROCESS = """
import sys
from ur3dq.cli import main
try:
    main(sys.argv[1:])
except SystemExit as end:
    assert not end.code, end.code
print("numba" in sys.modules)
"""


def run_telling_numba(tmp_path, jit, *args):
    """(stdout lines, "True"/"False": whether numba was imported) of `ur3dq args` run as its own process in
    `tmp_path`, with NUMBA_DISABLE_JIT set to `jit` ("" leaves it unset, as a user's shell does)."""
    env = {key: value for key, value in cli_env(tmp_path).items() if key != "NUMBA_DISABLE_JIT"}
    env.update({"NUMBA_DISABLE_JIT": jit} if jit else {})
    result = subprocess.run([sys.executable, "-c", OWN_PROCESS, *map(str, args)], capture_output=True, text=True,
                            env=env, cwd=tmp_path, timeout=60, check=False)
    assert result.returncode == 0, result.stderr
    *lines, numba = result.stdout.strip().splitlines()
    return lines, numba
