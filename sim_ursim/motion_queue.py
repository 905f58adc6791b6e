"""The motion queue of the simulated arm: the active segment, a blended tail, the planned moves waiting.

Each commanded motion has a `Motion` handle the caller waits on. Planned moves (movej, movel) queue and start one
after another; a blend radius r > 0 lets the next move start inside the previous one's blend zone, superposed on
the rest of it in joint space (q = q_rest + q_next − q_next_start), so speed stays continuous and the arm ends
exactly on the next target (the blend path is not the controller's). Streaming commands (speedj, speedl, servoj)
replace whatever runs; stops replace every motion by a deceleration to rest.

Not thread-safe on its own: the controller calls it under its lock, once per control cycle (`advance`) and from
its commands. Segments come from trajectories.py.
"""
import dataclasses
import logging
import threading
import time
from collections.abc import Callable
from typing import TypeAlias

import numpy as np

from . import kinematics, trajectories
from .models import RobotModel
from .vocabulary import PROTECTIVE_STOP_DECELERATION

log = logging.getLogger("sim_ursim.controller")

JOINT_SPEED_TOLERANCE = 1.05  # movel/speedl may exceed a joint's max speed by 5 % before the protective stop


# The robot error code of a protective stop: (code, argument) of the primary port's error-code message, shown as
# C<code>A<argument>. A Cartesian move whose joints would outrun their speed limit (the arm near a singularity)
# stops with C204, the controller's "path sanity check" family (UR forum: C204A1 "sudden change in target
# position", C204A6 blending failures; C204A3 is what a UR3 reported when its trajectories stopped in
# ros-industrial/universal_robot#345). UR does not publish which sub-code is "close to singularity"; A3 is ours.
SINGULARITY_STOP_CODE = (204, 3)
DEFAULT_STOP_CODE = (209, 0)

#: A move that queues and blends (movej, movel), and every segment a MotionEntry runs (streaming and stops too).
PlannedMove: TypeAlias = trajectories.JointMove | trajectories.LinearMove
Segment: TypeAlias = (PlannedMove | trajectories.JointSpeed | trajectories.CartesianSpeed | trajectories.ServoTarget
                      | trajectories.Stop)


class MotionFault(Exception):
    """A running motion must end in a protective stop: `reason` for the stop, `program_reason` for the program,
    `code` the (code, argument) of the robot error message."""

    def __init__(self, reason: str, program_reason: str, code: tuple = DEFAULT_STOP_CODE):
        super().__init__(reason)
        self.reason = reason
        self.program_reason = program_reason
        self.code = code


class Motion:
    """Handle of one commanded motion: `wait()` for its end, then read `error` (None when it succeeded)."""

    def __init__(self, kind: str, blend_radius: float = 0.0):
        self.kind = kind
        self.blend_radius = blend_radius
        self.error: str | None = None
        self._ended = threading.Event()
        self._wake_on_end: list[threading.Event] = []  # events of waiters to set when the motion ends

    @property
    def done(self) -> bool:
        """True once the motion has ended, successfully or not (see `error`)."""
        return self._ended.is_set()

    @property
    def succeeded(self) -> bool:
        """True once the motion has ended without error."""
        return self._ended.is_set() and self.error is None

    def wait(self, timeout: float | None = None, cancel: threading.Event | None = None) -> bool:
        """Block until the motion ends (True), or `timeout` s pass / `cancel` is set (False). Does not stop the arm."""
        if cancel is None:
            return self._ended.wait(timeout)
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._ended.is_set():
            if cancel.is_set():
                return False
            remaining = 0.05 if deadline is None else min(0.05, deadline - time.monotonic())
            if remaining <= 0:
                return False
            self._ended.wait(remaining)
        return True

    def wake_on_end(self, event: threading.Event) -> None:
        """Set `event` when the motion ends (at once if it has): a waiter for several things waits on one event."""
        self._wake_on_end.append(event)
        if self._ended.is_set():
            event.set()

    def _finish(self, error: str | None = None) -> None:
        if not self._ended.is_set():
            self.error = error
            self._ended.set()
            for event in list(self._wake_on_end):
                event.set()

    def __repr__(self) -> str:
        status = "running" if not self.done else ("ok" if self.error is None else f"failed: {self.error}")
        return f"<Motion {self.kind} {status}>"


@dataclasses.dataclass
class MotionEntry:
    """A segment being executed, the Motion it reports to, and whether trajectory time follows the slider."""

    segment: Segment | None  # None for a planned move until it starts (`plan` builds it)
    motion: Motion
    follows_slider: bool
    target_q: np.ndarray | None = None  # planned moves: where the arm ends (for blending and queued starts)
    plan: Callable[[np.ndarray], PlannedMove] | None = None  # planned moves: start_q -> segment, when it starts
    in_blend_zone: bool = False
    tcp_matrix: Callable[[np.ndarray], np.ndarray] | None = None  # planned moves: the TCP of their command



class MotionQueue:
    """The arm's motions (see the module docstring); each planned move measures its blend zone at the TCP of its
    command (MotionEntry.tcp_matrix)."""

    def __init__(self, model: RobotModel):
        self.model = model
        self.active: MotionEntry | None = None
        self.tail: MotionEntry | None = None  # a move still finishing underneath its blended successor
        self.waiting: list[MotionEntry] = []  # planned moves waiting for the current one

    @property
    def busy(self) -> bool:
        """True while a motion (or the rest of a blended one) runs."""
        return self.active is not None or self.tail is not None

    def end_q(self, q_now: np.ndarray) -> np.ndarray:
        """Where the arm will be when a newly queued move starts: the last queued/active target, else q_now."""
        for entry in reversed(self.waiting):
            assert entry.target_q is not None   # a queued move is a planned one, with its target
            return entry.target_q
        if self.active is not None and self.active.target_q is not None:
            return self.active.target_q
        return np.array(q_now)

    def enqueue(self, entry: "MotionEntry", plan: Callable[[np.ndarray], PlannedMove], q_now: np.ndarray,
                qd_now: np.ndarray) -> None:
        """Queue a planned move; `plan(start_q)` builds its segment when it starts."""
        entry.plan = plan
        streaming = self.active is not None and self.active.target_q is None
        if streaming:
            # A speed/servo command is running: bring it to rest first, then the move starts.
            self.stop(qd_now, PROTECTIVE_STOP_DECELERATION, entry.motion.kind, end_queue=False)
        self.waiting.append(entry)
        if self.active is None:
            self._start_next(np.array(q_now), blended=False)

    def _start_next(self, start_q: np.ndarray, blended: bool) -> None:
        """Start the first queued move from start_q (superposed on the current one when blended)."""
        entry = self.waiting.pop(0)
        assert entry.plan is not None   # enqueue gives every waiting move its plan
        try:
            entry.segment = entry.plan(start_q)
        except (ValueError, kinematics.IKError) as error:
            reason = str(error)   # `error` is unbound once the except block ends; the callback must not need it
            entry.motion._finish(reason)
            self.end_all(lambda queued: f"not started: an earlier move failed ({reason})")
            return
        if blended:
            self.tail = self.active
        self.active = entry
        log.info("%s started (%.3f s planned)", entry.motion.kind, entry.segment.profile.duration)

    def speed_ramp_start(self, kind: str, measured: np.ndarray) -> np.ndarray:
        """Where a new speedj/speedl ramp starts: the running command's own ramp when it is the same kind, else
        the measured speed.

        Clients repeat speed commands every cycle or two (ur_rtde's speed thread does): continuing the commanded
        ramp keeps them exact, whereas the measured speed already includes the speed slider (each restart would
        shrink it again) and any measurement error.
        """
        segment = self.active.segment if self.active is not None and self.tail is None else None
        if isinstance(segment, (trajectories.JointSpeed, trajectories.CartesianSpeed)) and segment.kind == kind:
            return segment.commanded_speed
        return np.array(measured, dtype=float)

    def replace(self, segment: trajectories.JointSpeed | trajectories.CartesianSpeed | trajectories.ServoTarget,
                kind: str, follows_slider: bool) -> Motion:
        """Streaming commands (speedj, speedl, servoj) take over at once from whatever runs. A held speed command
        first uses the time its thread's previous one left in the cycle just moved (trajectories.SpeedRamp); when
        that covers all of it, its Motion is over at once."""
        ramp = segment if isinstance(segment, trajectories.SpeedRamp) else None
        unused = self._unused_time_of(None if ramp is None else ramp.hold_owner)
        self.end_all(lambda entry: None if entry.motion.kind == kind else f"interrupted by {kind}")
        self.tail = None
        entry = MotionEntry(segment, Motion(kind), follows_slider)
        self.active = entry
        if ramp is not None and unused > 0:
            ramp.start_within(unused)
            if ramp.holding:
                entry.motion._finish(None)
        return entry.motion

    def _unused_time_of(self, owner: object) -> float:
        """What `owner`'s held speed command left of the cycle just moved (0 for anything else)."""
        active = self.active
        if owner is None or active is None or self.tail is not None:
            return 0.0
        if not isinstance(active.segment, trajectories.SpeedRamp) or active.segment.hold_owner is not owner:
            return 0.0
        return active.segment.unused_time

    def stop(self, qd: np.ndarray, deceleration: float, kind: str, end_queue: bool = True,
             error: str | None = None) -> Motion:
        """Replace every motion by a deceleration to rest from joint speeds qd; returns the stop's Motion.

        The ended motions fail with `error` (default "stopped by <kind>"); with end_queue=False the waiting moves
        stay queued.
        """
        error = error or f"stopped by {kind}"
        if end_queue:
            self.end_all(lambda entry: error)
        else:
            for entry in (self.tail, self.active):
                if entry is not None:
                    entry.motion._finish(error)
        entry = MotionEntry(trajectories.Stop(qd, deceleration), Motion(kind), False)
        self.active = entry
        self.tail = None
        return entry.motion

    def clear(self, error: str) -> None:
        """Every motion ends with `error` and nothing runs any more (halt, power off, shutdown)."""
        self.end_all(lambda entry: error)
        self.active = None
        self.tail = None

    def end_all(self, error_of: Callable[["MotionEntry"], str | None]) -> None:
        """End every motion, each with the error `error_of(entry)` (None: succeeded); the queue empties."""
        for entry in [self.tail, self.active] + self.waiting:
            if entry is not None:
                entry.motion._finish(error_of(entry))
        self.waiting = []

    def advance(self, q: np.ndarray, dt: float, planned_dt: float) -> np.ndarray:
        """Joints after one cycle of the active motion from q (call only while `active`).

        `planned_dt` is dt scaled by the speed slider and the pause ramp (planned and slider-following motions use
        it). Raises MotionFault when the step would cross a joint limit, exceed a joint speed limit on a
        Cartesian motion, or has no IK solution; the arm then stays at q.
        """
        active = self.active
        assert active is not None and active.segment is not None   # called only while a motion runs
        try:
            new_q = active.segment.advance(planned_dt if active.follows_slider else dt, q)
            if self.tail is not None:
                # Blend: the rest of the previous move plus this move's displacement from its own start.
                tail = self.tail
                # only planned moves blend: both the tail and the move started inside its blend zone
                assert isinstance(tail.segment, PlannedMove) and isinstance(active.segment, PlannedMove)
                new_q = tail.segment.advance(planned_dt) + (new_q - active.segment.q_start)
                if tail.segment.finished:
                    self.tail = None
        except kinematics.IKError as error:
            raise MotionFault(f"{active.motion.kind}: {error}", f"{active.motion.kind} failed") from None
        violation = self._step_violation(q, new_q, dt, active)
        if violation is not None:
            reason, code = violation
            raise MotionFault(reason, reason, code)
        self._finish_or_blend(active, new_q)
        return new_q

    def _step_violation(self, q, new_q, dt, active) -> tuple | None:
        """(why, error code) when a step breaks joint-limit or (Cartesian motions) joint-speed protection; None
        when it does not."""
        outside = np.nonzero((new_q < self.model.joint_lower) | (new_q > self.model.joint_upper))[0]
        if outside.size:
            return f"joint {int(outside[0])} position limit reached during {active.motion.kind}", DEFAULT_STOP_CODE
        if active.segment.kind in ("movel", "speedl"):
            speeds = np.abs(new_q - q) / dt
            too_fast = np.nonzero(speeds > self.model.max_joint_speed * JOINT_SPEED_TOLERANCE)[0]
            if too_fast.size:
                i = int(too_fast[0])
                return (f"close to singularity: joint {i} speed {speeds[i]:.2f} rad/s above its limit during "
                        f"{active.motion.kind}", SINGULARITY_STOP_CODE)
        return None

    def holding_owner(self) -> object:
        """The script thread whose held speedj/speedl has moved its time and waits for that thread's next command
        (trajectories.SpeedRamp), or None."""
        active = self.active
        if active is None or self.tail is not None or not isinstance(active.segment, trajectories.SpeedRamp) \
                or not active.segment.holding:
            return None
        return active.segment.hold_owner

    def release_hold(self, owner: object) -> None:
        """The script thread `owner` will not follow its held speedj/speedl with another command
        (trajectories.SpeedRamp)."""
        active = self.active
        if active is not None and isinstance(active.segment, trajectories.SpeedRamp) \
                and active.segment.hold_owner is owner:
            active.segment.release()

    def _finish_or_blend(self, active, new_q) -> None:
        """End a finished segment and start the next queued one; with r > 0 start it inside the blend zone."""
        if getattr(active.segment, "holding", False):
            # A script's speedj/speedl has moved its time t: the command returns, the arm waits for the thread's next.
            active.motion._finish(None)
            return
        if active.segment.finished and self.tail is None:
            active.motion._finish(None)
            self.active = None
            if self.waiting:
                self._start_next(new_q, blended=False)
            return
        if active.target_q is None or active.motion.blend_radius <= 0:
            return
        if not active.in_blend_zone:
            assert active.tcp_matrix is not None   # a planned move carries its command's TCP
            here = active.tcp_matrix(new_q)[:3, 3]
            there = active.tcp_matrix(active.target_q)[:3, 3]
            if float(np.linalg.norm(there - here)) > active.motion.blend_radius:
                return
            # Inside the blend zone the program may go on (the URScript move returns) while the arm continues.
            active.in_blend_zone = True
            active.motion._finish(None)
        if self.waiting and self.tail is None:
            self._start_next(active.target_q, blended=True)
