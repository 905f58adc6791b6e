"""Calibrated arms: Newton steps on the full DH chain from the nominal closed-form branches."""
from __future__ import annotations

import math
import threading

import numpy as np

from ur3dq.kinematics.ur_ik.geometry import (
    CALIBRATED_MAX_STEPS,
    CALIBRATED_TOLERANCE,
    FK_TOLERANCE_M,
    FK_TOLERANCE_RAD,
    LIMIT_ROUNDING,
    _Geometry,
)
from ur3dq.kinematics.ur_ik.newton_floats import (
    DAMPING_MATRIX,
    HOPELESS_STEP,
    ROUNDING_CEILING,
    damped_solve,
    float_frames,
    float_jacobian,
    float_joints,
    going_on,
    refine_row,
)

#: Rows up to which Newton steps in Python floats (newton_floats), a row at a time: ~15 µs a row against ~50 µs
#: for a batched step of any few rows (measured).
_FLOAT_ROWS = 2
#: Rows from which a Newton step runs the joint-major kernels: their fixed cost (~1 ms of numpy calls) beats the
#: batched matrices (~4.5 µs a row) from ≈ 200 rows (measured).
_COLUMN_ROWS = 256

_TERMS: dict = {}
_TERMS_LOCK = threading.Lock()   # drivers solve IK from their own threads


#: Rounding allowance (m per metre of the chain's Σ|a| + Σ|d| + |TCP|) of one FK evaluation in floats: six joints
#: each turn the frame's columns (a few ε each, ≲ 30ε accumulated) that the offsets, up to the length, then scale,
#: and add (ε·length): ≲ 33ε = 7e-15. Measured, the 4×4 chain and the model's dual quaternion FK differ by at most
#: 3.1e-16 per metre (3000 configurations of three test tables with 3–10 km of cancelling offsets).
_ROUNDING_PER_METRE = 1e-14


#: How far (rad) a joint of a solution may be from an exact 2π multiple of Newton's joint and keep _fk_implied's
#: verdict: ik_batch's ±2π variants round by a few ulps of 4π (~4e-15); a clamp onto a joint limit moves by up to
#: LIMIT_ROUNDING, and one beyond this goes through the FK filter.
VARIANT_SHIFT = 1e-12


def _fk_implied(g: _Geometry) -> bool:
    """Whether every row _refine_batch accepts (residual ≤ CALIBRATED_TOLERANCE) provably meets its pose's FK filter
    (fk_filter._fk_check), also with each joint moved by a 2π multiple and up to VARIANT_SHIFT; computed once per
    geometry (_cached_terms, _implied_by_residual).

    Such a row's flange is within its residual of the target: position error ≤ CALIBRATED_TOLERANCE and, facing
    it (_refine_batch), rotation φ ≤ CALIBRATED_TOLERANCE (rad; the filter allows FK_TOLERANCE_RAD, ten times
    that). The TCP, at |t| from the flange, then misses by ≤ (1 + |t|)·CALIBRATED_TOLERANCE; six joint shifts turn
    it by ≤ 6·VARIANT_SHIFT and move it by ≤ 6·VARIANT_SHIFT·(R + |t|), R ≥ the flange's distance from every axis
    (_curvature_bound's); the Newton residual and the filter's FK each round by ≤ _ROUNDING_PER_METRE·length. When
    the position stays within half FK_TOLERANCE_M and twice the rotation within half FK_TOLERANCE_RAD (|t| up to
    ~3 m on factory tables, ~1 m on 10 km of offsets; the other half for what the sums leave out, such as a target
    quaternion off unit by up to fk_filter._EXACT_UNIT) the filter's verdict is known: True.
    """
    return _cached_terms(g)[3]


def _implied_by_residual(g: _Geometry, reach: float) -> bool:
    """_fk_implied's value, from the geometry's lengths, TCP and ``reach`` (R of _curvature_bound)."""
    lever = 0.0 if g.tcp_offset is None else 2.0 * math.sqrt(sum(v * v for v in g.tcp_offset[1]))
    length = sum(abs(a) + abs(d) for a, d, *_ in g.joints) + lever
    position = ((1.0 + lever) * CALIBRATED_TOLERANCE + 6.0 * VARIANT_SHIFT * (reach + lever)
                + 2.0 * _ROUNDING_PER_METRE * length)
    return (position <= 0.5 * FK_TOLERANCE_M
            and 2.0 * (CALIBRATED_TOLERANCE + 6.0 * VARIANT_SHIFT) <= 0.5 * FK_TOLERANCE_RAD)


def _joint_terms(g: _Geometry) -> tuple:
    """(angle shifts (6, 1, 3), terms (6, 3, 16)) of the geometry's joints.

    A standard DH joint is T(θ) = cos θ·A + sin θ·B + 1·C with constant A, B, C (4×4, flattened to 16): all six
    joints of M configurations are one (6, M, 3) @ (6, 3, 16) matmul, its left side (cos θ, sin θ, 1) one np.cos
    of (θ, θ, 0) + (offset, offset − π/2, 0). Each entry of T is one of the three products (the others are exact
    zeros), so the matmul rounds nothing. Cached per geometry (kept alive with its entry, so its id cannot be
    reused), like geometry._geometry, together with _curvature_bound's value.
    """
    return _cached_terms(g)[0]


def _curvature_bound(g: _Geometry) -> float:
    """M: |F″(x)(d, d)| ≤ M·|d|² for every x and d (6,), F = (flange position, the three columns of its rotation).

    For joint i before or at j, ∂²F/∂θi∂θj = z_i × (z_j × (v − o_j)) (Jacobi's identity), v the position (or a
    rotation column, with o_j = 0): at most the distance of the flange from axis j (or 1). That distance is at most
    R = Σ |P_k − P_k−1| + |flange − P_6|, P_1 the base origin and P_k the foot of P_k−1 on axis k: P_k lies on
    axis k and is fixed in link k−1's frame, hence in link k's, so every term is a constant of the arm (evaluated
    at q = 0; ~a2 + a3 + d4 + d5 + d6, whatever the table's cancelling d offsets). With (Σ|dᵢ|)² ≤ 6·|d|², the
    position and three columns give M = 6·√(R² + 3).
    """
    return _cached_terms(g)[1]


def _cached_terms(g: _Geometry) -> tuple:
    """(_joint_terms, _curvature_bound, newton_floats.float_joints, _fk_implied) of a geometry, computed once."""
    cached = _TERMS.get(id(g))
    if cached is not None and cached[0] is g:
        return cached[1]
    shift = np.array([[joint[2], joint[2] - 0.5 * math.pi, 0.0] for joint in g.joints])
    basis = np.zeros((6, 3, 4, 4))
    for i, (a, d, _, cos_half, sin_half) in enumerate(g.joints):
        cos_alpha, sin_alpha = cos_half * cos_half - sin_half * sin_half, 2.0 * cos_half * sin_half
        basis[i, 0] = [[1.0, 0.0, 0.0, a], [0.0, cos_alpha, -sin_alpha, 0.0], [0.0] * 4, [0.0] * 4]
        basis[i, 1] = [[0.0, -cos_alpha, sin_alpha, 0.0], [1.0, 0.0, 0.0, a], [0.0] * 4, [0.0] * 4]
        basis[i, 2] = [[0.0] * 4, [0.0] * 4, [0.0, sin_alpha, cos_alpha, d], [0.0, 0.0, 0.0, 1.0]]
    terms = (shift.reshape(6, 1, 3), basis.reshape(6, 3, 16))
    frames = _chain_frames(terms, np.zeros((1, 6)))[:, 0]
    foot, reach = np.zeros(3), 0.0
    for axis, origin in [(np.array([0.0, 0.0, 1.0]), np.zeros(3))] + [(f[:3, 2], f[:3, 3]) for f in frames[:5]]:
        step = axis * np.dot(foot - origin, axis) + origin - foot   # to the foot of ``foot`` on this axis
        foot, reach = foot + step, reach + float(np.linalg.norm(step))
    reach += float(np.linalg.norm(frames[5, :3, 3] - foot))
    value = (terms, 6.0 * math.sqrt(reach * reach + 3.0), float_joints(g.joints),
             _implied_by_residual(g, reach))
    with _TERMS_LOCK:
        if len(_TERMS) >= 64:
            _TERMS.pop(next(iter(_TERMS)))
        _TERMS[id(g)] = (g, value)
    return value


#: Multiplies each joint angle into _joint_terms' three cosines: θ, θ and 0 (the constant term's cos 0 = 1).
_ANGLE_SCALE = np.array([1.0, 1.0, 0.0])


def _chain_frames(terms: tuple, q: np.ndarray) -> np.ndarray:
    """(6, M, 4, 4) frames 1…6 of standard DH joints q (M, 6) in the base frame (frame 0 is the identity).

    Newton's inner loop works on 4×4 matrices rather than dual quaternions for speed alone: all six joint
    transforms are one batched matmul and the chain five more, where the coefficient form costs ~70 small array
    operations per joint. Joint-major, so that each frame is one contiguous block (a matmul on strided blocks costs
    twice as much). What a solution is accepted on is still the FK filter (fk_filter._fk_check /
    batch._fk_filter).
    """
    shift, basis = terms
    trig = np.cos(q.T[..., None] * _ANGLE_SCALE + shift)        # (6, M, 3): cos θ, sin θ, 1
    joints = (trig @ basis).reshape(6, len(q), 4, 4)
    frames = np.empty_like(joints)   # a separate output: an out= overlapping an input makes numpy copy first
    frames[0] = joints[0]
    for i in range(1, 6):
        np.matmul(frames[i - 1], joints[i], out=frames[i])
    return frames


def _rotation_of_products() -> np.ndarray:
    """(16, 9) map from the products q_a·q_b (a, b over w, x, y, z; row-major) of a unit quaternion to its rotation
    matrix minus the identity: 2·[[−yy−zz, xy−wz, xz+wy], [xy+wz, −xx−zz, yz−wx], [xz−wy, yz+wx, −xx−yy]]."""
    w, x, y, z = range(4)
    entries = (((y, y, -2), (z, z, -2)), ((x, y, 2), (w, z, -2)), ((x, z, 2), (w, y, 2)),
               ((x, y, 2), (w, z, 2)), ((x, x, -2), (z, z, -2)), ((y, z, 2), (w, x, -2)),
               ((x, z, 2), (w, y, -2)), ((y, z, 2), (w, x, 2)), ((x, x, -2), (y, y, -2)))
    matrix = np.zeros((16, 9))
    for entry, terms in enumerate(entries):
        for a, b, factor in terms:
            matrix[4 * a + b, entry] = factor
    return matrix


_ROTATION_OF_PRODUCTS = _rotation_of_products()
_IDENTITY_ROWS = np.eye(3).reshape(9)


def _target_matrices(targets: np.ndarray) -> tuple:
    """(rotation (M, 3, 3), position (M, 3)) of target pairs (M, 7) = (qw, qx, qy, qz, px, py, pz).

    The rotation is one matmul of the quaternion's outer products (four numpy calls whatever M: a single pose's
    target was ~30 calls on 1-element arrays, ~10 % of its Newton time)."""
    quaternion = targets[:, :4]
    products = (quaternion[:, :, None] * quaternion[:, None, :]).reshape(-1, 16)
    return (products @ _ROTATION_OF_PRODUCTS + _IDENTITY_ROWS).reshape(-1, 3, 3), targets[:, 4:]


#: (9, 4) map from a row-major 3×3 matrix to the axial vector of its skew part, ½·(m21 − m12, m02 − m20, m10 − m01),
#: and its trace m00 + m11 + m22.
_AXIAL_TRACE = np.zeros((9, 4))
_AXIAL_TRACE[[7, 2, 3], [0, 1, 2]], _AXIAL_TRACE[[5, 6, 1], [0, 1, 2]] = 0.5, -0.5
_AXIAL_TRACE[[0, 4, 8], 3] = 1.0


#: (9, 3) map from the outer product a ⊗ b (row-major) to a × b: (a1·b2 − a2·b1, a2·b0 − a0·b2, a0·b1 − a1·b0).
_CROSS = np.zeros((9, 3))
_CROSS[[5, 6, 1], [0, 1, 2]], _CROSS[[7, 2, 3], [0, 1, 2]] = 1.0, -1.0

#: Joint 1's Jacobian row after its first two entries: (z0 × p)_z = 0, then z0 = (0, 0, 1).
_BASE_ROW_TAIL = np.array([0.0, 0.0, 0.0, 1.0])


def _pose_residual(end: np.ndarray, rotation_t: np.ndarray, position_t: np.ndarray) -> np.ndarray:
    """(M, 7) [position error (m), rotation error (rad, base frame), trace of R_t·Rᵀ] from end frames (M, 4, 4) to
    the targets: the error is the first six columns.

    The rotation error is the axial vector of the skew part of R_t·Rᵀ (sin θ·axis): the rotation vector to first
    order, which is all Newton needs (errors here are small). It vanishes at θ = π too, which the trace, 1 + 2·cos θ,
    tells apart (same matmul, no extra numpy call)."""
    relative = rotation_t @ end[:, :3, :3].transpose(0, 2, 1)
    error = np.empty((len(end), 7))
    np.subtract(position_t, end[:, :3, 3], out=error[:, :3])
    np.matmul(relative.reshape(-1, 9), _AXIAL_TRACE, out=error[:, 3:])
    return error


def _jacobian_rows(frames: np.ndarray) -> np.ndarray:
    """(6, M, 6) base-frame Jacobian, joint-major: row i = [z_{i−1} × (p − o_{i−1}), z_{i−1}] of joint i + 1.

    Frame i−1 of joint i: the base (z = (0, 0, 1) at the origin) for joint 1, else frames[i − 2]. The five cross
    products are one matmul of the outer products z ⊗ (p − o) (5, M, 9) with _CROSS: ~11 µs for 8 rows against
    ~15 for the products of cyclic shifts (measured), the same sums.
    """
    rows = np.empty((6, frames.shape[1], 6))
    end = frames[5, :, :3, 3]
    rows[0, :, 0], rows[0, :, 1], rows[0, :, 2:] = -end[:, 1], end[:, 0], _BASE_ROW_TAIL
    axis = frames[:5, :, :3, 2]
    lever = end - frames[:5, :, :3, 3]
    np.matmul((axis[..., :, None] * lever[..., None, :]).reshape(5, -1, 9), _CROSS, out=rows[1:, :, :3])
    rows[1:, :, 3:] = axis
    return rows


def _matrix_residual(terms: tuple, q: np.ndarray, target: tuple) -> tuple:
    """(error (R, 7) as _pose_residual's, frames (6, R, 4, 4)) of joints q (R, 6) against target (rotation, position)
    rows."""
    frames = _chain_frames(terms, q)
    return _pose_residual(frames[5], *target), frames


def _matrix_step(frames: np.ndarray, error: np.ndarray) -> tuple:
    """((R, 6) Newton steps solving J·Δq = e, whether LAPACK's LU solved every row: False where some J was exactly
    singular and every row took its least-squares step, newton_floats.damped_solve) for frames (6, R, 4, 4) and
    errors e (R, ≥ 6: _pose_residual's, the trace column unused).

    The other kernels solve the damped normal equations (JᵀJ + λ²I)·Δq = Jᵀe; with λ = 1e-9 that is the same step
    to rounding wherever J is regular, and beside a singularity both are as long (|Δq| up to |e|/σ or |e|/2λ). J
    itself spares two matmuls and an addition: a step of 8 rows 24.3 → 18.7 µs, calibrated ik_all ~10 % (measured).
    """
    delta, solved = damped_solve(_jacobian_rows(frames).transpose(1, 2, 0), error[:, :6, None])
    return delta[..., 0], solved


#: Below this error norm a row's Newton step may be its last (_stepped_bound): a step there is ≲ 1e-6 rad, where
#: ½·M·|Δq|² can fall under the stopping error (100× inside CALIBRATED_TOLERANCE); above it no bound is computed.
_LAST_STEP_ERROR = 1e-7
#: Allowance (in the residual's units) for what _stepped_bound leaves out, all rounding: q + Δq (each joint moves
#: by ≤ ε·|q| ≲ 3e-15 rad, the flange by ≤ √6·3e-15·√(R² + 2) ≲ 2e-14 for R ≤ 2 m); LU's backward error,
#: |e − J·Δq| ≤ γ₁₈·(growth ≤ 2⁵)·n·|J|·|Δq| ≲ 1e-12·|Δq| (Higham, Accuracy and Stability, thm 9.4), under
#: 1e-18 at the steps it is asked for; the bound's own sums (~1e-16 of its terms).
_STEP_ROUNDING = 1e-13
#: _stepped_bound's factor of |e|·|Δq|: 1.25·√6 rounded up.
_ROTATION_LEVER = 2.0 * math.sqrt(6.0)


def _stepped_bound(error: np.ndarray, norm: np.ndarray, delta: np.ndarray, curvature: float) -> float:
    """A bound on the residual norm of every row after its LU-solved Newton step Δq (R, 6) (J·Δq = e to
    rounding), from the errors e (R, 7: _pose_residual's), of norms ``norm`` (R,), at the joints they step from; inf
    where some flange is not within 60° of its target (trace of R_t·Rᵀ ≤ 2). ``curvature``: _curvature_bound's M.

    The residual is affine in F = (position, the end rotation's three columns): e = L(F) (target minus position,
    and ½·Σ_c r_c × t_c over the columns). So e(q + Δq) = e(q) + L′·F′(q)·Δq + L′·ρ with |L′·ρ| ≤ |ρ| ≤ ½·M·|Δq|²
    (_curvature_bound). L′·F′(q)·Δq is −J·Δq in position; in rotation it is ½·(S·ω − tr S·ω) − ω, where ω = J_ω·Δq
    (|ω| ≤ √6·|Δq|, six unit axes) and S = R·R_tᵀ − I: |S| ≤ φ, |tr S| ≤ φ², the flange φ < 60° from its target
    with sin φ = |e_ω| ≤ |e|, so that term is below 1.25·|e|·|ω|. With e − J·Δq = 0 up to rounding
    (_STEP_ROUNDING), |e(q + Δq)| ≤ 2·√6·|e|·|Δq| + ½·M·|Δq|² + _STEP_ROUNDING, here with the largest |e| and
    |Δq| of the rows. It bounds the exact residual, as the one _refine_batch measures does up to the FK's rounding
    (calibrated._fk_implied allows for both alike)."""
    if not error[:, 6].min() > 2.0:
        return math.inf
    size = math.sqrt(np.einsum("ij,ij->i", delta, delta).max())
    return size * (_ROTATION_LEVER * float(norm.max()) + 0.5 * curvature * size) + _STEP_ROUNDING


def _column_residual(g: _Geometry, q: np.ndarray, target: tuple) -> tuple:
    """(error (R, 7), (axes, origins) of frames 0…6) of joints q (R, 6): the matrix path's quantities, joint-major.

    Every coordinate is an (R,) array (row of a (3, R) vector) and the chain is written out per column:
    for thousands of rows numpy's batched 4×4 matmuls and 6×6 LAPACK solves cost ~0.3 µs and ~0.8 µs per matrix,
    where one elementwise operation costs ~0.5 ns per row (measured on the benchmark machine).
    """
    end, frames = _column_frames(g, q)
    rotation_t, position_t = target
    error = np.empty((len(q), 7))
    for k in range(3):
        np.subtract(position_t[:, k], frames[1][6][k], out=error[:, k])
    # ½·Σ_c r_c × t_c over the columns c of the end rotation and the target's: the axial vector of the skew part
    # of R_t·Rᵀ, as _pose_residual computes it.
    for k, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
        error[:, 3 + k] = 0.5 * sum(end[c][i] * rotation_t[:, j, c] - end[c][j] * rotation_t[:, i, c]
                                    for c in range(3))
    error[:, 6] = sum(end[c][k] * rotation_t[:, k, c] for c in range(3) for k in range(3))   # Σ_c r_c · t_c
    return error, frames


def _column_frames(g: _Geometry, q: np.ndarray) -> tuple:
    """((x, y, z) columns of the end frame, (axes, origins) of frames 0…6) of joints q (R, 6), each vector a (3, R)
    array ((3, 1) for the base frame), its coordinate k the row [k]: the chain of _chain_frames written out per
    column, one operation for the three coordinates (a third of the calls of one per coordinate, same roundings)."""
    angles = q.T + np.array([joint[2] for joint in g.joints])[:, None]
    cos, sin = np.cos(angles), np.sin(angles)
    x, y, z, p = np.eye(4)[:3, :, None].transpose(1, 0, 2)   # base frame: its columns and origin, (3, 1)
    axes, origins = [z], [p]
    for c, s, (a, d, _, cos_half, sin_half) in zip(cos, sin, g.joints):
        cos_alpha, sin_alpha = cos_half * cos_half - sin_half * sin_half, 2.0 * cos_half * sin_half
        # T = Rz(θ)·Tz(d)·Tx(a)·Rx(α) on the frame's columns: x' = c·x + s·y, y'' = c·y − s·x, then α about x'.
        x, turned = c * x + s * y, c * y - s * x
        p = p + d * z + a * x
        y, z = cos_alpha * turned + sin_alpha * z, cos_alpha * z - sin_alpha * turned
        axes.append(z)
        origins.append(p)
    return (x, y, z), (axes, origins)


def _column_jacobian(frames: tuple) -> list:
    """Per joint its base-frame Jacobian column [z × (p − o), z] (6 coordinates, (R,) arrays, (1,) for the base
    frame's axis) from the (axes, origins) of _column_frames: the rows of _jacobian_rows, joint-major per column."""
    axes, origins = frames
    end = origins[6]
    columns = []
    for z, o in zip(axes[:6], origins[:6]):
        lever = end - o
        columns.append((z[1] * lever[2] - z[2] * lever[1], z[2] * lever[0] - z[0] * lever[2],
                        z[0] * lever[1] - z[1] * lever[0]) + tuple(z))
    return columns


def _column_step(frames: tuple, error: np.ndarray, damping: np.ndarray) -> np.ndarray:
    """(R, 6) joint steps solving (JᵀJ + λ²I)·Δq = Jᵀe, the normal equations and Cholesky written out per entry."""
    columns = _column_jacobian(frames)
    residual = error.T
    rhs = [sum(column[r] * residual[r] for r in range(6)) for column in columns]
    lower = [[None] * 6 for _ in range(6)]
    inverse_diagonal = []
    for j in range(6):
        for i in range(j, 6):
            entry = sum(columns[i][r] * columns[j][r] for r in range(6)) - sum(lower[i][k] * lower[j][k]
                                                                                 for k in range(j))
            if i == j:
                # A pivot of the damped normal matrix is ≥ λ² in exact arithmetic; rounding may take it below.
                inverse_diagonal.append(1.0 / np.sqrt(np.maximum(entry + damping[j, j], damping[j, j])))
            lower[i][j] = entry * inverse_diagonal[j]
    solution = [None] * 6
    for j in range(6):
        solution[j] = (rhs[j] - sum(lower[j][k] * solution[k] for k in range(j))) * inverse_diagonal[j]
    for j in reversed(range(6)):
        solution[j] = (solution[j] - sum(lower[k][j] * solution[k] for k in range(j + 1, 6))) * inverse_diagonal[j]
    return np.stack(solution, axis=-1)


def _refine_batch(g: _Geometry, q: np.ndarray, targets: np.ndarray, normals=None, patient=None):
    """Newton steps on the calibrated FK: (refined q (M, 6), final residual norm (M,)); rows of NaN stay NaN.

    ``normals`` (optional, (6, 6, M)): where a row stops in a step of the joint-major kernels its JᵀJ at its final
    joints is written there (_frames_normal of the step's frames: _isolated's _column_normal, not computed again).

    A row whose flange ends facing away from its target (rotated by more than 90°: Newton's rotation error sin φ·axis
    also vanishes at φ = π) has residual inf: every finite residual bounds the flange's distance to its target
    (position, and rotation angle φ = asin|sin φ|), what calibrated._fk_implied builds on.

    ``targets``: (M, 7) pairs, or one (1, 7) pair shared by every row.
    A row stops when it is 100× inside CALIBRATED_TOLERANCE; when, already below ROUNDING_CEILING, a step no
    longer halves its error (the rounding floor of its table): iterating on would only stir rounding. A row whose
    error grows is not dropped: some seeds converge after a few growing steps (dropping them at the first growth
    lost 87 of 2001 solutions on 300 UR3 poses). A row still above HOPELESS_ERROR after HOPELESS_STEP steps stops
    unless it is ``patient`` ((M,) bools; default every row): the seeds of a pose beside a singular wrist converge
    linearly, or after wandering, to solutions no other seed reaches (newton_floats.going_on); patient stragglers
    take up to CALIBRATED_MAX_STEPS, alone. In the batched-matrix kernels, when _stepped_bound proves that every
    row's step takes it inside the stopping error, the rows stop after that step without the FK that would
    measure them (mostly the third step: ~25 µs of ~250 for a calibrated ik_all; the FK's verdict would be the
    same, to the table's rounding).
    Steps solve (JᵀJ + λ²I)·Δq = Jᵀe with a tiny λ (the batched matrices J·Δq = e itself, _matrix_step), a Newton
    step wherever J is regular (no SVD per step). A step of _COLUMN_ROWS rows or more runs the joint-major kernels
    (_column_residual, _column_step), a smaller one the batched-matrix kernels, and from _FLOAT_ROWS rows down
    (the stragglers of a larger refinement) each row goes on alone in floats (newton_floats): the same quantities,
    the first cheap per row, the second in few numpy calls, the last without numpy's fixed cost per call.
    """
    q = q.copy()
    terms = _joint_terms(g)
    rotation_t, position_t = _target_matrices(targets)
    shared = len(targets) == 1
    residual = np.full(len(q), np.inf)
    # The active rows' joints, last errors and indices in q, kept compact: rows that stop are written back once.
    rows, current, previous = np.arange(len(q)), q, np.full(len(q), np.inf)
    patient = np.ones(len(q), dtype=bool) if patient is None else np.asarray(patient, dtype=bool)
    for step in range(CALIBRATED_MAX_STEPS + 1):
        # The last rows of a refinement step cheaper in floats. A refinement of one or two rows from the start (ik's
        # row from q_ref) keeps the numpy kernels: the full ranking reaches the same solution through them, and a
        # solution at a joint limit must round alike in both (in floats it could land past the limit, and ik took
        # another configuration).
        if len(rows) <= _FLOAT_ROWS < len(q):
            _refine_in_floats(g, q, residual, (rows, current, previous, patient), (rotation_t, position_t), step)
            break
        target = (rotation_t, position_t) if shared else (rotation_t[rows], position_t[rows])
        columns = len(rows) >= _COLUMN_ROWS
        error, frames = (_column_residual(g, current, target) if columns
                         else _matrix_residual(terms, current, target))
        pose_error = error[:, :6]
        norm = np.sqrt(np.einsum("ij,ij->i", pose_error, pose_error))
        # Before HOPELESS_STEP, rows at or above ROUNDING_CEILING all go on (going_on): one reduction instead of its
        # six operations and two more, in most steps. False for NaN (an absent branch), which going_on stops.
        every = step < HOPELESS_STEP and len(norm) > 0 and norm.min() >= ROUNDING_CEILING
        going = None if every else going_on(norm, previous, step, patient)
        if step == CALIBRATED_MAX_STEPS or not (every or going.any()):
            q[rows], residual[rows] = current, _faced(norm, error)
            if columns and normals is not None:
                normals[:, :, rows] = _frames_normal(frames)
            break
        if columns:   # the kernel's columns are not sliced: rows stopping now take one more solve
            delta = _column_step(frames, error, DAMPING_MATRIX)
        if not (every or going.all()):   # converged rows drop out: a batch's last steps are for a few stragglers
            stop = ~going
            q[rows[stop]], residual[rows[stop]] = current[stop], _faced(norm[stop], error[stop])
            if columns and normals is not None:
                normals[:, :, rows[stop]] = _frames_normal(_row_frames(frames, stop))
            rows, current, norm = rows[going], current[going], norm[going]
            patient = patient[going]
            if columns:
                delta = delta[going]
            else:
                frames, error = frames[:, going], error[going]
        if not columns:
            delta, solved = _matrix_step(frames, error)
            # When every row's step provably ends it (mostly the third), they stop without one more FK: the joints
            # the FK would stop them at, as it would measure at most the bound plus its rounding (below the
            # stopping error on factory tables; where a table's floor is above, the FK's rows would stir on).
            bound = (_stepped_bound(error, norm, delta, _curvature_bound(g))
                     if solved and norm.max() <= _LAST_STEP_ERROR else math.inf)
            if bound <= 0.01 * CALIBRATED_TOLERANCE:
                q[rows], residual[rows] = current + delta, bound
                break
        current = current + delta
        previous = norm
    return q, residual


def _faced(norm: np.ndarray, error: np.ndarray) -> np.ndarray:
    """The residuals _refine_batch reports for error norms (R,) of errors (R, 7) (_pose_residual's): inf where the
    trace of R_t·Rᵀ, 1 + 2·cos φ, is not above 1."""
    return np.where(error[:, 6] > 1.0, norm, np.inf)


def _refine_in_floats(g: _Geometry, q: np.ndarray, residual: np.ndarray, state: tuple, target: tuple, step: int):
    """Newton's steps from ``step`` on of the active rows ``state`` = (indices into q (R,), their joints (R, 6),
    last errors (R,), patient (R,)), one row at a time in floats (newton_floats.refine_row); q (M, 6) and residual
    (M,) are written in place. ``target``: (rotation (M or 1, 3, 3), position (M or 1, 3))."""
    joints, (rotation_t, position_t) = _cached_terms(g)[2], target
    for row, start, previous, patient in zip(*(part.tolist() for part in state)):
        pose = 0 if len(position_t) == 1 else row
        pair = _float_pair(rotation_t[pose], position_t[pose])
        q[row], residual[row] = refine_row(joints, start, pair, (step, previous), patient)


def _float_pair(rotation: np.ndarray, position: np.ndarray) -> tuple:
    """A target rotation (3, 3) and position (3,) (_target_matrices') as the 12 floats newton_floats takes."""
    return tuple(rotation.ravel().tolist()) + tuple(position.tolist())


#: Bound on |F(x) − F(x′)| for two solutions accepted at CALIBRATED_TOLERANCE (F as in _curvature_bound): each is
#: within √(1 + 2·(π/2)²)·tolerance < 2.25·tolerance of the target (the residual's rotation part is sin φ·axis,
#: a column moves by ≤ √2·φ), so two are within 4.5·tolerance; 5 leaves room for rounding.
_SOLUTION_GAP = 5.0 * CALIBRATED_TOLERANCE


def _isolation_radius(g: _Geometry, q: np.ndarray) -> np.ndarray:
    """(M,) per solution q (M, 6): a radius (rad, Euclidean in joint space, any ±2π shift) within which no other
    solution accepted at CALIBRATED_TOLERANCE lies, except its own copies within ~_SOLUTION_GAP/σ; 0 if none.

    Along x′ = x + d, |F(x′) − F(x) − G·d| ≤ ½·M·|d|² (_curvature_bound), and G, the Jacobian of F, has
    |G·d|² = |J_p·d|² + 2·|J_ω·d|² ≥ (σ·|d|)² with σ the least singular value of the 6×6 Jacobian J. Another
    solution has |F(x′) − F(x)| ≤ _SOLUTION_GAP, so σ·t − ½·M·t² ≤ gap for t = |d|: t lies below the smaller root
    (the same solution) or beyond the larger, (σ + √(σ² − 2·M·gap))/M, returned here."""
    # σ² is the least eigenvalue of JᵀJ (eigvalsh costs 60 % of an SVD of J and is as exact: 1e-16·|J|²).
    return _radius_of_sigma(g, np.sqrt(np.maximum(np.linalg.eigvalsh(_normal_matrices(g, q))[:, 0], 0.0)))


def _radius_of_sigma(g: _Geometry, sigma: np.ndarray) -> np.ndarray:
    """_isolation_radius of solutions whose Jacobians' least singular values are ``sigma`` (any shape)."""
    bound = _curvature_bound(g)
    discriminant = sigma * sigma - 2.0 * bound * _SOLUTION_GAP
    return np.where(discriminant > 0.0, (sigma + np.sqrt(np.maximum(discriminant, 0.0))) / bound, 0.0)


def _normal_matrices(g: _Geometry, q: np.ndarray) -> np.ndarray:
    """(M, 6, 6) JᵀJ of the calibrated chain's Jacobian at joints q (M, 6), from the joint-major kernel for
    _COLUMN_ROWS rows or more (no 4×4 matmuls), from the float kernels for _FLOAT_ROWS or fewer, else from the
    batched matrices."""
    if len(q) >= _COLUMN_ROWS:
        return _column_normal(g, q).transpose(2, 0, 1)
    if len(q) <= _FLOAT_ROWS:   # ik's one row: the float kernels, ~25 µs less than the batched matrices
        joints = _cached_terms(g)[2]
        columns = [float_jacobian(float_frames(joints, row)[1]) for row in q.tolist()]
        transposed = np.array(columns).reshape(-1, 6, 6)
    else:
        transposed = _jacobian_rows(_chain_frames(_joint_terms(g), q)).transpose(1, 0, 2)
    return transposed @ transposed.transpose(0, 2, 1)


def _column_normal(g: _Geometry, q: np.ndarray) -> np.ndarray:
    """(6, 6, R) JᵀJ at joints q (R, 6) from the joint-major kernel, each entry one contiguous run of rows."""
    return _frames_normal(_column_frames(g, q)[1])


def _frames_normal(frames: tuple) -> np.ndarray:
    """(6, 6, R) JᵀJ from _column_frames' (axes, origins) of R rows."""
    jacobian = np.empty((6, 6, frames[1][6].shape[1]))   # (joint, coordinate, row)
    for joint, column in enumerate(_column_jacobian(frames)):
        for coordinate, value in enumerate(column):
            jacobian[joint, coordinate] = value
    return np.einsum("irn,jrn->ijn", jacobian, jacobian)   # 3× a matmul of the (R, 6, 6) transposes


def _row_frames(frames: tuple, rows) -> tuple:
    """_column_frames' (axes, origins) of the given rows only (the base frame's (3, 1) vectors, first, as they are)."""
    return tuple([vectors[0]] + [v[:, rows] for v in vectors[1:]] for vectors in frames)


def _largest_isolation_radius(g: _Geometry) -> float:
    """A bound on every _isolation_radius of the geometry: the radius is at most 2σ/M, and σ ≤ |J·e6| =
    |(z6 × (p − o6), z6)| = √(1 + a6²) (a reference ~0.04 rad or more from the answer is beyond it on a UR3)."""
    return 2.0 * math.sqrt(1.0 + g.joints[5][0] ** 2) / _curvature_bound(g)


def _proof_span(cost, least_weight: float):
    """The distance (rad, joint space; a float or an array like ``cost``) that _isolated must rule out around a
    Newton answer at weighted cost ``cost`` (Σ wᵢ·Δqᵢ²) from its reference for it to be provably the nearest: a
    solution nearer the reference than the answer lies within 2·(√(c / min w) + √6·LIMIT_ROUNDING) of it (both
    within the first term of the reference, up to LIMIT_ROUNDING per joint), and twice that is required, for the
    rounding of σ. nearest._reference_solution proves with it, nearest._proof_expected guesses with it and
    batch._calibrated_nearest proves a batch's rows with it."""
    root = np.sqrt(cost / least_weight) if isinstance(cost, np.ndarray) else math.sqrt(cost / least_weight)
    return 4.0 * (root + math.sqrt(6.0) * LIMIT_ROUNDING)


def _isolated(g: _Geometry, q: np.ndarray, reach: np.ndarray, normal=None) -> np.ndarray:
    """(M,) whether reach (M,) < _isolation_radius of solutions q (M, 6): no other accepted solution within it.
    ``normal`` (optional, (6, 6, M), NaN where unknown): _column_normal's JᵀJ of rows that _refine_batch computed
    (its ``normals``), not computed again.

    For _COLUMN_ROWS rows or more without eigenvalues (eigvalsh costs ~2 µs a matrix): the radius exceeds t = reach
    exactly when σ exceeds σ_t = max(√(2·M·gap), min(M·t, M·t/2 + gap/t)) (the larger root of ½·M·t² − σ·t + gap
    passes t), i.e. when JᵀJ − σ_t²·I is positive definite: a Cholesky written out per entry, every pivot > 0.
    """
    bound, gap = _curvature_bound(g), _SOLUTION_GAP
    possible = reach < _largest_isolation_radius(g)   # farther reaches fail without a Jacobian
    if not possible.all():
        decided = np.zeros(len(q), dtype=bool)
        if possible.any():
            decided[possible] = _isolated(g, q[possible], reach[possible],
                                          None if normal is None else normal[:, :, possible])
        return decided
    if len(q) < _COLUMN_ROWS:
        return reach < _isolation_radius(g, q)
    needed = np.maximum(math.sqrt(2.0 * bound * gap), np.minimum(bound * reach, 0.5 * bound * reach + gap / reach))
    if normal is None:
        normal = _column_normal(g, q)
    else:
        missing = np.isnan(normal[0, 0])
        if missing.any():
            normal[:, :, missing] = _column_normal(g, q[missing])
    shift = needed * needed
    lower = [[None] * 6 for _ in range(6)]
    definite = np.ones(len(q), dtype=bool)
    for j in range(6):
        pivot = normal[j, j] - shift - sum(lower[j][k] * lower[j][k] for k in range(j))
        definite &= pivot > 0.0
        inverse_root = 1.0 / np.sqrt(np.where(pivot > 0.0, pivot, 1.0))   # a failed row goes on harmlessly
        for i in range(j + 1, 6):
            lower[i][j] = (normal[i, j] - sum(lower[i][k] * lower[j][k] for k in range(j))) * inverse_root
    return definite
