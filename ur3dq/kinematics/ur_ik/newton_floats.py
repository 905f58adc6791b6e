"""Newton on the calibrated DH chain for a single row in Python floats: the steps of one or two rows.

A step of calibrated._refine_batch's batched kernels costs ~50 µs whatever its rows (~40 numpy calls on tiny
arrays); the same step in floats, with one numpy solve of its 6×6 normal equations, costs ~15 µs a row
(measured), so the rows left after the others converged — stragglers that may run all CALIBRATED_MAX_STEPS — and
single rows step here. The quantities and their order of operations are those of calibrated._column_frames and
_column_residual, the step that of the damped normal equations (_column_step's; _matrix_step solves J·Δq = e
itself, the same step to rounding where J is regular).
"""
from __future__ import annotations

from math import cos, inf, sin, sqrt

import numpy as np

from ur3dq.kinematics.ur_ik.geometry import CALIBRATED_MAX_STEPS, CALIBRATED_TOLERANCE

#: Damping λ of the Newton steps (rad·m): far below any regular singular value of a UR Jacobian (≥ 1e-3 away from
#: singularities), so a regular step is Newton's to ~1e-12 relative.
DAMPING = 1e-9
#: Below this error a step that does not halve it has hit rounding: the floor of a factory table is ≈ 3e-13
#: (measured), so 1e-11 leaves 30× room. Above it a row keeps stepping: beside a singularity Newton converges
#: linearly (a step may take 1e-8 only to 2e-11, measured on a UR5e at |sin θ5| = 0.06), which is not a floor.
ROUNDING_CEILING = 1e-11
DAMPING_MATRIX = np.eye(6) * DAMPING ** 2   # λ²I of the normal equations
#: A row still above HOPELESS_ERROR after HOPELESS_STEP steps stops: it is wandering, not converging. Measured on
#: 2100 random poses of the 14 factory tables (16,800 seeds): 2188 seeds never converge and used to run all
#: CALIBRATED_MAX_STEPS (a pose with out-of-reach branches cost ~3× a regular one); of the seeds that did converge,
#: those still above 1e-3 after 6 steps (6 of them) all reached a solution another seed of the pose had found, and
#: every seed that reached a new solution was below 9e-5 (10× inside) by then.
HOPELESS_STEP = 6
HOPELESS_ERROR = 1e-3


def going_on(norm, previous, step: int, patient):
    """Whether a row whose error is ``norm`` at ``step`` after one of ``previous`` steps again (floats or arrays
    alike, ``patient`` too): outside 100× CALIBRATED_TOLERANCE, not stalled (below ROUNDING_CEILING without halving
    its error) and, unless patient, not hopeless (above HOPELESS_ERROR from HOPELESS_STEP on). NaN stops."""
    going = (norm > 0.01 * CALIBRATED_TOLERANCE) & ((norm < 0.5 * previous) | (norm >= ROUNDING_CEILING))
    return going & ((norm <= HOPELESS_ERROR) | patient) if step >= HOPELESS_STEP else going


def refine_row(joints: tuple, q: list, target: tuple, start: tuple, patient: bool) -> tuple:
    """(joints (6 floats), final error norm: inf where the flange ends facing away) of Newton on one row from q
    (6 floats), from ``start`` = (its step, the error before it) on, the stopping rule (``patient`` as going_on's)
    and residual of calibrated._refine_batch; ``joints`` from float_joints, ``target`` as float_residual takes it."""
    first, previous = start
    for step in range(first, CALIBRATED_MAX_STEPS + 1):
        end, frames = float_frames(joints, q)
        error = float_residual(end, frames, target)
        norm = sqrt(sum(e * e for e in error[:6]))
        if step == CALIBRATED_MAX_STEPS or not going_on(norm, previous, step, patient):
            break
        q = [v + d for v, d in zip(q, float_step(frames, error[:6], DAMPING_MATRIX))]
        previous = norm
    return q, norm if error[6] > 1.0 else inf


def float_joints(joints: tuple) -> tuple:
    """Per joint (a, d, θ offset, cos α, sin α) of a geometry's joints (a, d, θ offset, cos α/2, sin α/2)."""
    return tuple((a, d, offset, ch * ch - sh * sh, 2.0 * ch * sh) for a, d, offset, ch, sh in joints)


def float_frames(joints: tuple, q) -> tuple:
    """(end rotation's columns x, y, z (9 floats), per frame 0…6 its axis and origin (6 floats)) of six joint
    floats q; ``joints`` from float_joints. calibrated._column_frames on floats."""
    x0, x1, x2, y0, y1, y2, z0, z1, z2 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    p0 = p1 = p2 = 0.0
    frames = [(0.0, 0.0, 1.0, 0.0, 0.0, 0.0)]
    for angle, (a, d, offset, cos_alpha, sin_alpha) in zip(q, joints):
        c, s = cos(angle + offset), sin(angle + offset)
        # x' = c·x + s·y, y'' = c·y − s·x, the origin along the old z and the new x, then α about x'.
        x0, x1, x2, u0, u1, u2 = (c * x0 + s * y0, c * x1 + s * y1, c * x2 + s * y2,
                                  c * y0 - s * x0, c * y1 - s * x1, c * y2 - s * x2)
        p0, p1, p2 = p0 + d * z0 + a * x0, p1 + d * z1 + a * x1, p2 + d * z2 + a * x2
        y0, y1, y2, z0, z1, z2 = (cos_alpha * u0 + sin_alpha * z0, cos_alpha * u1 + sin_alpha * z1,
                                  cos_alpha * u2 + sin_alpha * z2, cos_alpha * z0 - sin_alpha * u0,
                                  cos_alpha * z1 - sin_alpha * u1, cos_alpha * z2 - sin_alpha * u2)
        frames.append((z0, z1, z2, p0, p1, p2))
    return (x0, x1, x2, y0, y1, y2, z0, z1, z2), frames


def float_residual(end: tuple, frames: list, target: tuple) -> tuple:
    """Pose error (6 floats: position, then the axial vector of R_t·Rᵀ's skew part) and trace of R_t·Rᵀ (a 7th
    float) of float_frames' end rotation and frames against ``target`` = (R_t row-major (9 floats), position
    (3 floats)); _column_residual on floats."""
    x0, x1, x2, y0, y1, y2, z0, z1, z2 = end
    r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2 = target
    _, _, _, p0, p1, p2 = frames[6]
    return (t0 - p0, t1 - p1, t2 - p2,
            0.5 * ((x1 * r20 - x2 * r10) + (y1 * r21 - y2 * r11) + (z1 * r22 - z2 * r12)),
            0.5 * ((x2 * r00 - x0 * r20) + (y2 * r01 - y0 * r21) + (z2 * r02 - z0 * r22)),
            0.5 * ((x0 * r10 - x1 * r00) + (y0 * r11 - y1 * r01) + (z0 * r12 - z1 * r02)),
            (x0 * r00 + x1 * r10 + x2 * r20) + (y0 * r01 + y1 * r11 + y2 * r21) + (z0 * r02 + z1 * r12 + z2 * r22))


def float_jacobian(frames: list) -> list:
    """The Jacobian's columns [z × (p − o), z] (6 tuples of 6 floats, one per joint) of float_frames' frames 0…5
    (calibrated._column_jacobian on floats)."""
    _, _, _, e0, e1, e2 = frames[6]
    columns = []
    for z0, z1, z2, o0, o1, o2 in frames[:6]:
        l0, l1, l2 = e0 - o0, e1 - o1, e2 - o2
        columns.append((z1 * l2 - z2 * l1, z2 * l0 - z0 * l2, z0 * l1 - z1 * l0, z0, z1, z2))
    return columns


def float_step(frames: list, error: tuple, damping: np.ndarray) -> list:
    """Joint step (6 floats) solving (JᵀJ + λ²I)·Δq = Jᵀe, ``damping`` = λ²I (6, 6) (DAMPING_MATRIX): the Jacobian
    of float_frames' frames in floats (float_jacobian), the 6×6 solve numpy's
    LAPACK one (one matrix: ~5 µs, a Cholesky written out in floats costs 13)."""
    return float_step_and_normal(frames, error, damping)[0]


def float_step_and_normal(frames: list, error: tuple, damping: np.ndarray) -> tuple:
    """(float_step's step (6 floats), the undamped JᵀJ (6, 6) it solved with): for a caller that also wants J's
    least singular value (nearest._proof_expected)."""
    transposed = np.array(float_jacobian(frames))   # Jᵀ: a row per joint
    normal = transposed @ transposed.T
    return damped_solve(normal + damping, (transposed @ error)[:, None])[0][:, 0].tolist(), normal


def damped_solve(matrix: np.ndarray, rhs: np.ndarray) -> tuple:
    """(matrix⁻¹·rhs of matrices (…, 6, 6) — damped normal matrices, or Jacobians — and right-hand sides
    (…, 6, 1) (numpy's LAPACK solve), whether LAPACK's LU solved them all).

    Where J is exactly singular (a seed at θ5 = 0 or π, a clamped elbow) λ² = 1e-18 is below the rounding of JᵀJ's
    entries and LAPACK may meet an exact zero pivot: then every matrix takes its least-squares solution, the null
    direction dropped as the damping would (numpy raised LinAlgError out of ik_all before), and the flag is False."""
    try:
        return np.linalg.solve(matrix, rhs), True
    except np.linalg.LinAlgError:
        pairs = zip(matrix.reshape(-1, 6, 6), rhs.reshape(-1, 6, rhs.shape[-1]))
        solutions = [np.linalg.lstsq(square, right, rcond=None)[0] for square, right in pairs]
        return np.array(solutions).reshape(rhs.shape), False
