"""Jog steps: one move along one axis, in joint space or along a TCP axis of the base or tool frame (pure).

A jog step turns one joint (J1..J6) or moves the TCP along, or turns it about, an axis of the base or tool frame
(X Y Z RX RY RZ), by a bounded `size` (a key press, a step of the screen's jog panel) or, held without a size, as
far as the operator keeps it going (at most HELD_JOINT_TRAVEL, HELD_LINE or HELD_TURN). The driver plans its target
here, checks it like any motion (limits, FK, travel, the whole path) and runs it (ur3dq.robot.jog: a step runs to
its end, a held jog only while its operator keeps it alive).

Examples
--------
>>> import numpy as np
>>> from ur3dq.kinematics import robot_model
>>> step = JogStep("J2", -1, np.radians(1.0))
>>> move, joints, pose = step_target(robot_model("ur3"), np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0]), step)
>>> move, round(float(joints[1]), 4), pose is None
('joint', -1.2175, True)
>>> JogStep("Z", 1).held, JogStep("Z", 1).distance     # held: as far as HELD_LINE
(True, 0.3)
"""
from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from ur3dq.dualquat import DualQuaternion

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel

JOINT_AXES = ("J1", "J2", "J3", "J4", "J5", "J6")
TCP_AXES = ("X", "Y", "Z", "RX", "RY", "RZ")
FRAMES = ("base", "tool")
#: The step sizes a pendant offers (the keyboard jog and the screen's jog panel): mm for X Y Z, degrees otherwise.
STEP_SIZES = (0.1, 1.0, 10.0)
#: The largest step one key press may ask for: 10 mm (the jog's coarsest step) with room, and 10° likewise.
MAX_STEP_M = 0.02
MAX_STEP_RAD = math.radians(20.0)
#: How far one held jog may go (released sooner, it stops sooner).
HELD_JOINT_TRAVEL = math.pi / 2   # rad
HELD_LINE = 0.3                   # m
HELD_TURN = math.pi / 2           # rad
#: A jog's speed limits: a jog is a small, slow move.
MAX_JOINT_SPEED = 0.5      # rad/s
MAX_TCP_SPEED = 0.1        # m/s (rad/s for a turn of the TCP)
JOINT_ACCELERATION = 1.0   # rad/s²
TCP_ACCELERATION = 0.5     # m/s² (rad/s² for a turn)


@dataclasses.dataclass(frozen=True)
class JogStep:
    """One jog: `axis` (J1..J6, or X Y Z RX RY RZ of the TCP), `direction` +1 or -1, `size` (rad for joints and
    turns, m for X Y Z, at most MAX_STEP_RAD / MAX_STEP_M; None: held, as far as the operator keeps it going) and
    `frame` ('base' or 'tool', TCP axes only)."""

    axis: str
    direction: int
    size: float | None = None
    frame: str = "base"

    def __post_init__(self) -> None:
        if self.axis not in JOINT_AXES + TCP_AXES:
            raise ValueError(f"jog: axis {self.axis!r} is not one of {', '.join(JOINT_AXES + TCP_AXES)}")
        if self.direction not in (1, -1):
            raise ValueError(f"jog: direction must be +1 or -1, got {self.direction!r}")
        if self.frame not in FRAMES:
            raise ValueError(f"jog: frame {self.frame!r} is not one of {', '.join(FRAMES)}")
        bound, unit = (MAX_STEP_M, "m") if self.linear else (MAX_STEP_RAD, "rad")
        if self.size is None:
            return
        if isinstance(self.size, bool) or not isinstance(self.size, (int, float)) \
                or not (math.isfinite(self.size) and 0 < self.size <= bound):
            raise ValueError(f"jog: step must be a number in (0, {bound:g}] {unit}, got {self.size!r}")

    @property
    def joint_mode(self) -> bool:
        """True for a joint step (J1..J6)."""
        return self.axis in JOINT_AXES

    @property
    def linear(self) -> bool:
        """True for a straight TCP step (X, Y, Z): its size is in metres."""
        return self.axis in TCP_AXES[:3]

    @property
    def label(self) -> str:
        """'J1+', 'Z-', ... as the pendant names it."""
        return f"{self.axis}{'+' if self.direction > 0 else '-'}"

    @property
    def held(self) -> bool:
        """True for a held jog (no size): it goes on while its operator keeps it alive."""
        return self.size is None

    @property
    def distance(self) -> float:
        """How far the jog goes at most (rad, or m for X Y Z): its size, or the held bound."""
        if self.size is not None:
            return float(self.size)
        return HELD_JOINT_TRAVEL if self.joint_mode else HELD_LINE if self.linear else HELD_TURN

    @property
    def top_speed(self) -> float:
        """The jog's speed limit: MAX_JOINT_SPEED (rad/s) for a joint, MAX_TCP_SPEED (m/s, rad/s) for the TCP."""
        return MAX_JOINT_SPEED if self.joint_mode else MAX_TCP_SPEED

    @property
    def acceleration(self) -> float:
        """The jog's acceleration: JOINT_ACCELERATION (rad/s²) or TCP_ACCELERATION (m/s², rad/s²)."""
        return JOINT_ACCELERATION if self.joint_mode else TCP_ACCELERATION


def step_of(axis: str, direction: int, size: float | None, frame: str = "base") -> JogStep:
    """The JogStep of a pendant's choice: `size` one of STEP_SIZES (mm for X Y Z, degrees otherwise) or None (held).

    >>> step_of("Z", -1, 1.0, "tool").size, step_of("J1", 1, 10.0).size == math.radians(10.0)
    (0.001, True)
    """
    linear = axis in TCP_AXES[:3]
    return JogStep(axis, direction, None if size is None else size * (1e-3 if linear else math.pi / 180.0), frame)


def tcp_step_pose(pose: DualQuaternion, step: JogStep, distance: float | None = None) -> DualQuaternion:
    """The TCP pose `distance` (default: the step's) along one TCP `step` from `pose`: a translation along, or a turn
    about, the step's axis of the base frame (the turn about the TCP point) or of the tool frame."""
    distance = step.distance if distance is None else distance
    axis = np.zeros(3)
    axis[TCP_AXES.index(step.axis) % 3] = step.direction
    if step.linear:
        move = DualQuaternion.from_translation(axis * distance)
        return pose * move if step.frame == "tool" else move * pose
    turn = DualQuaternion.from_axis_angle(axis, distance)
    if step.frame == "tool":
        return pose * turn
    at = DualQuaternion.from_translation(pose.translation)   # about the base axes, through the TCP
    return at * turn * at.inverse() * pose


def step_target(model: URModel, q: np.ndarray, step: JogStep,
                distance: float | None = None) -> tuple[str, np.ndarray, DualQuaternion | None]:
    """(move type, target joints (6,), target TCP pose or None) of `step` from joints `q` (6,) on `model`, `distance`
    along it (default: the step's distance): a joint step turns one joint (a movej); a TCP step goes on a straight
    line (a movel) to the IK solution nearest `q`. UnreachablePoseError when the TCP target is out of reach."""
    q = np.asarray(q, dtype=float)
    distance = step.distance if distance is None else distance
    if step.joint_mode:
        target = q.copy()
        target[JOINT_AXES.index(step.axis)] += step.direction * distance
        return "joint", target, None
    pose = tcp_step_pose(model.fk(q), step, distance)
    return "linear", np.asarray(model.ik(pose, q), dtype=float), pose
