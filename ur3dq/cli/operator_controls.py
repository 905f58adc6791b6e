"""Pause, resume and stop while `run-poses` moves the arm: keys in a terminal, signals for scripts.

In a terminal, `p` (or the space bar) pauses: the driver asks the controller to pause the program (the arm
decelerates to rest on its path; where the controller refuses, the arm is stopped instead) and the step is shown
with the choices `r` resume, `s` stop (the run can go on later with `run-poses --resume`) and `q` quit (stop and
forget the run). Ctrl-Z (SIGTSTP) and SIGUSR1 pause as `p` does, SIGCONT and SIGUSR2 resume, so a script or a
supervisor can pause and resume a run with `kill`; Ctrl-C, SIGTERM and SIGHUP stop it as always (ur3dq.cli.signals).

The keys are read by a thread (the terminal in cbreak mode, restored on exit) and the robot is paused or resumed
by another, so the main thread keeps watching the motion, as the driver requires (ur3dq.robot.Robot.pause).
"""
from __future__ import annotations

import contextlib
import os
import queue
import select
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from types import FrameType, TracebackType
from typing import Any

from rich.console import Console

from ur3dq.errors import RobotError

PAUSE_KEYS = ("p", " ")
RESUME_KEYS = ("r", " ", "\n", "\r")
PAUSE_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTSTP", "SIGUSR1") if hasattr(signal, name))
RESUME_SIGNALS = tuple(getattr(signal, name) for name in ("SIGCONT", "SIGUSR2") if hasattr(signal, name))
KEY_POLL = 0.1   # s between two looks at the keyboard (and at the end of the run)


class OperatorControls:
    """The operator's pause/resume/stop during one run of `robot`; use it with `with` around the run.

    `describe()` names the step running now (shown when paused). After the run, `stop_choice` is "stop" or "quit"
    when the operator stopped it, and `paused_by_stop` is True when a pause had to stop the arm instead.
    """

    def __init__(self, robot: Any, console: Console, describe: Callable[[], str]) -> None:
        self.robot = robot
        self.console = console
        self.describe = describe
        self.stop_choice: str | None = None
        self.paused_by_stop = False
        self.paused = False
        self._requests: queue.Queue[str] = queue.Queue()
        self._done = threading.Event()
        self._threads: list[threading.Thread] = []
        self._previous_handlers: dict[int, Any] = {}
        self._keyboard = sys.stdin.isatty() and threading.current_thread() is threading.main_thread()

    def __enter__(self) -> OperatorControls:
        if threading.current_thread() is threading.main_thread():
            for signum in PAUSE_SIGNALS + RESUME_SIGNALS:
                self._previous_handlers[signum] = signal.signal(signum, self._on_signal)
        self._start(self._act, "ur3dq-operator")
        if self._keyboard:
            self._start(self._read_keys, "ur3dq-keys")
        hint = "p pauses, s stops, q quits" if self._keyboard else "SIGUSR1 or SIGTSTP pauses, SIGCONT resumes"
        self.console.print(f"[dim]{hint}; Ctrl-C stops the arm[/]")
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self._done.set()
        self._requests.put("")
        for thread in self._threads:
            thread.join(2.0)
        for signum, handler in self._previous_handlers.items():
            signal.signal(signum, handler)

    def _start(self, target: Callable[[], None], name: str) -> None:
        thread = threading.Thread(target=target, name=name, daemon=True)
        self._threads.append(thread)
        thread.start()

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        self._requests.put("pause" if signum in PAUSE_SIGNALS else "resume")

    def _read_keys(self) -> None:
        """Read single keys from the terminal until the run ends; pass on what they ask."""
        with cbreak(sys.stdin.fileno()):
            while not self._done.is_set():
                key = read_key(sys.stdin.fileno(), KEY_POLL)
                if key == "":   # the terminal closed
                    return
                if key is None:
                    continue
                if key == "s" or key == "q":
                    self._requests.put("stop" if key == "s" else "quit")
                elif self.paused and key in RESUME_KEYS:
                    self._requests.put("resume")
                elif not self.paused and key in PAUSE_KEYS:
                    self._requests.put("pause")

    def _act(self) -> None:
        """Carry out the requests, one at a time, off the main thread (which watches the motion)."""
        while not self._done.is_set():
            request = self._requests.get()
            if not request or self.stop_choice is not None:
                continue
            try:
                getattr(self, f"_{request}")()
            except RobotError as error:   # the main thread's watch reports the fault itself
                self.console.print(f"[red]{request}: {error}[/]")

    def _pause(self) -> None:
        if self.paused:
            return
        if self.robot.pause() == "stopped":
            self.paused_by_stop = True
            self.console.print("The controller would not pause this program: the arm was stopped instead.")
            return
        self.paused = True
        keys = "r resume, s stop (go on later with --resume), q quit" if self._keyboard else \
            "SIGCONT resumes, Ctrl-C or SIGTERM stops"
        self.console.print(f"[bold]Paused[/] during {self.describe()}: the arm rests on its path. {keys}.")

    def _resume(self) -> None:
        if not self.paused:
            return
        self.robot.resume()
        self.paused = False
        self.console.print("Resumed.")

    def _stop(self) -> None:
        self.stop_choice = "stop"
        self.robot.stop()

    def _quit(self) -> None:
        self.stop_choice = "quit"
        self.robot.stop()


@contextlib.contextmanager
def cbreak(fd: int) -> Iterator[None]:
    """The terminal `fd` in cbreak mode (keys one at a time, not echoed; Ctrl-C still a signal) while inside."""
    import termios
    import tty

    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def read_key(fd: int, timeout: float) -> str | None:
    """One key typed on `fd` within `timeout` s, None when none came, "" at the end of the input (a pipe that
    closed); an escape sequence (an arrow key) comes as one string, and keys typed together one at a time."""
    ready, _, _ = select.select([fd], [], [], timeout)
    if not ready:
        return None
    data = os.read(fd, 1)
    if not data:
        return ""
    if data == b"\x1b":   # an escape sequence follows at once, or it was the Esc key alone
        while len(data) < 8 and select.select([fd], [], [], 0.01)[0]:
            data += os.read(fd, 1)
            if data[-1:].isalpha() or data[-1:] == b"~":
                break
    return data.decode("utf-8", "replace")
