"""Jog steps: one bounded move per key press, in joint space or along a TCP axis of the base or tool frame (pure).

A jog step is a small, complete motion: the driver plans its target here, checks it like any motion (limits, FK,
travel, the whole path) and watches it to its end (Robot.jog). It never outlives the key press that asked for it:
there is no motion that runs "while held", so nothing moves between key presses.

Examples
--------
>>> import numpy as np
>>> from ur3dq.kinematics import robot_model
>>> step = JogStep("J2", -1, np.radians(1.0))
>>> move, joints, pose = step_target(robot_model("ur3"), np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0]), step)
>>> move, round(float(joints[1]), 4), pose is None
('joint', -1.2175, True)
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
#: The largest step one key press may ask for: 10 mm (the jog's coarsest step) with room, and 10° likewise.
MAX_STEP_M = 0.02
MAX_STEP_RAD = math.radians(20.0)
#: A jog's speed limits: a key press is a small, slow move.
MAX_JOINT_SPEED = 0.5      # rad/s
MAX_TCP_SPEED = 0.1        # m/s (rad/s for a turn of the TCP)
JOINT_ACCELERATION = 1.0   # rad/s²
TCP_ACCELERATION = 0.5     # m/s²


@dataclasses.dataclass(frozen=True)
class JogStep:
    """One key press: `axis` (J1..J6, or X Y Z RX RY RZ of the TCP), `direction` +1 or -1, `size` (rad for joints and
    turns, m for X Y Z, at most MAX_STEP_RAD / MAX_STEP_M) and `frame` ('base' or 'tool', TCP axes only)."""

    axis: str
    direction: int
    size: float
    frame: str = "base"

    def __post_init__(self) -> None:
        if self.axis not in JOINT_AXES + TCP_AXES:
            raise ValueError(f"jog: axis {self.axis!r} is not one of {', '.join(JOINT_AXES + TCP_AXES)}")
        if self.direction not in (1, -1):
            raise ValueError(f"jog: direction must be +1 or -1, got {self.direction!r}")
        if self.frame not in FRAMES:
            raise ValueError(f"jog: frame {self.frame!r} is not one of {', '.join(FRAMES)}")
        bound, unit = (MAX_STEP_M, "m") if self.linear else (MAX_STEP_RAD, "rad")
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


def tcp_step_pose(pose: DualQuaternion, step: JogStep) -> DualQuaternion:
    """The TCP pose one TCP `step` from `pose`: a translation along, or a turn about, the step's axis of the base
    frame (the turn about the TCP point) or of the tool frame."""
    axis = np.zeros(3)
    axis[TCP_AXES.index(step.axis) % 3] = step.direction
    if step.linear:
        move = DualQuaternion.from_translation(axis * step.size)
        return pose * move if step.frame == "tool" else move * pose
    turn = DualQuaternion.from_axis_angle(axis, step.size)
    if step.frame == "tool":
        return pose * turn
    at = DualQuaternion.from_translation(pose.translation)   # about the base axes, through the TCP
    return at * turn * at.inverse() * pose


def step_target(model: URModel, q: np.ndarray, step: JogStep) -> tuple[str, np.ndarray, DualQuaternion | None]:
    """(move type, target joints (6,), target TCP pose or None) of `step` from joints `q` on `model`: a joint
    step turns one joint (a movej); a TCP step goes on a straight line (a movel) to the IK solution nearest `q`.
    UnreachablePoseError when the TCP target is out of reach."""
    q = np.asarray(q, dtype=float)
    if step.joint_mode:
        target = q.copy()
        target[JOINT_AXES.index(step.axis)] += step.direction * step.size
        return "joint", target, None
    pose = tcp_step_pose(model.fk(q), step)
    return "linear", np.asarray(model.ik(pose, q), dtype=float), pose
