"""Analytic inverse kinematics of the UR family, after the thesis' dual-quaternion derivation (seed 000, §4.3).

    from ur3dq.kinematics import robot_model
    from ur3dq.kinematics import ur_ik
    model = robot_model("ur5e")
    pose = model.fk([0.1, -1.2, 1.3, -0.4, 0.9, 0.2])
    ur_ik.ik_all(model, pose)                  # every FK-verified solution, each joint in (−π, π]
    ur_ik.ik(model, pose, q_ref)               # the solution nearest q_ref among ±2π variants inside the limits
    ur_ik.ik_batch(model, poses, q_refs)       # (N, 6), NaN rows where unreachable
    ur_ik.ik_all_batch(model, poses)           # (N, 8, 6), branch slots, NaN where absent

Poses are TCP poses (flange · model.tcp) in the base frame: a DualQuaternion or 8 coefficients (w, x, y, z real |
dual); frames and conventions in docs/conventions.md. The equations are written once, in ``equations`` (with the
singular cases and their tolerances), compiled with numba (ur3dq.kinematics.jit); a single pose runs the very
kernel a batch runs, so ``ik_batch`` is ``ik`` row by row. Calibrated models (DH deltas) refine the closed form's
branches by Newton on the full DH chain (``newton``, ``solve``).

At a singular wrist only θ234 ± θ6 is fixed: ``ik_all`` and ``ik`` keep θ6 at q_ref[5] (0 without one) where the
arm reaches with that split, else the nearest reachable split; ``ik`` moves it so far that θ4 stays inside its
limits where θ6 = q_ref[5] would put it past one. Chaining ``ik`` with q_ref = the previous answer minimises the
distance to q_ref only: at an elbow or shoulder crossing the nearest solution can be the mirrored branch, which
ur3dq.pathcheck reports before anything moves.
"""
from __future__ import annotations

import functools
import math
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics.arm import (
    CALIBRATED_TOLERANCE,
    DOMAIN_TOLERANCE,
    DUPLICATE_TOLERANCE,
    FK_TOLERANCE_M,
    FK_TOLERANCE_RAD,
    LENGTHS,
    LIMIT_ROUNDING,
    LOWER,
    UPPER,
    WRIST_SINGULAR_TOLERANCE,
    arm_vector,
    vector,
)
from ur3dq.kinematics.inputs import UNIT_WEIGHTS, joint_floats, joint_rows, joint_weights, pose_row, unit_pose_rows
from ur3dq.units import LENGTH, Measured

__all__ = [
    "CALIBRATED_TOLERANCE", "DUPLICATE_TOLERANCE", "FK_TOLERANCE_M", "FK_TOLERANCE_RAD", "LIMIT_ROUNDING",
    "WRIST_SINGULAR_TOLERANCE", "closed_form_pose", "closed_form_poses", "dh_frames", "ik", "ik_all", "ik_all_batch",
    "ik_batch", "joint_variants", "nearest_variant", "wrap_angle",
]

_BLOCK = 4096   # poses per block of closed_form_poses: its tangents stay in the cache


@functools.cache
def kernels() -> tuple[ModuleType, ModuleType, ModuleType]:
    """The compiled kernel modules (fk, nearest, solve), imported on first use: they load numba, and the first use
    after an install compiles them (once per cache, saying so on stderr; ur3dq.kinematics.jit)."""
    from ur3dq import dualquat
    from ur3dq.kinematics import arm, chain, chain_kernels, fk, jit
    from ur3dq.kinematics.ur_ik import nearest, solve
    sources = sorted(Path(__file__).parent.glob("*.py")) + [Path(str(module.__file__)) for module in (
        fk, chain_kernels, chain, dualquat, arm, jit)]
    jit.warm_once("kinematics", tuple(str(path) for path in sources), warm)
    return fk, nearest, solve


def closed_form_poses(model: Any, joints: np.ndarray, tool: np.ndarray) -> np.ndarray:
    """(N, 8) poses of ``tool`` (8 coefficients in the flange frame: the TCP, or the identity for the flange) on a
    nominal arm at joints (N, 6, float64, C order), by the compiled closed form."""
    fk, _, _ = kernels()
    arm, out = arm_vector(model), np.empty((len(joints), 8))
    for start in range(0, len(joints), _BLOCK):
        block = slice(start, start + _BLOCK)
        tangents = np.empty((6, len(joints[block])))
        fk.half_tangent_angles(joints[block], tangents)
        np.tan(tangents, out=tangents)   # numpy's vectorised tan: every sine and cosine of the block at once
        fk.nominal_poses(arm, tool, tangents, out[block])
    return out


def closed_form_pose(model: Any, q: tuple[float, ...], tool: np.ndarray) -> tuple[float, ...]:
    """The 8 coefficients of ``tool`` (8 coefficients in the flange frame) on a nominal arm at 6 joint floats."""
    pose: tuple[float, ...] = kernels()[0].nominal_pose(arm_vector(model), tool, *q)
    return pose


def dh_frames(model: Any, joints: np.ndarray) -> np.ndarray:
    """(N, 7, 4, 4) DH frames 0…6 (6 = flange, no TCP) in the base frame at joints (N, 6) of the model's (possibly
    calibrated) table, by the compiled DH chain."""
    fk, _, _ = kernels()
    out = np.empty((len(joints), 7, 4, 4))
    fk.chain_matrices(arm_vector(model), np.ascontiguousarray(joints, dtype=float), out)
    return out


def wrap_angle(angle: Any) -> np.ndarray:
    """Angle(s) mapped into (−π, π] (radians; floats or arrays, NaN stays NaN)."""
    angle = np.asarray(angle, dtype=float)
    wrapped = angle - 2.0 * math.pi * np.rint(angle / (2.0 * math.pi))
    wrapped = np.where(wrapped <= -math.pi, wrapped + 2.0 * math.pi, wrapped)   # rounding can land a hair outside
    result: np.ndarray = np.where(wrapped > math.pi, wrapped - 2.0 * math.pi, wrapped)
    return result


def ik_all_batch(model: Any, poses: Any, q_ref: Any = None) -> np.ndarray:
    """(N, 8, 6) every FK-verified solution of (N, 8) TCP poses, in (−π, π]; NaN rows where a branch is absent,
    repeats an earlier one or misses the pose. Slot k of every pose is the same sign choice (θ1, θ5, θ3), + first.
    ``q_ref`` ((6,) or (N, 6), optional) only resolves the wrist singularity, as in ``ik_all``."""
    rows = unit_pose_rows(poses)
    theta6 = np.zeros(len(rows)) if q_ref is None else wrap_angle(joint_rows(q_ref, len(rows), "q_ref")[:, 5])
    out = np.empty((len(rows), 8, 6))
    kernels()[1].all_rows(arm_vector(model), rows, np.ascontiguousarray(theta6), out)
    return out


def ik_all(model: Any, pose: Any, q_ref: Any = None) -> list[np.ndarray]:
    """Every FK-verified joint solution (radians, each in (−π, π]) of the TCP ``pose`` (base frame), up to 8.

    ``q_ref`` (optional) only resolves the wrist singularity: there θ6 is q_ref[5] (0 without one) when the arm
    reaches with it (see the module notes). Raises UnreachablePoseError (a ValueError) saying why when there is none.
    """
    row = pose_row(pose)
    theta6 = np.zeros(1) if q_ref is None else np.array([wrap_angle(joint_floats(q_ref, "q_ref")[5])])
    out = np.empty((1, 8, 6))
    kernels()[1].all_rows(arm_vector(model), row, theta6, out)
    found = out[0][~np.isnan(out[0, :, 0])]
    if not len(found):
        reason, lengths = _unreachable_reason(model, row[0])
        raise UnreachablePoseError(f"pose unreachable for {model.name}: {reason}", measured=lengths)
    return list(found)


def ik_batch(model: Any, poses: Any, q_ref: Any, weights: Any = None) -> np.ndarray:
    """(N, 6): for each (N, 8) TCP pose the solution nearest q_ref ((6,) or (N, 6)) as ``ik`` finds it; NaN rows
    where the pose is unreachable or no solution lies inside the joint limits (no exception: batches keep going)."""
    rows = unit_pose_rows(poses)
    references, weight = joint_rows(q_ref, len(rows), "q_ref"), joint_weights(weights)
    out, status = np.empty((len(rows), 6)), np.empty(len(rows), dtype=np.int64)
    kernels()[1].nearest_rows(arm_vector(model), rows, references, weight, out, status)
    return out


def ik(model: Any, pose: Any, q_ref: Any, weights: Any = None) -> np.ndarray:
    """The joint solution of TCP ``pose`` nearest ``q_ref`` (least Σ wᵢ·Δqᵢ² over the ±2π variants inside the limits).

    The choice a replay needs: the arm never flips branch while a nearer solution exists. At the wrist singularity
    θ6 stays at q_ref[5] unless the arm cannot reach with it or θ4 would leave its limits. The FK filter runs on the
    joints returned. Raises UnreachablePoseError when no solution lies inside the joint limits, saying why.
    """
    row = pose_row(pose)
    reference, weight = np.array([joint_floats(q_ref, "q_ref")]), joint_weights(weights)
    out, status = np.empty((1, 6)), np.empty(1, dtype=np.int64)
    _, nearest, solve = kernels()
    nearest.nearest_rows(arm_vector(model), row, reference, weight, out, status)
    if status[0] == solve.OUTSIDE_LIMITS:
        raise UnreachablePoseError(f"pose unreachable for {model.name}: outside limits — every solution has a joint "
                                   "outside the joint limits")
    if status[0] == solve.UNREACHABLE:
        reason, lengths = _unreachable_reason(model, row[0])
        raise UnreachablePoseError(f"pose unreachable for {model.name}: {reason}", measured=lengths)
    answer: np.ndarray = out[0]
    return answer


def _unreachable_reason(model: Any, pose: np.ndarray) -> tuple[str, list[Measured]]:
    """Why ``pose`` (8 unit coefficients) has no solution on ``model``: the first constraint it violates, in words
    whose lengths are ``{0}`` and ``{1}`` (the error's measured values, shown in its reader's units)."""
    arm, figures = arm_vector(model), np.empty(6)
    kernels()[1].reach_figures(arm, pose, figures)
    d4 = abs(arm[LENGTHS + 3])
    if figures[0] < d4 * (1.0 - DOMAIN_TOLERANCE):
        return ("too close to the base axis: the wrist centre is {0} from it, less than the shoulder offset d4 = {1}",
                _lengths(figures[0], d4))
    a2, a3 = abs(arm[LENGTHS + 1]), abs(arm[LENGTHS + 2])
    needed, longest, shortest = figures[1:5], a2 + a3, abs(a2 - a3)
    prefix = "wrist singular (θ5 = 0 or π) and no θ4 ± θ6 split reaches: " if figures[5] == 1.0 else ""
    if np.all(needed > longest):
        return (prefix + "too far: the elbow would have to span {0}, the upper and lower arm reach at most {1}",
                _lengths(needed.min(), longest))
    if np.all(needed < shortest):
        return (prefix + "too close: the elbow would have to span {0}, the folded arm reaches no closer than {1}",
                _lengths(needed.max(), shortest))
    return "no analytic branch passes the FK filter (numerically singular pose)", []


def _lengths(*metres: float) -> list[Measured]:
    return [Measured(float(value), LENGTH, si_digits=4) for value in metres]


def nearest_variant(model: Any, q: Any, reference: Any) -> np.ndarray:
    """(6,) each joint of ``q`` moved by a multiple of 2π to its value inside the model's limits nearest
    ``reference`` (the rule ``ik`` applies); inf where a joint has none. A variant within LIMIT_ROUNDING past a
    limit is that limit."""
    angles, references = joint_rows(q, 1, "q")[0], joint_rows(reference, 1, "reference")[0]
    arm, solve = arm_vector(model), kernels()[2]
    return np.array([solve.closest_variant(float(a), float(r), float(arm[LOWER + j]), float(arm[UPPER + j]),
                                           LIMIT_ROUNDING)[0]
                     for j, (a, r) in enumerate(zip(angles.tolist(), references.tolist(), strict=False))])


def joint_variants(model: Any, q: Any) -> np.ndarray:
    """(M, 6) every q + 2πk (per joint) inside the model's limits; an unlimited joint is listed within ±2π.

    A variant within LIMIT_ROUNDING past a limit is listed at the limit, as ``ik`` takes it."""
    per_joint = []
    for angle, low, high in zip(joint_rows(q, 1, "q")[0].tolist(), model.joint_lower, model.joint_upper, strict=False):
        low, high = max(low, -2.0 * math.pi), min(high, 2.0 * math.pi)
        first = angle + 2.0 * math.pi * math.ceil((low - LIMIT_ROUNDING - angle) / (2.0 * math.pi))
        stop = high + LIMIT_ROUNDING
        values = np.arange(first, stop, 2.0 * math.pi) if first <= stop else np.empty(0)
        per_joint.append(np.clip(values, low, high))
    grids = np.meshgrid(*per_joint, indexing="ij")
    return np.stack([grid.ravel() for grid in grids], axis=-1)


def warm() -> None:
    """Run every kernel once (a nominal and a calibrated arm: the same compiled code), so numba compiles or loads
    them all now."""
    from ur3dq.kinematics import fk
    from ur3dq.kinematics.ur_ik import nearest, solve
    lengths, limit = (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819), np.full(6, 2.0 * math.pi)
    a, d = np.array([0.0, lengths[1], lengths[2], 0.0, 0.0, 0.0]), np.array([lengths[0], 0, 0, *lengths[3:]])
    alpha, identity = np.array([math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0]), np.eye(1, 8)[0]
    q, pose = np.array([[0.1, -1.2, 1.3, -0.4, 0.9, 0.2]]), np.empty((1, 8))
    for calibrated in (False, True):
        arm = vector(a, d, alpha, np.full(6, 1e-4 * calibrated), lengths, identity, -limit, limit)
        tangents = np.empty((6, 1))
        fk.half_tangent_angles(q, tangents)
        fk.nominal_poses(arm, identity, np.tan(tangents), pose)
        fk.nominal_pose(arm, identity, *q[0].tolist())
        solve.closest_variant(0.0, 0.0, -1.0, 1.0, LIMIT_ROUNDING)
        nearest.all_rows(arm, pose, np.zeros(1), np.empty((1, 8, 6)))
        nearest.nearest_rows(arm, pose, q, UNIT_WEIGHTS, np.empty((1, 6)), np.empty(1, dtype=np.int64))
        nearest.reach_figures(arm, pose[0], np.empty(6))
        fk.chain_matrices(arm, q, np.empty((1, 7, 4, 4)))

