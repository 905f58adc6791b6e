"""Checks every motion passes before it is sent, and the clamping of its speed and acceleration.

Each function is pure: it takes the numbers (and, for FK consistency, the model) and either returns the safe
values or raises SafetyCheckError (ValueError) naming the argument and the problem.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import SafetyCheckError
from ur3dq.real_numbers import is_number, real_array

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel

#: A pose argument: a DualQuaternion (TCP in the base frame) or a UR pose vector [x, y, z, rx, ry, rz].
PoseLike = DualQuaternion | Sequence[float] | np.ndarray

# Default bound on any single joint's travel in one move: a surprising IK branch (a 2π wrist flip, an elbow
# swap) travels more than this and is refused instead of swinging the arm.
DEFAULT_MAX_JOINT_TRAVEL = math.pi
MAX_TCP_SPEED = 1.0          # m/s: the pendant's default tool speed limit region; faster is lowered to it
MAX_TCP_ACCELERATION = 4.0   # m/s²
DEFAULT_TCP_SPEED = 0.25     # m/s, URScript movel's default
DEFAULT_TCP_ACCELERATION = 1.2   # m/s², URScript movel's default


def check_joint_vector(q: object, name: str = "q") -> np.ndarray:
    """`q` as a float array of six finite joint angles (radians), or SafetyCheckError naming the problem."""
    try:
        array = real_array(q)
    except (TypeError, ValueError):
        raise SafetyCheckError(f"{name} must be six joint angles in radians, got {q!r}") from None
    if array.shape != (6,):
        raise SafetyCheckError(f"{name} must be six joint angles in radians, got shape {array.shape}")
    bad = [index for index in range(6) if not math.isfinite(array[index])]
    if bad:
        raise SafetyCheckError(f"{name}: joint {bad[0] + 1} is {array[bad[0]]!r}; every joint angle must be finite")
    return array


def check_pose_vector(pose: object, name: str = "pose") -> np.ndarray:
    """`pose` as a float array [x, y, z, rx, ry, rz] (metres, rotation vector) of six finite values."""
    try:
        array = real_array(pose)
    except (TypeError, ValueError):
        raise SafetyCheckError(f"{name} must be a UR pose vector [x, y, z, rx, ry, rz], got {pose!r}") from None
    if array.shape != (6,) or not np.all(np.isfinite(array)):
        raise SafetyCheckError(f"{name} must be a UR pose vector of six finite numbers, got {pose!r}")
    return array


def pose_of(pose: PoseLike) -> DualQuaternion:
    """`pose` as a DualQuaternion: itself, or the pose of a UR pose vector [x, y, z, rx, ry, rz] (metres, rotation
    vector); SafetyCheckError for anything else."""
    if isinstance(pose, DualQuaternion):
        return pose
    return DualQuaternion.from_ur_pose(check_pose_vector(pose, "pose"))


def check_joint_limits(q: object, lower: Sequence[float] | np.ndarray, upper: Sequence[float] | np.ndarray,
                       name: str = "q") -> np.ndarray:
    """`q` unchanged if every joint lies within [lower, upper] (radians), else SafetyCheckError naming the joint."""
    q = check_joint_vector(q, name)
    for index in range(6):
        if not lower[index] <= q[index] <= upper[index]:
            raise SafetyCheckError(
                f"{name}: joint {index + 1} = {q[index]:.6f} rad lies outside its limits "
                f"[{lower[index]:.6f}, {upper[index]:.6f}]"
            )
    return q


def check_travel(q_from: object, q_to: object, max_travel: float, name: str = "q") -> np.ndarray:
    """`q_to` unchanged if no joint travels more than `max_travel` radians from `q_from`, else SafetyCheckError."""
    travel = np.abs(check_joint_vector(q_to, name) - check_joint_vector(q_from, "current joints"))
    worst = int(np.argmax(travel))
    if travel[worst] > max_travel:
        raise SafetyCheckError(
            f"{name}: joint {worst + 1} would travel {travel[worst]:.4f} rad, more than the allowed "
            f"{max_travel:.4f} rad per move (a different IK branch? raise max_joint_travel if intended)"
        )
    return np.asarray(q_to, dtype=float)


def clamp_movej_speed(delta_q: Sequence[float] | np.ndarray, a: float, v: float,
                      max_acceleration: Sequence[float] | np.ndarray,
                      max_speed: Sequence[float] | np.ndarray) -> tuple[float, float]:
    """(a, v) for a movej of joint travel `delta_q`, lowered so that no joint exceeds its own max (rad/s², rad/s).

    The leading joint moves at a and v; joint i at a·|Δq_i|/D and v·|Δq_i|/D, D = max |Δq|.
    """
    a, v = _positive(a, "a"), _positive(v, "v")
    travel = np.abs(np.asarray(delta_q, dtype=float))
    leading = float(np.max(travel)) if travel.size else 0.0
    if leading == 0.0:
        return min(a, float(np.min(max_acceleration))), min(v, float(np.min(max_speed)))
    moving = travel > 0
    share = travel[moving] / leading
    with np.errstate(divide="ignore", over="ignore"):  # a joint with a vanishing share has no binding limit (inf)
        a_limit = float(np.min(np.asarray(max_acceleration, dtype=float)[moving] / share))
        v_limit = float(np.min(np.asarray(max_speed, dtype=float)[moving] / share))
    return min(a, a_limit), min(v, v_limit)


def clamp_tcp_speed(a: float | None, v: float | None) -> tuple[float, float]:
    """(a, v) of a linear or process move (m/s², m/s): URScript's defaults where None, lowered to MAX_TCP_ACCELERATION
    and MAX_TCP_SPEED; SafetyCheckError unless each is a finite number > 0."""
    a = DEFAULT_TCP_ACCELERATION if a is None else _positive(a, "a")
    v = DEFAULT_TCP_SPEED if v is None else _positive(v, "v")
    return min(a, MAX_TCP_ACCELERATION), min(v, MAX_TCP_SPEED)


def check_fk_consistency(model: URModel, q: object, pose: DualQuaternion, tol_m: float = 1e-4, tol_rad: float = 1e-3,
                         name: str = "q") -> np.ndarray:
    """`q` unchanged if the model's FK of `q` is `pose` (DualQuaternion) within tolerance, else SafetyCheckError."""
    reached = model.fk(check_joint_vector(q, name))
    metres, radians = reached.distance(pose)
    if metres > tol_m or radians > tol_rad:
        raise SafetyCheckError(
            f"{name} does not reach the pose it was solved for: FK is {metres * 1000:.3f} mm / "
            f"{math.degrees(radians):.3f}° away (tolerance {tol_m * 1000:.3f} mm / {math.degrees(tol_rad):.3f}°)"
        )
    return np.asarray(q, dtype=float)


def _positive(value: object, name: str) -> float:
    """`value` as a float if finite and > 0, else SafetyCheckError."""
    if not is_number(value):   # float() would read "1.5" and True
        raise SafetyCheckError(f"{name} must be a positive number, got {value!r}")
    number = float(value)   # type: ignore[arg-type]   # is_number checked it
    if not (math.isfinite(number) and number > 0):
        raise SafetyCheckError(f"{name} must be finite and > 0, got {number!r}")
    return number
