"""What is known about one sent motion program, decided from the state stream and the robot messages (pure).

A motion is done only on evidence that *this* program ran and ended — its own PROGRAM_XXX_STOPPED key message, or
the state stream showing it running and then not running — with the arm at rest on the target, and the state stream
showing no program running (or another client's, started after it): what a caller reads next agrees with the end.
Being at rest on the target proves nothing by itself: a closed path [B, A] or a zero-length move starts there. A
paused program is neither running on nor ended: the watch waits, and the time it spends paused does not count
against its timeout.
"""
from __future__ import annotations

import queue
import time
from collections.abc import Callable, Iterator
from typing import Protocol

import numpy as np

from ur3dq.errors import MotionTimeoutError, ProgramError, UR3DQError, literal
from ur3dq.robot import primary, state
from ur3dq.units import ANGLE, Measured

#: s a stopped program may take to show the arm at rest before it counts as failed
SETTLE_TIME = 0.3


class GapMeter(Protocol):
    """What the watch asks of the heartbeat its program is armed on (ur3dq.robot.heartbeat.Heartbeat)."""

    def longest_gap(self) -> float: ...


class MotionWatch:
    """One sent program `name` that ends with the arm at joint `target`: started, paused, ended, and the
    controller's errors about it.

    Parameters
    ----------
    name : str
        The program's name (its key messages carry it).
    target : (6,) array
        Where the arm rests when the program has run to its end (rad).
    running_at_send : bool
        Whether a program was running when this one was sent: its "running" flag is not this program's start.
    heartbeat : GapMeter, optional
        The heartbeat the program is armed on; a stop after a gap in it is blamed on the controller's watchdog.
    watchdog_period : float
        The watchdog's period (s): a heartbeat gap at least this long may have stopped the program.
    state_lag : float
        How long (s) after the program's end the state stream may go on delivering states that show a program
        running before it counts as failed (the driver gives it as long as the stream may go without fresh data).
    reported_end : callable, optional
        ``reported_end()`` is True once the program's own reports say it ran its last step (a cell program's step
        reports). Then a program that ended with the arm at rest on the target but without that report was stopped
        short (its path ends where it began, or it stopped within the tolerance of its end): a ProgramError.
    """

    def __init__(self, name: str, target: object, running_at_send: bool, heartbeat: GapMeter | None = None,
                 watchdog_period: float = 0.1, state_lag: float = 1.0,
                 reported_end: Callable[[], bool] | None = None) -> None:
        self.name = name
        self.reported_end = reported_end
        self.state_lag = state_lag
        self.heartbeat = heartbeat
        self.watchdog_period = watchdog_period
        self.target = np.asarray(target, dtype=float)
        self.started = False
        self.stopped = False  # our STOPPED key message arrived
        # A program already running when ours was sent (or its stale flag) is not ours: the state's "running"
        # counts as our start only after the state has shown no program since the send.
        self._running_is_ours = not running_at_send
        self._seen_running = False  # the state stream showed our program running
        self._reported = False  # a key message of our program arrived: a program started after that is another's
        self._ended_on_state = False  # ... and then not running
        self.last_error_text: str | None = None
        self.replaced_by: str | None = None   # the name of a program that started after ours (another client's)
        self.runtime_error: ProgramError | None = None  # raised once the state had time to show a safety stop
        self._ended_at: float | None = None   # when the watch first knew the program had ended
        self._error_at: float | None = None
        self._paused_since: float | None = None   # when the program was seen paused, while it is
        self._paused_total = 0.0
        self._started_after: float | None = None   # s from the send to the first poll that saw it started

    def note_message(self, message: object) -> None:
        """Update from one robot message (key messages, runtime exceptions, error codes)."""
        if primary.is_program_started(message, self.name):
            self.started = self._reported = True
        elif self._reported and isinstance(message, primary.KeyMessage) and message.title.endswith("_STARTED"):
            # Another client's program took over. Not before our own key message: a late key message of an
            # earlier program (one that ended on the state's evidence before its reports came) precedes ours.
            self.replaced_by = self.replaced_by or message.text
        elif primary.is_program_stopped(message, self.name):
            self.started = self.stopped = self._reported = True
        elif isinstance(message, primary.RuntimeExceptionMessage) and self.runtime_error is None:
            self.runtime_error = ProgramError(
                f"the controller reported an error in program {self.name} at line {message.line}, "
                f"column {message.column}: {message.text}")
        elif isinstance(message, primary.ErrorCodeMessage) and message.report_level >= 2:
            self.last_error_text = f"C{message.code}A{message.argument}: {message.text}"

    def distance(self, status: state.RobotStatus) -> float:
        """The largest joint distance (rad) from the arm to the target."""
        return float(np.max(np.abs(status.joints - self.target)))

    @property
    def ended(self) -> bool:
        """True once there is evidence that this program ran and ended."""
        return self.stopped or self._ended_on_state

    @property
    def paused(self) -> bool:
        """True while the last status showed the program paused."""
        return self._paused_since is not None

    def paused_seconds(self, now: float) -> float:
        """How long (s) the program has been paused since it was sent: its timeout stands still meanwhile."""
        return self._paused_total + (now - self._paused_since if self._paused_since is not None else 0.0)

    def check_progress(self, status: state.RobotStatus, elapsed: float, now: float, start_timeout: float,
                       timeout: float, timeout_note: str) -> None:
        """ProgramError when the program has not started `start_timeout` s after it was sent (`elapsed` s ago),
        MotionTimeoutError when it ran past `timeout` s from its start (a controller parses a long program before
        it starts it), the time it spent paused not counted (`timeout_note` says what the timeout holds beyond the
        motion's own duration). None once its STOPPED key message came: what is left, the state showing the end,
        is bounded by `finished` (`state_lag`, SETTLE_TIME) and, on a stream that delivers nothing, by its freeze
        check."""
        if self.stopped:
            return
        if self.started and self._started_after is None:
            self._started_after = elapsed
        if not self.started and not self.paused and elapsed > start_timeout:
            raise ProgramError(f"the controller did not start program {self.name} within {start_timeout:.1f} s")
        running = elapsed - self._started_after if self._started_after is not None else 0.0
        if running - self.paused_seconds(now) > timeout:
            raise MotionTimeoutError(
                f"program {self.name} did not finish within {timeout:.2f} s (derived from its trapezoidal duration "
                f"and the speed slider, {timeout_note}); the arm is {self.distance(status):.4f} rad from target")

    def finished(self, status: state.RobotStatus, now: float) -> bool:
        """True when the program has ended with the arm at rest on target and the state showing no program running
        (or another client's, started after it); ProgramError if it ended elsewhere, the state never showed it
        ended, or the controller reported a runtime error (after SETTLE_TIME, so a safety stop behind it is seen
        first)."""
        if self.runtime_error is not None:
            if self._error_at is None:
                self._error_at = now
            elif now - self._error_at > SETTLE_TIME:
                raise self.runtime_error
            return False
        if status.program_paused and not self.stopped:   # at rest on its path: it goes on when resumed
            if self._paused_since is None:
                self._paused_since = now
            self._ended_at = None
            return False
        if self._paused_since is not None:
            self._paused_total, self._paused_since = self.paused_seconds(now), None
        if status.program_running:
            if self._running_is_ours:
                self.started = self._seen_running = True
            if not self.stopped:
                self._ended_at = None
                return False
        else:
            self._running_is_ours = True
            if self._seen_running:
                self._ended_on_state = True
        if not self.ended:
            return False
        if self._ended_at is None:
            self._ended_at = now
        if self._state_shows_it_running(status, now, self._ended_at):
            return False
        if state.at_rest_at(status, self.target):
            return self._ran_to_its_end()
        # Only a state the stream delivered after the end says where the arm ended: one from before (a frozen
        # stream, garbled on the wire) shows the arm where it was then, and the stream's freeze check reports it.
        if now - self._ended_at > SETTLE_TIME and now - status.age > self._ended_at:
            raise ProgramError(literal(f"program {self.name}") + " ended with the arm {0} from its target"
                               + literal(self._stop_reason()),
                               measured=[Measured(self.distance(status), ANGLE, si_digits=4)])
        return False

    def _ran_to_its_end(self) -> bool:
        """For a program that ended at rest on its target: True when it also reported its end (or reports none);
        False while its reports may still be on their way (its STOPPED key message, which follows them on the same
        stream, has not come: the motion's timeout bounds the wait); ProgramError once that message came first."""
        if self.reported_end is None or self.reported_end():
            return True
        if not self.stopped:
            return False
        raise ProgramError(f"program {self.name} ended before it reported its last step, with the arm at rest where "
                           "the program ends" + self._stop_reason())

    def _state_shows_it_running(self, status: state.RobotStatus, now: float, ended_at: float) -> bool:
        """True while the state stream still shows a program running after this one ended (at `ended_at`, as far as
        the watch knows).

        The controller's key message announces the end a state cycle (RTDE: 2-8 ms; the primary interface: up to
        0.1 s) before the stream agrees, and a caller reading the state next must find the program ended. A program
        another client started after it (its key message) is not this one: the state then rightly shows it
        running. A state showing none running agrees once the stream has shown this program running, else only
        when it was delivered after the end (a program shorter than a state cycle may show in one state only, still
        on its way). ProgramError when a state the stream delivered `state_lag` s after the end still shows
        one running (a frozen stream delivers none: its freeze check reports it)."""
        if self.replaced_by is not None:
            return False
        delivered = now - status.age
        if not status.program_running:
            return not self._seen_running and delivered <= ended_at
        if delivered > ended_at + self.state_lag:
            raise ProgramError(f"program {self.name} ended, but the controller's state still showed a program "
                               f"running {self.state_lag:g} s after its end, and no other program's start was "
                               "reported: the state stream lags far behind the controller, or a program started "
                               "unannounced; check the link and the controller's program (`ur3dq status`), then go on")
        return True

    def _stop_reason(self) -> str:
        """What ended the program short of its target, as far as ur3dq can tell: the controller's error, another
        client's program that started after it, the heartbeat watchdog when the heartbeat went a watchdog period
        without a write, else a stop without an error (the controller's key message does not say why a program
        stopped)."""
        if self.last_error_text:
            return f": {self.last_error_text}"
        if self.replaced_by is not None:
            return (f": another client replaced it with its own program {self.replaced_by!r} (a controller runs one "
                    "program at a time)")
        gap = self.heartbeat.longest_gap() if self.heartbeat is not None else 0.0
        if gap >= self.watchdog_period:
            return (f": most likely the controller's heartbeat watchdog (ur3dq's heartbeat wrote nothing for "
                    f"{gap:.3f} s; the watchdog stops a program after {self.watchdog_period:g} s): this computer "
                    "was too busy to keep the heartbeat; end what loads it, then go on")
        return (": the controller stopped it without an error, as when another client stops the program (a "
                "dashboard or pendant stop)")


def last_reports(watcher: queue.Queue[object], outcome: MotionWatch, on_message: Callable[[object], None],
                 wait: float) -> None:
    """After a failed or interrupted program: hand `on_message` the messages it sent up to its end (its STOPPED key
    message; at most `wait` s), so a caller following its reports (the step it had reached) misses none. The driver
    calls it with Ctrl-C taken at its polls (ur3dq.robot.interrupts): a second Ctrl-C does not cut it short."""
    deadline = time.monotonic() + wait
    while not outcome.stopped and time.monotonic() < deadline:
        for message in drain(watcher):
            outcome.note_message(message)
            try:
                on_message(message)
            except UR3DQError:
                pass
        time.sleep(0.01)


def drain(watcher: queue.Queue[object]) -> Iterator[object]:
    """Every message waiting in `watcher`, without blocking."""
    while True:
        try:
            yield watcher.get_nowait()
        except queue.Empty:
            return
