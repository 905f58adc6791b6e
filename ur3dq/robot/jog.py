"""Hold-to-move jogging: one checked, bounded motion that runs only while its operator keeps it alive.

A jog is one URScript program from the arm's joints towards a target at most `step` away along one axis: a joint
(movej of that joint alone) or a TCP axis of the base or tool frame (movel: a straight line, or a turn about the
TCP). Held without a step, the target is as far as the checks let the arm go (HELD_JOINT_TRAVEL, HELD_LINE,
HELD_TURN at most). The whole path is checked before anything is sent: joint limits, the travel bound, and the
path check (self-collision, the cell, singularities, reach, joint speeds); a path that fails is shortened to the
longest that passes (bisection), and refused when nothing of it does.

The program arms two controller watchdogs (the RTDE input watchdog, as every ur3dq motion): the driver's heartbeat
(ur3dq dies: the arm stops) and KEEPALIVE_REGISTER at KEEPALIVE_FREQUENCY: the operator (a page's heartbeat, a key
held in a terminal) calls `keep_alive()` at least every 1/KEEPALIVE_FREQUENCY s, and when that stops the controller
stops the program. Releasing the button is `stop()`: stopj at STOP_DECELERATION. The program is an ordinary watched
motion (Robot.run_script, in a thread of the Jog's own): every check the driver makes before sending one is made.

Example
-------
>>> request = JogRequest("Z", -1, speed=0.05, frame="tool", step=0.01)   # 10 mm down the tool's z, at 50 mm/s
>>> request.label, request.linear
('Z-', True)
>>> jog = Jog(robot, cell)                                     # doctest: +SKIP
>>> jog.start(JogRequest("J1", +1, speed=0.2))                 # doctest: +SKIP
>>> while held(): jog.keep_alive(); time.sleep(0.05)           # doctest: +SKIP
>>> jog.stop()                                                 # doctest: +SKIP
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import threading
from typing import TYPE_CHECKING

import numpy as np

from ur3dq import urscript
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import RobotConnectionError, RobotError, SafetyCheckError, UnreachablePoseError
from ur3dq.pathcheck import Cell, Margins, PathPlan, PathSegment, check_path
from ur3dq.robot.motion import trapezoid_duration

if TYPE_CHECKING:
    from ur3dq.robot.robot import Robot

JOINT_AXES = ("J1", "J2", "J3", "J4", "J5", "J6")
TCP_AXES = ("X", "Y", "Z", "RX", "RY", "RZ")
FRAMES = ("base", "tool")
#: The RTDE input integer register the operator's keep-alive is written to (this client holds 18-22; 20 beats).
KEEPALIVE_REGISTER = 21
#: The operator's keep-alive must come at least this often: 250 ms of silence stops a jog.
KEEPALIVE_FREQUENCY = 4.0
ENDED_WAIT = 2.0                  # s a stopped jog's watch may take to end (its settle time and poll)
HELD_JOINT_TRAVEL = math.pi / 2   # rad: the furthest one held jog goes (released sooner, it stops sooner)
HELD_LINE = 0.3                   # m
HELD_TURN = math.pi / 2           # rad
MAX_JOINT_SPEED = 1.0             # rad/s: the fastest jog of a joint, or turn of the TCP
MAX_TCP_SPEED = 0.25              # m/s: the fastest straight jog of the TCP
JOINT_ACCELERATION = 2.0          # rad/s²
TCP_ACCELERATION = 1.0            # m/s² (rad/s² for turns)
STOP_DECELERATION = 10.0          # rad/s² of the stopj that ends a released jog
LIMIT_ROOM = math.radians(0.5)    # a held joint jog stops this far from its limit
SHORTEST = (math.radians(0.05), 0.0005)   # (rad, m): a jog shorter than this is refused
BISECTIONS = 10                   # halvings of a failing jog in search of the longest that passes


@dataclasses.dataclass(frozen=True)
class JogRequest:
    """One jog: `axis` (J1..J6, or X Y Z RX RY RZ of the TCP), `direction` +1 or -1, `frame` ('base' or 'tool',
    TCP axes only), `speed` (rad/s for joints and turns, m/s for X Y Z) and `step` (rad or m; None: as far as
    held)."""

    axis: str
    direction: int
    speed: float
    frame: str = "base"
    step: float | None = None

    def __post_init__(self) -> None:
        if self.axis not in JOINT_AXES + TCP_AXES:
            raise ValueError(f"jog: axis {self.axis!r} is not one of {', '.join(JOINT_AXES + TCP_AXES)}")
        if self.direction not in (1, -1):
            raise ValueError(f"jog: direction must be +1 or -1, got {self.direction!r}")
        if self.frame not in FRAMES:
            raise ValueError(f"jog: frame {self.frame!r} is not one of {', '.join(FRAMES)}")
        limit = MAX_TCP_SPEED if self.linear else MAX_JOINT_SPEED
        if not (isinstance(self.speed, (int, float)) and math.isfinite(self.speed) and 0 < self.speed <= limit):
            raise ValueError(f"jog: speed must be in (0, {limit:g}] {'m/s' if self.linear else 'rad/s'}, "
                             f"got {self.speed!r}")
        if self.step is not None and not (math.isfinite(self.step) and self.step > 0):
            raise ValueError(f"jog: step must be a number > 0, got {self.step!r}")

    @property
    def joint_mode(self) -> bool:
        """True for a joint jog (J1..J6)."""
        return self.axis in JOINT_AXES

    @property
    def linear(self) -> bool:
        """True for a straight TCP jog (X, Y, Z): speeds and steps in metres."""
        return self.axis in TCP_AXES[:3]

    @property
    def label(self) -> str:
        """'J1+', 'X-', ... as the pendant names it."""
        return f"{self.axis}{'+' if self.direction > 0 else '-'}"


@dataclasses.dataclass(frozen=True)
class JogPlan:
    """A checked jog: its move ('joint' or 'linear'), end joints (6,), the distance it may go (rad or m) and
    whether the checks shortened it (`limited_by`: what stopped it short, or None)."""

    request: JogRequest
    move: str
    joints: np.ndarray
    distance: float
    limited_by: str | None


class Jog:
    """Jogs of one connected Robot, checked in `cell` (a pathcheck Cell, or None) with `margins`."""

    def __init__(self, robot: Robot, cell: Cell | None = None, margins: Margins | None = None) -> None:
        self.robot = robot
        self.cell = cell
        self.margins = margins or Margins()
        self._beats = itertools.count(1)
        self._released = False
        self._ended: threading.Event | None = None
        self.active: JogPlan | None = None
        self.failed: list[RobotError] = []   # the last jog's failure, if it ended for another reason than stop()

    # ------------------------------------------------------------------------------------------------ planning
    def plan(self, request: JogRequest, start: np.ndarray | None = None) -> JogPlan:
        """The checked jog of `request` from joints `start` (default: the arm's); SafetyCheckError naming what
        stops it when it cannot move at all."""
        q0 = np.asarray(self.robot.joints() if start is None else start, dtype=float)
        wanted = request.step if request.step is not None else (
            HELD_JOINT_TRAVEL if request.joint_mode else HELD_LINE if request.linear else HELD_TURN)
        limited_by = None
        if request.joint_mode:
            room = self._joint_room(q0, JOINT_AXES.index(request.axis), request.direction)
            if room < wanted:
                wanted, limited_by = room, f"the joint limit of {request.axis}"
        move = "joint" if request.joint_mode else "linear"
        shortest = SHORTEST[1 if request.linear else 0]
        joints, problem, fraction = self._try(request, q0, wanted) if wanted >= shortest else (None, limited_by, 0.0)
        if joints is not None:
            return JogPlan(request, move, joints, wanted, limited_by)
        # The longest jog that passes, by bisection: every distance that reaches the failing sample fails.
        best, low, high = None, 0.0, wanted * (fraction if fraction is not None else 1.0)
        for _ in range(BISECTIONS):
            middle = (low + high) / 2
            if middle < shortest:
                break
            joints, failed, fraction = self._try(request, q0, middle)
            if joints is not None:
                best, low = (joints, middle), middle
            else:
                problem, high = failed, middle * (fraction if fraction is not None else 1.0)
        if best is None:
            raise SafetyCheckError(f"jog {request.label}: the arm cannot move that way: {problem}")
        return JogPlan(request, move, best[0], best[1], "the path check")

    def _joint_room(self, q0: np.ndarray, joint: int, direction: int) -> float:
        """How far (rad) joint `joint` may turn in `direction` before LIMIT_ROOM of its limit."""
        model = self.robot.model
        limit = model.joint_upper[joint] if direction > 0 else model.joint_lower[joint]
        return max(float(abs(limit - q0[joint])) - LIMIT_ROOM, 0.0) if math.isfinite(limit) else math.inf

    def _target_pose(self, request: JogRequest, q0: np.ndarray, distance: float) -> DualQuaternion:
        """The TCP pose `distance` along the request's TCP axis from the pose at `q0`."""
        pose: DualQuaternion = self.robot.model.fk(q0)
        axis = np.zeros(3)
        axis[TCP_AXES.index(request.axis) % 3] = request.direction
        if request.linear:
            move = DualQuaternion.from_translation(axis * distance)
            moved: DualQuaternion = pose * move if request.frame == "tool" else move * pose
            return moved
        turn = DualQuaternion.from_axis_angle(axis, distance)
        if request.frame == "tool":
            turned: DualQuaternion = pose * turn
            return turned
        at = DualQuaternion.from_translation(pose.translation)   # about the base axes, through the TCP
        turned = at * turn * at.inverse() * pose
        return turned

    def _try(self, request: JogRequest, q0: np.ndarray, distance: float) -> tuple[np.ndarray | None, str | None,
                                                                                 float | None]:
        """(end joints, None, None) when the jog of `distance` passes every check, else (None, the first problem,
        the fraction of the move where it is, or None when the end cannot be reached at all)."""
        model = self.robot.model
        if request.joint_mode:
            joints = q0.copy()
            joints[JOINT_AXES.index(request.axis)] += request.direction * distance
            segment = PathSegment(f"jog {request.label}", "joint", target_joints=joints, speed=request.speed,
                                  acceleration=JOINT_ACCELERATION)
        else:
            pose = self._target_pose(request, q0, distance)
            try:
                joints = model.ik(pose, q0)
            except UnreachablePoseError as error:
                return None, str(error), None
            segment = PathSegment(f"jog {request.label}", "linear", target_joints=joints, target_pose=pose.to_array(),
                                  speed=request.speed, acceleration=TCP_ACCELERATION)
        result = check_path(model, PathPlan(q0, (segment,)), self.cell, self.margins, keep_samples=False)
        if result.ok:
            return joints, None, None
        first = min(result.problems, key=lambda problem: problem.fraction)
        return None, first.message, first.fraction

    # ------------------------------------------------------------------------------------------------ motion
    def start(self, request: JogRequest) -> JogPlan:
        """Plan the jog of `request` and send it; returns once it is on its way (the arm moves until stop(), the
        keep-alive stopping, or the planned end). SafetyCheckError and RobotError when it cannot start."""
        self.wait_ended()
        plan = self.plan(request)
        q0 = self.robot.joints()
        linear = plan.move == "linear"
        acceleration = TCP_ACCELERATION if linear else JOINT_ACCELERATION
        name = urscript.new_program_name("jog")
        keepalive = urscript.rtde_set_watchdog_statement(f"input_int_register_{KEEPALIVE_REGISTER}",
                                                         KEEPALIVE_FREQUENCY, "stop")
        move = urscript.move_statement("movel" if linear else "movej", plan.joints, acceleration, request.speed,
                                       t=0 if linear else None)
        segment = PathSegment(f"jog {request.label}", plan.move, target_joints=plan.joints, speed=request.speed,
                              acceleration=acceleration)
        duration = trapezoid_duration(plan.distance, acceleration, request.speed)
        self.keep_alive()
        self._released = False
        sent, ended, failed = threading.Event(), threading.Event(), []

        def run() -> None:
            try:
                self.robot.run_script(name, urscript.program(name, [keepalive, move]), plan.joints, duration,
                                      path=PathPlan(q0, (segment,)), on_sent=sent.set)
            except RobotError as error:      # a release ends the jog short of its target: that is no failure
                if not (sent.is_set() and self._released):
                    failed.append(error)
            finally:
                ended.set()

        self._ended = ended
        threading.Thread(target=run, name="ur3dq-jog", daemon=True).start()
        while not (sent.wait(0.01) or ended.is_set()):
            pass
        if failed and not sent.is_set():
            raise failed[0]
        self.failed, self.active = failed, plan
        return plan

    def keep_alive(self) -> None:
        """The operator is still there: write the keep-alive register (call at least every 1/KEEPALIVE_FREQUENCY
        s while a jog may run)."""
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
