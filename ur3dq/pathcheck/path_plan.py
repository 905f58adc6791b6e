"""The path check's input: a start joint vector and the ordered motion segments of a plan (validated on construction).

This is deliberately small and explicit so any plan (today's replay plan, a cell program) adapts to it in a few
lines: one :class:`PathSegment` per move, in execution order. Action steps (I/O, waits) do not move the arm and are
left out. Units: metres, radians, seconds; poses are TCP poses in the base frame as (8,) dual quaternions
[rw rx ry rz dw dx dy dz] (docs/conventions.md).
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence

import numpy as np
import numpy.typing as npt

from ur3dq import dqarray
from ur3dq.array_types import FloatArray
from ur3dq.dualquat import DualQuaternion
from ur3dq.pose import MAX_JOINT_ABS

MOVE_TYPES = ("joint", "linear", "process")


@dataclasses.dataclass(frozen=True, slots=True)  # slots: one per move, 10⁵ in a big plan
class PathSegment:
    """One move, from wherever the previous one ended.

    name:          the step's name (shown in every problem found on it).
    move:          "joint" (movej: synchronised joint interpolation), "linear" (movel: straight TCP line) or
                   "process" (movep: the same straight line, constant TCP speed).
    target_joints: (6,) joint target in rad. Required for joint moves unless `target_pose` is given (then the IK
                   solution nearest the start is used); optional for linear/process moves, where the controller
                   reaches the pose by IK continuity: a target on another IK branch is reported.
    target_pose:   the TCP pose, a DualQuaternion σ or its (8,) coefficients [rw rx ry rz dw dx dy dz]; for
                   linear/process moves required unless `target_joints` is given (its FK). A unit dual quaternion
                   within dqarray.UNIT_TOLERANCE (normalised), as the IK takes it, its translation within
                   ±dqarray.MAX_POSE_COORDINATE m.
    speed:         rad/s (joint) or m/s (linear/process); acceleration rad/s² or m/s² (kept for the time figures).
    blend:         blend radius (m) into the next segment; 0 = stop at the target.
    tcp_offset:    (6,) UR pose vector [x y z rx ry rz] (m, rad, flange frame) of the TCP this move runs with (a
                   cell program's waypoint taught with its own TCP: set_tcp before the move); None = the model's.
                   A linear move's straight line, and `target_pose`, belong to this TCP.
    Joint values lie within ±pose.MAX_JOINT_ABS rad (as in the pose store). Bad input: ValueError naming the
    segment and the field. The fields are annotated with what the segment keeps: target_joints and target_pose as
    read-only float arrays, tcp_offset as a tuple of floats, whatever numbers (or DualQuaternion) they were given as.
    """

    name: str
    move: str = "joint"
    target_joints: FloatArray | None = None   # given as any 6 numbers
    target_pose: FloatArray | None = None     # given as 8 numbers or a DualQuaternion
    speed: float = 1.05
    acceleration: float = 1.4
    blend: float = 0.0
    tcp_offset: tuple[float, ...] | None = None   # given as any 6 numbers

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"path segment name must be a non-empty string, got {self.name!r}")
        if self.move not in MOVE_TYPES:
            raise ValueError(f"segment {self.name!r}: move must be one of {', '.join(MOVE_TYPES)}, got {self.move!r}")
        joints = None if self.target_joints is None else _joint_vector(self.target_joints, self.name)
        target_pose = self.target_pose.to_array() if isinstance(self.target_pose, DualQuaternion) else self.target_pose
        pose = None if target_pose is None else _unit_pose(target_pose, self.name)
        if joints is None and pose is None:
            raise ValueError(f"segment {self.name!r}: give target_joints or target_pose")
        for field, value in (("speed", self.speed), ("acceleration", self.acceleration)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"segment {self.name!r}: {field} must be a number > 0, got {value!r}")
        if not (isinstance(self.blend, (int, float)) and math.isfinite(self.blend) and self.blend >= 0):
            raise ValueError(f"segment {self.name!r}: blend must be a radius ≥ 0 in metres, got {self.blend!r}")
        object.__setattr__(self, "target_joints", joints)
        object.__setattr__(self, "target_pose", pose)
        if self.tcp_offset is not None:
            object.__setattr__(self, "tcp_offset", _tcp_offset(self.tcp_offset, self.name))

    @classmethod
    def joint_targets(cls, names: Iterable[str], moves: Iterable[str], targets: npt.ArrayLike,
                      speeds: Iterable[float], accelerations: Iterable[float], blends: Iterable[float],
                      tcp_offsets: Sequence[tuple[float, ...] | None]) -> list[PathSegment]:
        """Segments to joint targets, one per row.

        Segments to joint targets, one per row: names (n,) and moves (n,) str, targets (n, 6) rad, speeds,
        accelerations, blends (n,) and tcp_offsets (n,) (each (6,) or None); each checked as PathSegment checks it.

        Examples
        --------
        >>> segments = PathSegment.joint_targets(["a", "b"], ["joint"] * 2, [[0.0] * 6, [0.1] * 6], [1.0] * 2,
        ...                                      [1.4] * 2, [0.0] * 2, [None] * 2)
        >>> [segment.name for segment in segments], segments[1].target_joints.tolist()
        (['a', 'b'], [0.1, 0.1, 0.1, 0.1, 0.1, 0.1])
        """
        name_list, move_list = list(names), list(moves)
        count = len(name_list)
        rows = np.array(targets, dtype=float).reshape(-1, 6) if count else np.zeros((0, 6))
        if len(rows) != count or len(move_list) != count or len(tcp_offsets) != count:
            raise ValueError(f"{count} names need as many moves, targets and TCP offsets")
        return [cls(name, move, target, None, speed, acceleration, blend, offset)
                for name, move, target, speed, acceleration, blend, offset
                in zip(name_list, move_list, rows, speeds, accelerations, blends, tcp_offsets, strict=True)]

    @property
    def cartesian(self) -> bool:
        """True for moves whose TCP follows a straight line (linear, process)."""
        return self.move != "joint"



@dataclasses.dataclass(frozen=True)
class PathPlan:
    """start_joints (6,) rad: where the arm is before the first segment; segments: the moves in order.

    start_known=False says the arm's position is not known (a plan checked offline): start_joints is then the first
    segment's target, whose configuration is checked as a move of length 0, and that move is no neighbour that
    limits the first waypoint's blend radius (the real move into it comes from wherever the arm will be).
    """

    start_joints: FloatArray   # given as any 6 numbers, kept as a read-only array
    segments: Sequence[PathSegment]   # kept as a tuple
    start_known: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "start_joints", _joint_vector(self.start_joints, "start"))
        segments = tuple(self.segments)
        if not segments:
            raise ValueError("a path plan needs at least one segment")
        for segment in segments:
            if not isinstance(segment, PathSegment):
                raise ValueError(f"path plan segments must be PathSegment, got {type(segment).__name__}")
        object.__setattr__(self, "segments", segments)


def _finite_vector(value: object, size: int, name: str, what: str) -> FloatArray:
    array = np.array(value, dtype=float)
    if array.shape != (size,):
        raise ValueError(f"segment {name!r}: {what} must have {size} numbers, got shape {array.shape}")
    if not all(map(math.isfinite, array.tolist())):   # on 6 numbers, cheaper than np.isfinite(array).all()
        raise ValueError(f"segment {name!r}: {what} contain NaN or infinite values")
    array.flags.writeable = False
    return array


def _joint_vector(value: object, name: str) -> FloatArray:
    """(6,) read-only finite joint values within ±MAX_JOINT_ABS rad (no arm is wound up 16 turns); ValueError
    naming the segment."""
    array = _finite_vector(value, 6, name, "joints")
    if not float(np.max(np.abs(array))) <= MAX_JOINT_ABS:
        raise ValueError(f"segment {name!r}: joints must lie within ±{MAX_JOINT_ABS:g} rad (radians, not "
                         f"degrees), got {float(np.max(np.abs(array))):.4g}")
    return array


def _unit_pose(value: object, name: str) -> FloatArray:
    """(8,) read-only unit pose, normalised from within dqarray.UNIT_TOLERANCE as the IK takes it, translation
    within ±dqarray.MAX_POSE_COORDINATE m; ValueError naming the segment (a scaled or non-rigid 8-vector)."""
    array = _finite_vector(value, 8, name, "pose")
    try:
        pose = dqarray.normalise(dqarray.check_unit(array, "pose"))
    except ValueError as error:
        raise ValueError(f"segment {name!r}: {error}") from None
    translation = float(np.max(np.abs(dqarray.translation_unchecked(pose))))
    if translation > dqarray.MAX_POSE_COORDINATE:
        raise ValueError(f"segment {name!r}: pose translation {translation:.3g} m is beyond "
                         f"±{dqarray.MAX_POSE_COORDINATE:g} m: give metres")
    pose.flags.writeable = False
    return pose


def _tcp_offset(value: Iterable[float], name: str) -> tuple[float, ...]:
    """(6,) UR pose vector of a TCP offset, as dqarray.from_ur_pose accepts it; ValueError naming the segment."""
    offset = _finite_tuple(value, 6, name, "tcp_offset")
    try:
        dqarray.from_ur_pose(offset)
    except ValueError as error:
        raise ValueError(f"segment {name!r}: tcp_offset {str(error).removeprefix('pose: ')}") from None
    return offset


def _finite_tuple(value: Iterable[float], size: int, name: str, what: str) -> tuple[float, ...]:
    """`value` as a tuple of `size` finite floats (a hashable key: plans group their moves by TCP); ValueError
    naming the segment for anything else (not iterable, not numbers, another count)."""
    try:
        numbers = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        numbers = ()
    if len(numbers) != size:
        raise ValueError(f"segment {name!r}: {what} must be {size} numbers, got {value!r}")
    if not all(map(math.isfinite, numbers)):
        raise ValueError(f"segment {name!r}: {what} contain NaN or infinite values")
    return numbers
