"""The driver's jog: one checked motion along one axis, a step run to its end or a held jog kept alive by its operator.

A jog (ur3dq.robot.jog_steps.JogStep) is one URScript program from the arm's joints towards a target along one axis:
a joint (movej of that joint alone) or a TCP axis of the base or tool frame (movel: a straight line, or a turn about
the TCP), its size or, held, as far as the checks let it go (jog_steps.HELD_*). The whole path is checked before
anything is sent: joint limits, the travel bound, FK, and the path check (self-collision, singularities, reach,
joint speeds, and the cell the robot requires or the Jog was given). A held jog that fails is shortened to the
longest part that passes (bisection); a step that fails is refused, as is a held jog with nothing left that passes.

Two ways to run one, the same program and checks:

- `run(step, speed)`: a bounded step watched to its end, so nothing moves once it returns (Robot.jog: a key of
  `ur3dq jog`).
- `start(step, speed)`: the program also arms a second controller watchdog, KEEPALIVE_REGISTER at
  KEEPALIVE_FREQUENCY, which the operator feeds with `keep_alive()` (a page's heartbeat) at least every
  1/KEEPALIVE_FREQUENCY s; when that stops (the page, the server or the network gone) the controller stops the
  program. Releasing the button is `stop()`: stopj at STOP_DECELERATION. It runs as a watched motion in a thread of
  the Jog's own; every program is also armed on the driver's heartbeat, as every ur3dq motion.

Example
-------
>>> from ur3dq.robot.jog_steps import JogStep
>>> JogStep("Z", -1, 0.01, frame="tool").label               # 10 mm down the tool's z
'Z-'
>>> robot.jog(JogStep("J1", +1, 0.01), speed=0.2)            # doctest: +SKIP
>>> jog = Jog(robot)                                         # doctest: +SKIP
>>> jog.start(JogStep("J1", +1), speed=0.2)                  # doctest: +SKIP
>>> while held(): jog.keep_alive(); time.sleep(0.05)         # doctest: +SKIP
>>> jog.stop()                                               # doctest: +SKIP
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import threading
from collections.abc import Callable
from typing import Protocol

import numpy as np

from ur3dq import urscript
from ur3dq.errors import RobotConnectionError, RobotError, SafetyCheckError, UnreachablePoseError, literal
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import Cell, Margins, PathPlan, PathSegment, check_path
from ur3dq.robot import interrupts, safety
from ur3dq.robot.jog_steps import JOINT_AXES, JogStep, step_target
from ur3dq.robot.motion import trapezoid_duration
from ur3dq.robot.rtde_inputs import RTDEInputs
from ur3dq.units import Wording

#: The RTDE input integer register the operator's keep-alive is written to (this client holds 18-22; 20 beats).
KEEPALIVE_REGISTER = 21
#: The operator's keep-alive must come at least this often: 250 ms of silence stops a held jog.
KEEPALIVE_FREQUENCY = 4.0
ENDED_WAIT = 2.0                  # s a stopped jog's watch may take to end (its settle time and poll)
STOP_DECELERATION = 10.0          # rad/s² of the stopj that ends a released jog
LIMIT_ROOM = math.radians(0.5)    # a held joint jog stops this far from its limit
SHORTEST = (math.radians(0.05), 0.0005)   # (rad, m): a held jog shorter than this is refused
BISECTIONS = 10                   # halvings of a failing held jog in search of the longest that passes


class JogArm(Protocol):
    """What a Jog needs of its robot (ur3dq.robot.Robot)."""

    host: str
    model: URModel
    max_joint_travel: float

    @property
    def inputs(self) -> RTDEInputs: ...

    @property
    def required_path_check(self) -> tuple[Cell | None, Margins] | None: ...

    def joints(self) -> np.ndarray: ...

    def run_script(self, name: str, program: str, target: np.ndarray, duration: float,
                   on_message: Callable[[object], None] | None = None, reached_end: Callable[[], bool] | None = None,
                   path: PathPlan | None = None, on_sent: Callable[[], None] | None = None) -> float: ...

    def stop(self, a: float = ...) -> None: ...


@dataclasses.dataclass(frozen=True)
class JogPlan:
    """A checked jog: its step and speed, its move ('joint' or 'linear'), start and end joints (6,), the distance it
    goes (rad or m) and what the checks shortened it for (`limited_by`, None when it goes the whole way)."""

    step: JogStep
    speed: float
    move: str
    start: np.ndarray
    joints: np.ndarray
    distance: float
    limited_by: str | None

    @property
    def segment(self) -> PathSegment:
        """The jog as the path check sees it."""
        return PathSegment(f"jog {self.step.label}", self.move, target_joints=self.joints, speed=self.speed,
                           acceleration=self.step.acceleration)

    def program(self, keep_alive: bool) -> tuple[str, str]:
        """(name, URScript program) of the jog; `keep_alive` arms the operator's watchdog first."""
        name = urscript.new_program_name("jog")
        linear = self.move == "linear"
        move = urscript.move_statement("movel" if linear else "movej", self.joints, self.step.acceleration,
                                       self.speed, t=0 if linear else None)
        watchdog = [urscript.rtde_set_watchdog_statement(f"input_int_register_{KEEPALIVE_REGISTER}",
                                                         KEEPALIVE_FREQUENCY, "stop")] if keep_alive else []
        return name, urscript.program(name, [*watchdog, move])


class Jog:
    """Jogs of one connected robot, checked in `cell` with `margins` (neither given: in what the robot requires,
    Robot.require_path_check, else without a cell)."""

    def __init__(self, robot: JogArm, cell: Cell | None = None, margins: Margins | None = None) -> None:
        self.robot = robot
        required = robot.required_path_check if cell is None and margins is None else None
        self.cell, self.margins = required if required is not None else (cell, margins or Margins())
        self._beats = itertools.count(1)
        self._released = False
        self._ended: threading.Event | None = None
        self.active: JogPlan | None = None
        self.failed: list[RobotError] = []   # the last jog's failure, if it ended for another reason than stop()

    # ------------------------------------------------------------------------------------------------ planning
    def plan(self, step: JogStep, speed: float, start: np.ndarray | None = None) -> JogPlan:
        """The checked jog of `step` at `speed` (rad/s, or m/s for X Y Z; capped at the jog's limit) from joints
        `start` (default: the arm's); SafetyCheckError naming what stops it."""
        if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not (math.isfinite(speed) and speed > 0):
            raise SafetyCheckError(f"jog speed must be a number > 0, got {speed!r}")
        speed = min(float(speed), step.top_speed)
        q0 = np.asarray(self.robot.joints() if start is None else start, dtype=float)
        wanted, limited_by = step.distance, None
        if step.joint_mode:
            room = self._joint_room(q0, JOINT_AXES.index(step.axis), step.direction, step.held)
            if room < wanted:
                wanted, limited_by = room, f"the joint limit of {step.axis}"
        move = "joint" if step.joint_mode else "linear"
        shortest = SHORTEST[1 if step.linear else 0]
        if limited_by is not None and (not step.held or wanted < shortest):
            raise SafetyCheckError(f"jog {step.label}: the arm cannot move that way: {limited_by}")
        joints, problem, fraction = self._try(step, speed, q0, wanted)
        if joints is not None:
            return JogPlan(step, speed, move, q0, joints, wanted, limited_by)
        if not step.held:
            raise _refused(step, problem)
        # The longest jog that passes, by bisection: every distance that reaches the failing sample fails.
        best, low, high = None, 0.0, wanted * (fraction if fraction is not None else 1.0)
        for _ in range(BISECTIONS):
            middle = (low + high) / 2
            if middle < shortest:
                break
            joints, failed, fraction = self._try(step, speed, q0, middle)
            if joints is not None:
                best, low = (joints, middle), middle
            else:
                problem, high = failed, middle * (fraction if fraction is not None else 1.0)
        if best is None:
            raise _refused(step, problem)
        return JogPlan(step, speed, move, q0, best[0], best[1], "the path check")

    def _joint_room(self, q0: np.ndarray, joint: int, direction: int, held: bool) -> float:
        """How far (rad) joint `joint` may turn in `direction` before its limit (less LIMIT_ROOM when `held`)."""
        model = self.robot.model
        limit = model.joint_upper[joint] if direction > 0 else model.joint_lower[joint]
        room = float(abs(limit - q0[joint])) - (LIMIT_ROOM if held else 0.0)
        return max(room, 0.0) if math.isfinite(limit) else math.inf

    def _try(self, step: JogStep, speed: float, q0: np.ndarray, distance: float) -> tuple[
            np.ndarray | None, Wording | None, float | None]:
        """(end joints, None, None) when the jog of `distance` passes every check, else (None, the first problem's
        wording (units.worded text, values), the fraction of the move where it is, or None when the end cannot be
        reached at all)."""
        model = self.robot.model
        try:
            move, joints, pose = step_target(model, q0, step, distance)
            if pose is not None:
                safety.check_fk_consistency(model, joints, pose, name="target")
            safety.check_travel(q0, joints, self.robot.max_joint_travel, name="target")
        except (UnreachablePoseError, SafetyCheckError) as error:
            return None, error.wording(), None
        segment = PathSegment(f"jog {step.label}", move, target_joints=joints, speed=speed,
                              acceleration=step.acceleration,
                              target_pose=None if pose is None else pose.to_array())
        result = check_path(model, PathPlan(q0, (segment,)), self.cell, self.margins, keep_samples=False)
        if result.ok:
            return joints, None, None
        first = min(result.problems, key=lambda problem: problem.fraction)
        return None, (first.what, first.measured), first.fraction

    # ------------------------------------------------------------------------------------------------ motion
    def _send(self, plan: JogPlan, keep_alive: bool, on_sent: Callable[[], None] | None = None) -> float:
        """Send the jog of `plan` and watch it to its end (run_script: every check the driver makes); the wall time."""
        name, program = plan.program(keep_alive)
        duration = trapezoid_duration(plan.distance, plan.step.acceleration, plan.speed)
        return self.robot.run_script(name, program, plan.joints, duration, path=PathPlan(plan.start, (plan.segment,)),
                                     on_sent=on_sent)

    def run(self, step: JogStep, speed: float) -> float:
        """Plan the bounded jog `step` at `speed` and run it to its end (nothing moves once it returns); the wall
        time (s). SafetyCheckError when it cannot go its whole step, RobotError when it does not end there."""
        if step.held:
            raise SafetyCheckError(f"jog {step.label}: a held jog needs its operator's keep-alive (Jog.start)")
        self.wait_ended()
        return self._send(self.plan(step, speed), keep_alive=False)

    def start(self, step: JogStep, speed: float) -> JogPlan:
        """Plan the jog of `step` at `speed` and send it with the keep-alive watchdog armed; returns once it is on
        its way (the arm moves until stop(), the keep-alive stopping, or the planned end). SafetyCheckError and
        RobotError when it cannot start."""
        self.wait_ended()
        plan = self.plan(step, speed)
        self.keep_alive()
        self._released = False
        sent, ended, failed = threading.Event(), threading.Event(), []

        def run() -> None:
            try:
                self._send(plan, keep_alive=True, on_sent=sent.set)
            except RobotError as error:      # a release ends the jog short of its target: that is no failure
                if not (sent.is_set() and self._released):
                    failed.append(error)
            finally:
                ended.set()

        self._ended = ended
        threading.Thread(target=run, name="ur3dq-jog", daemon=True).start()
        with interrupts.at_polls():   # a Ctrl-C inside the events' own locks would leave the jog's thread stuck
            while not (sent.wait(0.01) or ended.is_set()):
                interrupts.check()
        if failed and not sent.is_set():
            raise failed[0]
        self.failed, self.active = failed, plan
        return plan

    def keep_alive(self) -> None:
        """The operator is still there: write the keep-alive register (call at least every 1/KEEPALIVE_FREQUENCY
        s while a started jog may run)."""
        if not self.robot.inputs.set_int_register(KEEPALIVE_REGISTER, next(self._beats) % 2 ** 31):
            raise RobotConnectionError(f"cannot write the jog's keep-alive to the RTDE inputs of {self.robot.host}")

    def stop(self) -> None:
        """Stop the arm now (stopj at STOP_DECELERATION): the button was released. Returns once the jog's watch has
        ended (≤ ENDED_WAIT s), so that no later motion is taken for it."""
        self._released = True
        self.active = None
        self.robot.stop(STOP_DECELERATION)
        self.wait_ended()

    def wait_ended(self) -> None:
        """Wait (≤ ENDED_WAIT s) until the last jog's watch has ended: its stop of a failed motion must not fall on
        the next one."""
        if self._ended is not None:
            self._ended.wait(ENDED_WAIT)


def _refused(step: JogStep, problem: Wording | None) -> SafetyCheckError:
    """The error refusing the jog `step` for `problem` (units.worded text, values): its numbers read in the units of
    whoever shows it (UR3DQError.shown_in)."""
    assert problem is not None, "a refused jog has a problem"
    text, measured = problem
    return SafetyCheckError.from_wording(literal(f"jog {step.label}: the arm cannot move that way: ") + text, measured)
