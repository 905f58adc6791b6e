"""The heartbeat that stops the arm when ur3dq no longer can: killed, crashed, hung or cut off.

Ctrl-C, SIGTERM and SIGHUP reach ur3dq, which sends `stopj`; kill -9, a crash or a hang do not. For those the
controller itself must stop: every motion program ur3dq sends first arms the controller's RTDE input watchdog
(URScript `rtde_set_watchdog(variable, min_frequency, "stop")`, UR script manual) on HEARTBEAT_REGISTER, and a
small process of the heartbeat's own (ur3dq.robot.heartbeat_process) writes a new value to that register every
PERIOD over an RTDE connection of its own. When the values stop coming, the controller stops the program, and with
it the arm, 1/WATCHDOG_FREQUENCY s after the last one. The watchdog is removed when the program ends, so nothing
changes between motions.

The beats come from that process, not from a thread of ur3dq, so ur3dq's GIL does not hold them back. It stops
beating at once when ur3dq dies (the pipe to it ends) or is stopped (SIGSTOP), and HANG_TOLERANCE s after the
last tick of ur3dq's heartbeat thread when ur3dq freezes while running.

The driver starts the heartbeat with the first program it sends (a motion, freedrive, a jog step): a command that
moves nothing never starts the process. Another RTDE client holding the register or this client's RTDE inputs (a
second ur3dq moving the same arm, a user's own RTDEIOInterface) makes the controller refuse them, and the program
is refused with a line that says so.
"""
from __future__ import annotations

import os
import queue
import select
import subprocess
import sys
import threading
import time

from ur3dq.errors import RobotConnectionError
from ur3dq.robot.heartbeat_process import HANG_TOLERANCE, HEARTBEAT_REGISTER, PERIOD, TICK_PERIOD
from ur3dq.robot.rtde_inputs import RTDEInputs
from ur3dq.robot.rtde_wire import RTDE_PORT, connect_timeout
from ur3dq.urscript import first_statement_added, rtde_set_watchdog_statement

__all__ = ["HANG_TOLERANCE", "HEARTBEAT_REGISTER", "PERIOD", "WATCHDOG_FREQUENCY", "Heartbeat", "armed",
           "watchdog_statement"]

#: The controller stops a motion program this long (1/frequency) after the last heartbeat: 100 ms. A motion stopped
#: this way says so in its ProgramError (Heartbeat.longest_gap).
WATCHDOG_FREQUENCY = 10.0
#: Seconds the heartbeat's process may take to start (an interpreter on a loaded machine), besides its connection.
START_TIMEOUT = 5.0
#: Seconds to wait for the process's answer to a question, or for its end once told to stop.
ANSWER_TIMEOUT = 1.0
#: How the heartbeat's process starts: the package's own directory first on its path, nothing else imported.
_BOOT = ("import sys; sys.path.insert(0, sys.argv[1]); from ur3dq.robot.heartbeat_process import main; "
         "sys.exit(main(sys.argv[2:]))")


def watchdog_statement() -> str:
    """The URScript statement that arms the heartbeat watchdog: a motion program's first line."""
    return rtde_set_watchdog_statement(f"input_int_register_{HEARTBEAT_REGISTER}", WATCHDOG_FREQUENCY, "stop")


def armed(program: str, name: str) -> str:
    """`program` (URScript text holding `def name():`) with the watchdog armed as its first statement."""
    return first_statement_added(program, name, watchdog_statement())


def process_command(host: str) -> list[str]:
    """The command line of the heartbeat's process for `host`: this interpreter, isolated (-I, -S: no site
    packages), with the directory holding this ur3dq package first on its path."""
    if not sys.executable:
        raise RobotConnectionError("cannot start the heartbeat's process: this Python does not know its interpreter")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))   # holds ur3dq/robot/
    return [sys.executable, "-I", "-S", "-c", _BOOT, root, host, str(os.getpid())]


class Heartbeat:
    """The heartbeat's process writing a counter to HEARTBEAT_REGISTER every PERIOD s until `close()`, and the
    thread of ur3dq that ticks it and hears its reports.

    `inputs` are this client's other RTDE inputs (outputs, speed slider, registers): restart() reconnects them and
    close() closes them with the heartbeat, as one connection of the driver. `alive` turns False when a write
    fails (the connection dropped): a program must not start then, since nothing would stop it if ur3dq died.
    `silence()` is how ur3dq stops a program it has lost sight of: no more beats, so the controller's watchdog stops
    the program at the controller's own stop.
    """

    def __init__(self, inputs: RTDEInputs) -> None:
        self.inputs = inputs
        self.host = inputs.host
        self._watched_from = time.monotonic()   # see watch_gaps
        self._silenced = False
        self._ask_lock = threading.Lock()   # one question at a time
        self._start()

    def _start(self) -> None:
        """Start the process and its thread; return once its first value is on the wire (before any program can
        arm the watchdog on it); RobotConnectionError if it cannot connect."""
        try:
            # In ur3dq's own session: Linux schedules each session as one group (autogroup), and in a new session
            # of its own the process waited for the CPU long enough to miss the watchdog on a loaded machine, where
            # in ur3dq's it did not (docs/performance.md).
            self._process = subprocess.Popen(process_command(self.host), stdin=subprocess.PIPE,
                                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        except OSError as error:
            raise RobotConnectionError(f"cannot start the heartbeat's process: {error.strerror or error}") from None
        assert self._process.stdin is not None
        os.set_blocking(self._process.stdin.fileno(), False)   # a tick to a stopped process never blocks ur3dq
        self._pipe_lock = threading.Lock()   # writes to the process's stdin, and its closing
        self._stop, self._failed = threading.Event(), threading.Event()
        self._answers: queue.Queue[str] = queue.Queue()
        self._last_known = (0.0, time.monotonic())   # (longest gap, last write) as last told, for a dead process
        self._thread = threading.Thread(target=self._listen, args=(self._process, self._stop, self._answers),
                                        name="ur3dq-heartbeat", daemon=True)
        self._thread.start()
        first = self._answer(connect_timeout() + START_TIMEOUT)
        if first != "ready":
            self._halt()
            if first.startswith("refused "):
                raise RobotConnectionError(first.removeprefix("refused "))
            raise RobotConnectionError(f"the heartbeat to {self.host}:{RTDE_PORT} did not start: "
                                       f"{first or 'its process ended'}")

    def restart(self) -> None:
        """Reconnect after a failed write (the stream dropped) and beat again; RobotConnectionError if refused."""
        self._halt()
        self.inputs.reconnect()
        self._silenced = False
        self._start()

    def silence(self) -> None:
        """Stop the beats and disconnect, so that the controller's watchdog stops the program armed on them.

        The controller stops that program 1/WATCHDOG_FREQUENCY s after the last beat, at its own stop, whether or
        not this connection still reached it: how ur3dq stops a program once it has lost a connection to the
        controller. `silenced` stays True until restart(), which must not come while that program may still run
        (a new beat would keep it going)."""
        self._silenced = True
        self.close()

    @property
    def silenced(self) -> bool:
        """True from silence() to the next restart()."""
        return self._silenced

    def watch_gaps(self) -> None:
        """From now on, measure the longest time without a write (longest_gap): call it when a motion is sent."""
        self._watched_from = time.monotonic()
        self._tell(f"w {self._watched_from!r}")

    def longest_gap(self) -> float:
        """The longest time (s) without a heartbeat since watch_gaps.

        The longest time (s) since watch_gaps without a write, the time since the last write included, as the
        heartbeat's process measured it. At 1/WATCHDOG_FREQUENCY or more the controller's watchdog may have
        stopped the program: ur3dq was stopped or frozen, the heartbeat's process starved of the CPU, or the
        connection broke."""
        if self.alive:
            with self._ask_lock:
                while not self._answers.empty():   # an answer that came too late to a question before
                    self._answers.get_nowait()
                self._tell("g")
                answer = self._answer(ANSWER_TIMEOUT)
            if answer.startswith("gap "):
                return float(answer.removeprefix("gap "))
        longest, last_write = self._last_known
        return max(longest, time.monotonic() - max(last_write, self._watched_from))

    @property
    def alive(self) -> bool:
        """True while the process runs and its last write went through."""
        return self._thread.is_alive() and not self._failed.is_set()

    def _answer(self, timeout: float) -> str:
        """The process's next line that answers a question ('' when it ended or said nothing within `timeout`)."""
        try:
            return self._answers.get(timeout=timeout)
        except queue.Empty:
            return ""

    def _tell(self, line: str) -> None:
        """One line to the process; dropped when its pipe is full (it is stopped) or closed."""
        with self._pipe_lock:
            pipe = self._process.stdin
            if pipe is None or pipe.closed:
                return
            try:
                os.write(pipe.fileno(), line.encode("ascii") + b"\n")
            except (BlockingIOError, BrokenPipeError):   # a stopped process, or one that ended: its end is heard
                pass

    def _listen(self, process: subprocess.Popen[bytes], stop: threading.Event, answers: queue.Queue[str]) -> None:
        """The heartbeat's thread: tick the process every TICK_PERIOD and hear its lines, until it ends or `stop`."""
        assert process.stdout is not None
        out, pending = process.stdout.fileno(), b""
        while not stop.is_set():
            self._tell("t")
            if not select.select([out], [], [], TICK_PERIOD)[0]:
                continue
            data = os.read(out, 4096)
            if not data:   # the process ended: it wrote its last beat about now, unless it said otherwise
                if not self._failed.is_set():
                    self._last_known = (self._last_known[0], time.monotonic())
                self._failed.set()
                answers.put("")
                return
            *lines, pending = (pending + data).split(b"\n")
            for line in lines:
                self._hear(line.decode("ascii", "replace"), answers)

    def _hear(self, line: str, answers: queue.Queue[str]) -> None:
        if line.startswith("failed "):   # failed <longest gap> <last write> <reason>
            longest, last_write, _ = line.removeprefix("failed ").split(" ", 2)
            self._last_known = (float(longest), float(last_write))
            self._failed.set()
        else:
            answers.put(line)

    def _halt(self) -> None:
        """End the process (its pipe closed: it stops at once) and the thread."""
        self._stop.set()
        with self._pipe_lock:
            if self._process.stdin is not None:
                self._process.stdin.close()
        try:
            self._process.wait(ANSWER_TIMEOUT)
        except subprocess.TimeoutExpired:   # stopped or stuck: it must not beat on
            self._process.kill()
            self._process.wait()
        if self._thread is not threading.current_thread():
            self._thread.join(ANSWER_TIMEOUT)
        if self._process.stdout is not None:
            self._process.stdout.close()

    def close(self) -> None:
        """Stop the beats and disconnect (idempotent). A running program armed on them then stops by itself."""
        self._halt()
        self.inputs.close()
