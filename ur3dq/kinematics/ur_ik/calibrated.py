"""Calibrated arms: Newton steps on the full DH chain from the nominal closed-form branches."""
from __future__ import annotations

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import multiply_quaternion_coefficients
from ur3dq.kinematics.ur_ik.geometry import CALIBRATED_MAX_STEPS, CALIBRATED_TOLERANCE, _Geometry

#: Damping λ of the Newton steps (rad·m): far below any regular singular value of a UR Jacobian (≥ 1e-3 away from
#: singularities), so a regular step is Newton's to ~1e-12 relative.
_DAMPING = 1e-9
#: Below this error a step that does not halve it has hit rounding, not a basin boundary (Newton converges
#: quadratically from here: one regular step takes 1e-8 to ~1e-16).
_ROUNDING_CEILING = 1e-8


def _rotate(q, v) -> tuple:
    """Vector v rotated by unit quaternion q: v + 2w(u×v) + 2u×(u×v), u = vector part of q."""
    w, ux, uy, uz = q
    vx, vy, vz = v
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    return (vx + 2.0 * (w * cx + uy * cz - uz * cy), vy + 2.0 * (w * cy + uz * cx - ux * cz),
            vz + 2.0 * (w * cz + ux * cy - uy * cx))


def _refine_calibrated(g: _Geometry, branches: list, target) -> list:
    """Newton steps on the calibrated FK from the nominal branches; those that converge, as float tuples."""
    refined, residual = _refine_batch(g, np.array(branches, dtype=float), np.tile(np.array(target), (len(branches), 1)))
    return [tuple(q) for q, r in zip(refined.tolist(), residual.tolist()) if r <= CALIBRATED_TOLERANCE]


def _chain_frames(g: _Geometry, q: np.ndarray) -> list:
    """Frames 0…6 of standard DH joints q (M, 6) as (rotation 4-tuple, position 3-tuple) of (M,) arrays."""
    rotation = (np.ones(len(q)), np.zeros(len(q)), np.zeros(len(q)), np.zeros(len(q)))
    position = (np.zeros(len(q)), np.zeros(len(q)), np.zeros(len(q)))
    frames = [(rotation, position)]
    for i, (a, d, offset, cos_half_alpha, sin_half_alpha) in enumerate(g.joints):
        half = 0.5 * (q[:, i] + offset)
        ch, sh = np.cos(half), np.sin(half)
        step = _rotate(rotation, (a * (ch * ch - sh * sh), a * 2.0 * ch * sh, np.full(len(q), d)))
        position = tuple(p + s for p, s in zip(position, step))
        rotation = multiply_quaternion_coefficients(
            rotation, (ch * cos_half_alpha, ch * sin_half_alpha, sh * sin_half_alpha, sh * cos_half_alpha))
        frames.append((rotation, position))
    return frames


def _pose_residual(frame, target: np.ndarray) -> np.ndarray:
    """(M, 6) [position error (m), rotation error (rad, base frame)] from a frame to target pairs (M, 7)."""
    rotation, position = frame
    position_error = target[:, 4:] - np.stack(position, axis=-1)
    relative = dqarray.quaternion_multiply(target[:, :4], dqarray.quaternion_conjugate(np.stack(rotation, -1)))
    # 2·vec(q_t·q*) on the w ≥ 0 sheet: the rotation vector to first order (errors here are small).
    rotation_error = 2.0 * np.where(relative[:, :1] < 0.0, -1.0, 1.0) * relative[:, 1:]
    return np.concatenate((position_error, rotation_error), axis=-1)


def _geometric_jacobian(frames) -> np.ndarray:
    """(M, 6, 6) base-frame Jacobian [v; ω] of revolute DH joints: column i = [z_{i−1}×(p − o_{i−1}); z_{i−1}]."""
    end = np.stack(frames[-1][1], axis=-1)
    columns = []
    for rotation, position in frames[:-1]:
        w, x, y, z = rotation
        axis = np.stack((2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)), axis=-1)
        columns.append(np.concatenate((np.cross(axis, end - np.stack(position, axis=-1)), axis), axis=-1))
    return np.stack(columns, axis=-1)


def _refine_batch(g: _Geometry, q: np.ndarray, targets: np.ndarray):
    """Newton steps on the calibrated FK: (refined q (M, 6), final residual norm (M,)); rows of NaN stay NaN.

    A row stops when it is 100× inside CALIBRATED_TOLERANCE, or when, already below _ROUNDING_CEILING, a step no
    longer halves its error (the rounding floor of its table): iterating on would only stir rounding. Steps solve (JᵀJ + λ²I)·Δq = Jᵀe with a tiny λ, a
    Newton step wherever J is regular that stays bounded beside a singularity (no SVD per step).
    """
    q = q.copy()
    previous = np.full(len(q), np.inf)
    active = np.ones(len(q), dtype=bool)
    identity = np.eye(6) * _DAMPING ** 2
    for _ in range(CALIBRATED_MAX_STEPS):
        frames = _chain_frames(g, q)
        error = _pose_residual(frames[-1], targets)
        residual = np.linalg.norm(error, axis=-1)
        stalled = (residual >= 0.5 * previous) & (residual < _ROUNDING_CEILING)
        active &= (residual > 0.01 * CALIBRATED_TOLERANCE) & ~stalled
        if not np.any(active):
            break
        previous = np.where(active, residual, previous)
        jacobian = _geometric_jacobian(frames)
        transposed = np.swapaxes(jacobian, 1, 2)
        with np.errstate(invalid="ignore"):   # rows of NaN (branches that do not exist) stay NaN
            step = np.linalg.solve(transposed @ jacobian + identity, (transposed @ error[..., None]))[..., 0]
        q = q + np.where(active[:, None], step, 0.0)
    residual = np.linalg.norm(_pose_residual(_chain_frames(g, q)[-1], targets), axis=-1)
    return q, residual
