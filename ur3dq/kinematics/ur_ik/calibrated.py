"""Calibrated arms: Newton steps on the full DH chain from the nominal closed-form branches."""
from __future__ import annotations

import numpy as np

from ur3dq.kinematics.ur_ik.geometry import CALIBRATED_MAX_STEPS, CALIBRATED_TOLERANCE, _Geometry

#: Damping λ of the Newton steps (rad·m): far below any regular singular value of a UR Jacobian (≥ 1e-3 away from
#: singularities), so a regular step is Newton's to ~1e-12 relative.
_DAMPING = 1e-9
#: Below this error a step that does not halve it has hit rounding: the floor of a factory table is ≈ 3e-13
#: (measured), so 1e-11 leaves 30× room. Above it a row keeps stepping: beside a singularity Newton converges
#: linearly (a step may take 1e-8 only to 2e-11, measured on a UR5e at |sin θ5| = 0.06), which is not a floor.
_ROUNDING_CEILING = 1e-11


def _refine_calibrated(g: _Geometry, branches: list, target) -> list:
    """Newton steps on the calibrated FK from the nominal branches; those that converge, as float tuples."""
    refined, residual = _refine_batch(g, np.array(branches, dtype=float), np.tile(np.array(target), (len(branches), 1)))
    return [tuple(q) for q, r in zip(refined.tolist(), residual.tolist()) if r <= CALIBRATED_TOLERANCE]


def _dh_columns(g: _Geometry) -> tuple:
    """(a, d, θ offset, cos α, sin α), each (6,): the full DH table of a geometry."""
    a, d, offset, cos_half, sin_half = (np.array(column) for column in zip(*g.joints))
    return a, d, offset, cos_half * cos_half - sin_half * sin_half, 2.0 * cos_half * sin_half


def _chain_matrices(table: tuple, q: np.ndarray) -> np.ndarray:
    """(M, 7, 4, 4) frames 0…6 of standard DH joints q (M, 6): homogeneous transforms, frame 0 the base.

    Newton's inner loop works on 4×4 matrices rather than dual quaternions for speed alone: all six joint
    transforms come from a few (M, 6) array operations and the chain is six batched matmuls, where the
    coefficient form costs ~70 small array operations per joint. What a solution is accepted on is still the
    dual-quaternion FK filter (fk_filter._meets / batch._fk_filter).
    """
    a, d, offset, cos_alpha, sin_alpha = table
    theta = q + offset
    c, s = np.cos(theta), np.sin(theta)
    joint = np.zeros(q.shape + (4, 4))
    joint[..., 0, 0], joint[..., 0, 1], joint[..., 0, 2], joint[..., 0, 3] = c, -s * cos_alpha, s * sin_alpha, a * c
    joint[..., 1, 0], joint[..., 1, 1], joint[..., 1, 2], joint[..., 1, 3] = s, c * cos_alpha, -c * sin_alpha, a * s
    joint[..., 2, 1], joint[..., 2, 2], joint[..., 2, 3] = sin_alpha, cos_alpha, d
    joint[..., 3, 3] = 1.0
    frames = np.empty((len(q), 7, 4, 4))
    frames[:, 0] = np.eye(4)
    frames[:, 1] = joint[:, 0]
    for i in range(1, 6):
        np.matmul(frames[:, i], joint[:, i], out=frames[:, i + 1])
    return frames


def _target_matrices(targets: np.ndarray) -> tuple:
    """(rotation (M, 3, 3), position (M, 3)) of target pairs (M, 7) = (qw, qx, qy, qz, px, py, pz)."""
    w, x, y, z = targets[:, 0], targets[:, 1], targets[:, 2], targets[:, 3]
    rotation = np.stack((1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y),
                         2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x),
                         2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)), -1)
    return rotation.reshape(-1, 3, 3), targets[:, 4:]


def _pose_residual(end: np.ndarray, target: tuple) -> np.ndarray:
    """(M, 6) [position error (m), rotation error (rad, base frame)] from end frames (M, 4, 4) to the target.

    The rotation error is the axial vector of the skew part of R_t·Rᵀ (sin θ·axis): the rotation vector to first
    order, which is all Newton needs (errors here are small)."""
    rotation_t, position_t = target
    relative = rotation_t @ np.swapaxes(end[:, :3, :3], 1, 2)
    error = np.empty((len(end), 6))
    error[:, :3] = position_t - end[:, :3, 3]
    error[:, 3] = 0.5 * (relative[:, 2, 1] - relative[:, 1, 2])
    error[:, 4] = 0.5 * (relative[:, 0, 2] - relative[:, 2, 0])
    error[:, 5] = 0.5 * (relative[:, 1, 0] - relative[:, 0, 1])
    return error


def _geometric_jacobian(frames: np.ndarray) -> np.ndarray:
    """(M, 6, 6) base-frame Jacobian [v; ω] of revolute DH joints: column i = [z_{i−1}×(p − o_{i−1}); z_{i−1}]."""
    axis, origin = frames[:, :6, :3, 2], frames[:, :6, :3, 3]
    lever = frames[:, 6, None, :3, 3] - origin
    jacobian = np.empty((len(frames), 6, 6))
    ax, ay, az = axis[..., 0], axis[..., 1], axis[..., 2]
    lx, ly, lz = lever[..., 0], lever[..., 1], lever[..., 2]
    jacobian[:, 0], jacobian[:, 1], jacobian[:, 2] = ay * lz - az * ly, az * lx - ax * lz, ax * ly - ay * lx
    jacobian[:, 3:] = np.swapaxes(axis, 1, 2)
    return jacobian


def _refine_batch(g: _Geometry, q: np.ndarray, targets: np.ndarray):
    """Newton steps on the calibrated FK: (refined q (M, 6), final residual norm (M,)); rows of NaN stay NaN.

    A row stops when it is 100× inside CALIBRATED_TOLERANCE; when, already below _ROUNDING_CEILING, a step no
    longer halves its error (the rounding floor of its table): iterating on would only stir rounding. A row whose
    error grows is not dropped: some seeds converge after a few growing steps (dropping them at the first growth
    lost 87 of 2001 solutions on 300 UR3 poses), so the stragglers take all CALIBRATED_MAX_STEPS, alone.
    Steps solve (JᵀJ + λ²I)·Δq = Jᵀe with a tiny λ, a Newton step wherever J is regular that stays bounded beside
    a singularity (no SVD per step).
    """
    q = q.copy()
    table, (rotation_t, position_t) = _dh_columns(g), _target_matrices(targets)
    residual, previous = np.full(len(q), np.inf), np.full(len(q), np.inf)
    active = np.ones(len(q), dtype=bool)
    identity = np.eye(6) * _DAMPING ** 2
    for step in range(CALIBRATED_MAX_STEPS + 1):
        rows = np.flatnonzero(active)   # converged rows drop out: a batch's last steps are for a few stragglers
        if rows.size == 0:
            break
        frames = _chain_matrices(table, q[rows])
        error = _pose_residual(frames[:, 6], (rotation_t[rows], position_t[rows]))
        residual[rows] = norm = np.linalg.norm(error, axis=-1)
        stalled = (norm >= 0.5 * previous[rows]) & (norm < _ROUNDING_CEILING)
        going = (norm > 0.01 * CALIBRATED_TOLERANCE) & ~stalled   # NaN rows (absent branches) stop here too
        previous[rows] = norm
        active[rows] = going
        if step == CALIBRATED_MAX_STEPS or not going.any():
            break
        jacobian = _geometric_jacobian(frames[going])
        transposed = np.swapaxes(jacobian, 1, 2)
        q[rows[going]] += np.linalg.solve(transposed @ jacobian + identity, transposed @ error[going, :, None])[..., 0]
    return q, residual
