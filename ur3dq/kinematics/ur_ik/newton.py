"""Calibrated arms: Newton on the full DH chain (frames.chain_frames) from the closed form's branches, and the
isolation proof that lets ``ik`` keep the solution Newton reaches from q_ref as the nearest one.

A step solves the damped normal equations (JᵀJ + μI)·Δq = Jᵀe, J the 6×6 base-frame Jacobian and e the flange's
pose error (position; axial vector of R_goal·Rᵀ, the rotation vector to first order), μ = λ² + |e|²: Newton's step
near a solution wherever J is regular, a bounded one far from it or where J is singular.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.arm import CALIBRATED_TOLERANCE, CURVATURE, DH, LIMIT_ROUNDING
from ur3dq.kinematics.fk import chain_frames
from ur3dq.kinematics.jit import kernel
from ur3dq.kinematics.ur_ik.frames import FLANGE, FLANGE_MATRIX

#: Newton steps at most: a seed beside a singularity, or one that first leaves its basin, may need 13.
MAX_STEPS = 16
#: Damping λ (rad·m), far below any regular singular value of a UR Jacobian (≥ 1e-3 away from singularities).
DAMPING = 1e-9
#: Below this error a step that does not halve it has hit rounding (a factory table's floor is ≈ 3e-13): stop.
#: Above it a row keeps stepping: beside a singularity Newton converges linearly, which is not a floor.
ROUNDING_CEILING = 1e-11
#: Two solutions accepted at CALIBRATED_TOLERANCE have |F(x) − F(x′)| ≤ 4.5·tolerance (F: flange position and
#: rotation columns; the residual's rotation part is sin φ·axis, a column moves by ≤ √2·φ); 5 leaves room.
SOLUTION_GAP = 5.0 * CALIBRATED_TOLERANCE


@kernel
def pose_error(frames: np.ndarray, goal: np.ndarray, error: np.ndarray) -> float:
    """The flange's error against the goal into ``error`` (6: position, then the axial vector of R_goal·Rᵀ's skew
    part); returns the trace of R_goal·Rᵀ (1 + 2·cos φ: tells φ = π from φ = 0, where the axial vector vanishes)."""
    end, target = frames[6], goal[FLANGE_MATRIX:FLANGE_MATRIX + 9]
    for k in range(3):
        error[k] = goal[FLANGE + 4 + k] - end[9 + k]
        error[3 + k] = 0.0
    trace = 0.0
    for c in range(3):   # column c of R against column c of R_goal: ½·Σ r_c × t_c, and Σ r_c·t_c
        r0, r1, r2 = end[3 * c], end[3 * c + 1], end[3 * c + 2]
        t0, t1, t2 = target[c], target[3 + c], target[6 + c]
        error[3] += 0.5 * (r1 * t2 - r2 * t1)
        error[4] += 0.5 * (r2 * t0 - r0 * t2)
        error[5] += 0.5 * (r0 * t1 - r1 * t0)
        trace += r0 * t0 + r1 * t1 + r2 * t2
    return trace


@kernel
def normal_equations(frames: np.ndarray, error: np.ndarray, normal: np.ndarray, rhs: np.ndarray,
                     jacobian: np.ndarray) -> None:
    """JᵀJ (6, 6) and Jᵀe (6) of the Jacobian [z_i × (p − o_i); z_i] of joint i + 1 (axis and origin of frame i),
    row i of ``jacobian`` (6, 6: work space)."""
    end = frames[6]
    for i in range(6):
        z0, z1, z2 = frames[i, 6], frames[i, 7], frames[i, 8]
        l0, l1, l2 = end[9] - frames[i, 9], end[10] - frames[i, 10], end[11] - frames[i, 11]
        jacobian[i, 0], jacobian[i, 1], jacobian[i, 2] = z1 * l2 - z2 * l1, z2 * l0 - z0 * l2, z0 * l1 - z1 * l0
        jacobian[i, 3], jacobian[i, 4], jacobian[i, 5] = z0, z1, z2
    for i in range(6):
        rhs[i] = 0.0
        for k in range(6):
            rhs[i] += jacobian[i, k] * error[k]
        for j in range(i + 1):
            value = 0.0
            for k in range(6):
                value += jacobian[i, k] * jacobian[j, k]
            normal[i, j] = normal[j, i] = value


@kernel
def cholesky(matrix: np.ndarray, shift: float, floor: float, lower: np.ndarray) -> bool:
    """The Cholesky factor of matrix − shift·I (6, 6) into ``lower``; False if some pivot is not above ``floor``:
    with floor > 0 that pivot is raised to it (the damped solve goes on with a bounded step), with 0 it stops."""
    definite = True
    for j in range(6):
        pivot = matrix[j, j] - shift
        for k in range(j):
            pivot -= lower[j, k] * lower[j, k]
        if not pivot > floor:
            if floor == 0.0:
                return False
            definite, pivot = False, floor
        lower[j, j] = math.sqrt(pivot)
        for i in range(j + 1, 6):
            value = matrix[i, j]
            for k in range(j):
                value -= lower[i, k] * lower[j, k]
            lower[i, j] = value / lower[j, j]
    return definite


@kernel
def newton_step(frames: np.ndarray, error: np.ndarray, norm: float, step: np.ndarray, work: np.ndarray) -> None:
    """Δq (6) solving (JᵀJ + μI)·Δq = Jᵀe at ``frames`` for ``error`` of norm ``norm``, μ = λ² + |e|²: far from a
    solution (or beside a singularity) a Levenberg-Marquardt step of bounded length, near one Newton's step
    (Yamashita and Fukushima's choice, quadratic convergence kept). Pivots are floored at λ². ``work`` (4, 6, 6)
    is work space."""
    normal, lower, jacobian, rhs = work[0], work[1], work[2], work[3, 0]
    normal_equations(frames, error, normal, rhs, jacobian)
    cholesky(normal, -(DAMPING * DAMPING + norm * norm), DAMPING * DAMPING, lower)
    for i in range(6):   # L·y = rhs, then Lᵀ·Δq = y
        value = rhs[i]
        for k in range(i):
            value -= lower[i, k] * step[k]
        step[i] = value / lower[i, i]
    for i in range(5, -1, -1):
        value = step[i]
        for k in range(i + 1, 6):
            value -= lower[k, i] * step[k]
        step[i] = value / lower[i, i]


@kernel
def refine(arm: np.ndarray, q: np.ndarray, goal: np.ndarray, frames: np.ndarray) -> float:
    """Newton from joints q (6, refined in place) towards the goal's flange; returns the final error norm (inf when
    the flange ends facing away from its target, NaN for a NaN start).

    A row stops 100× inside CALIBRATED_TOLERANCE; or, below ROUNDING_CEILING, when a step no longer halves its
    error; or after MAX_STEPS. A growing error does not stop it: some seeds converge after a few growing steps."""
    error, step, work = np.empty(6), np.empty(6), np.empty((4, 6, 6))
    previous, norm, trace = math.inf, math.nan, 3.0
    for iteration in range(MAX_STEPS + 1):
        chain_frames(arm, q, frames)
        trace = pose_error(frames, goal, error)
        norm = math.sqrt(error[0] ** 2 + error[1] ** 2 + error[2] ** 2 + error[3] ** 2 + error[4] ** 2
                         + error[5] ** 2)
        going = norm > 0.01 * CALIBRATED_TOLERANCE and (norm < 0.5 * previous or norm >= ROUNDING_CEILING)
        if iteration == MAX_STEPS or not going:
            break
        newton_step(frames, error, norm, step, work)
        for k in range(6):
            q[k] += step[k]
        previous = norm
    return norm if trace > 1.0 or norm != norm else math.inf


@kernel
def proof_span(cost: float, least_weight: float) -> float:
    """The distance (rad, joint space) ``isolated`` must rule out around a Newton answer at weighted cost ``cost``
    (Σ wᵢ·Δqᵢ²) from its reference for it to be provably the nearest: a nearer solution lies within
    2·(√(c / min w) + √6·LIMIT_ROUNDING) of it (both within the first term of the reference, up to LIMIT_ROUNDING
    per joint), and twice that is required, for the rounding of σ."""
    return 4.0 * (math.sqrt(cost / least_weight) + math.sqrt(6.0) * LIMIT_ROUNDING)


@kernel
def isolated(arm: np.ndarray, q: np.ndarray, reach: float, frames: np.ndarray) -> bool:
    """Whether no other solution accepted at CALIBRATED_TOLERANCE lies within ``reach`` (rad, Euclidean in joint
    space, any ±2π shift) of the solution q (6), other than its own copies within ~SOLUTION_GAP/σ.

    Along x′ = x + d, |F(x′) − F(x) − G·d| ≤ ½·M·|d|² (arm.CURVATURE), and |G·d| ≥ σ·|d|, σ the least singular
    value of the 6×6 Jacobian J. Another solution has |F(x′) − F(x)| ≤ SOLUTION_GAP, so σ·t − ½·M·t² ≤ gap for
    t = |d|: t lies below the smaller root or beyond the larger, which exceeds ``reach`` exactly when σ exceeds
    σ_t = max(√(2·M·gap), min(M·t, M·t/2 + gap/t)), i.e. when JᵀJ − σ_t²·I is positive definite. The radius is at
    most 2σ/M with σ ≤ |J·e6| = √(1 + a6²): farther reaches fail without a Jacobian."""
    bound, gap = arm[CURVATURE], SOLUTION_GAP
    if not reach < 2.0 * math.sqrt(1.0 + arm[DH + 25] ** 2) / bound:
        return False
    needed = max(math.sqrt(2.0 * bound * gap), min(bound * reach, 0.5 * bound * reach + gap / reach))
    normal, rhs, lower, error = np.empty((6, 6)), np.empty(6), np.empty((6, 6)), np.zeros(6)
    chain_frames(arm, q, frames)
    normal_equations(frames, error, normal, rhs, np.empty((6, 6)))
    return cholesky(normal, needed * needed, 0.0, lower)
