"""One URScript thread as it runs: its scheduling (the scheduler lock, time slices, frames), its waits for
controller time and motions, and its cancellation. The interpreter (sim_ursim.urscript.interpreter) makes one
ThreadContext per script thread; every built-in receives the calling thread's.

Scheduling is described in the interpreter's module docstring: a thread holds its Execution's scheduler lock while
it runs statements and gives it up while it waits for physical time.
"""
import contextlib
import threading
from collections.abc import Callable, Iterator
from typing import Any

from sim_ursim.motion_queue import Motion
from sim_ursim.urscript.values import ScriptError
from sim_ursim.vocabulary import ControllerState

STATEMENTS_PER_SECOND = 25_000  # computation a script thread may do per second of controller time (see above)
MIN_STATEMENTS_PER_FRAME = 200  # a controller runs a URCL spline step (~55 statements) within a 2 ms frame
MOTION_WAIT_CHECK = 0.05  # s: a thread waiting for a motion looks at its cancel flag at least this often


class Cancelled(Exception):
    """The running thread was killed or its program stopped/replaced."""


class ThreadContext:
    """One script thread's state: its cancel event, call frames and critical-section depth. Built-ins receive it."""

    def __init__(self, execution: Any, name: str):
        self.execution = execution
        self.controller = execution.controller
        self.name = name
        self.cancel = threading.Event()  # set through request_cancel(), which also wakes a wait_for_motion()
        self.done = threading.Event()
        self._wake = threading.Event()  # set when the motion this thread waits for ends, or it is cancelled
        self.frames: list[dict[str, object]] = []  # one dict of locals per active function call / thread body
        self.critical = 0
        self.line = 0  # line of the statement being executed
        self.motion: Motion | None = None  # the Motion this thread is waiting for, if any
        self.last_timeout: str | None = None  # its last blocking read, if it timed out: explains a later halt
        self.running = False  # running statements (holding the scheduler), not waiting for anything
        self.awaiting_hold: Motion | None = None  # the held speedj/speedl Motion it waits for (builtins.motion)
        self.wakes_when: Callable[[ControllerState], bool] | None = None  # the cycle a sleep or sync waits for
        self._statements_in_slice = 0
        self._slice = max(MIN_STATEMENTS_PER_FRAME, int(STATEMENTS_PER_SECOND * execution.controller.period))

    # --- scheduling, used by the interpreter and by blocking built-ins
    def owes_frame(self) -> bool:
        """True while this thread runs statements, or what it waits for has come and it has not run since: its held
        speed command or its move is over, the cycle its sleep or sync waits for is out (cycle_clock.FrameTurn)."""
        hold, motion, wakes_when = self.awaiting_hold, self.motion, self.wakes_when
        return self.running or (hold is not None and hold.done) or (motion is not None and motion.done) or (
            wakes_when is not None and wakes_when(self.controller.state()))

    def set_running(self, running: bool) -> None:
        """This thread starts or stops running statements (the control loop's FrameTurn is told)."""
        self.running = running
        self.controller.frame_turn.changed(self)

    def request_cancel(self) -> None:
        """Kill this thread (or stop its program): it raises Cancelled when it next checks; a motion wait ends now."""
        self.cancel.set()
        self._wake.set()

    def wait_for_motion(self, motion: Motion) -> None:
        """Block until `motion` ends or this thread is cancelled: either wakes it (no polling every cycle)."""
        self._wake.clear()
        motion.wake_on_end(self._wake)
        while not motion.done and not self.cancel.is_set():
            self._wake.wait(MOTION_WAIT_CHECK)
            self._wake.clear()

    def check(self) -> None:
        """Raise Cancelled if this thread was killed or its program stopped; block while the program is paused."""
        if self.cancel.is_set():
            raise Cancelled()
        if not self.execution.unpaused.is_set():
            with self.waiting():
                while not self.execution.unpaused.wait(0.05):
                    if self.cancel.is_set():
                        break
            if self.cancel.is_set():
                raise Cancelled()

    @contextlib.contextmanager
    def waiting(self, keep_scheduler: bool = False) -> Iterator[None]:
        """Context manager: let other script threads run while this one waits for physical time (scheduler lock
        released unless `keep_scheduler`, not running). The main thread's line is published (RTDE
        script_control_line) here, where it stays for a while, rather than on every statement."""
        if self is self.execution.main:
            self.controller.set_script_control_line(self.line)
        self._statements_in_slice = 0  # physical time passes: a new slice starts
        self.set_running(False)
        if not keep_scheduler:
            self.execution.scheduler.release()
        try:
            yield
        finally:
            if not keep_scheduler:
                self.execution.scheduler.acquire()
            self.set_running(True)

    def time_slice(self):
        """Count one statement; a thread that used up its slice waits for the next frame (see module docstring)."""
        self._statements_in_slice += 1
        if self._statements_in_slice < self._slice:
            return
        # inside a critical section the thread keeps the scheduler lock: no other thread runs meanwhile
        self.sync(keep_scheduler=bool(self.critical))

    def sleep(self, seconds: float) -> None:
        """Wait `seconds` of controller time, whole cycles (late on a late host, like the arm), interruptibly."""
        end = self.controller.state().timestamp + seconds - 1e-9
        self._wait_for_cycle(lambda state: state.timestamp >= end, seconds)

    def sync(self, keep_scheduler: bool = False) -> None:
        """Wait for the next control cycle (the rest of this one is used up)."""
        now = self.controller.state().cycle
        self._wait_for_cycle(lambda state: state.cycle > now, self.controller.period, keep_scheduler)

    def _wait_for_cycle(self, wakes_when: Callable[[ControllerState], bool], seconds: float,
                        keep_scheduler: bool = False) -> None:
        """Wait until a published cycle satisfies `wakes_when` (owes_frame reads it), or `seconds` without a loop."""
        self.wakes_when = wakes_when
        with self.waiting(keep_scheduler):
            state = self.controller.state()
            while not wakes_when(state) and not self.cancel.is_set():
                if not self.controller.running:   # no cycle will come: wall time instead
                    self.cancel.wait(seconds)
                    break
                state = self.controller.wait_cycle(state.cycle, timeout=0.05)
        self.wakes_when = None
        self.check()

    def run_motion(self, command: Callable[[], Motion]) -> None:
        """Issue a motion with `command()` (returns a Motion) and block until it is done, interruptibly.

        ScriptError with the motion's error if it failed. A motion cut short because the program was paused (the
        runner brings the arm to rest) is commanded again from where the arm stopped once the program resumes.
        """
        while True:
            motion = command()
            self.motion = motion
            with self.waiting():
                self.wait_for_motion(motion)  # a stop/kill/new program cancels the thread and ends the wait at once
                if motion.done:
                    # The motion ends inside a control cycle whose snapshot is published just after: wait for it,
                    # so the next get_actual_* sees where the move ended.
                    self.controller.await_published()
            self.motion = None
            paused_meanwhile = motion.error is not None and not self.execution.unpaused.is_set()
            self.check()  # raises if cancelled; blocks while paused
            if paused_meanwhile:
                continue
            if motion.error:
                raise ScriptError(motion.error)
            return

    def publish(self, message: object) -> None:
        """Send a robot message to the primary interface's subscribers."""
        self.controller.messages.publish(message)
