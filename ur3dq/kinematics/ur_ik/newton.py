"""Calibrated arms: Newton on the full DH chain (frames.chain_frames) from the closed form's branches, and the
isolation proof that lets ``ik`` keep the solution Newton reaches from q_ref as the nearest one.

A step solves the damped normal equations (JᵀJ + μI)·Δq = Jᵀe, J the 6×6 base-frame Jacobian and e the flange's
pose error (position; axial vector of R_goal·Rᵀ, the rotation vector to first order), μ = λ² + |e|²: Newton's step
near a solution wherever J is regular, a bounded one far from it or where J is singular.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.arm import CALIBRATED_TOLERANCE, THIRD_DERIVATIVE
from ur3dq.kinematics.fk import chain_frames, cross
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
#: rotation columns, or those / √2; the residual's rotation part is sin φ·axis, a column moves by ≤ √2·φ).
SOLUTION_GAP = 5.0 * CALIBRATED_TOLERANCE
#: ``isolated`` decides with this much to spare: the rounding of its figures is ~1e-9 of them (cond(JᵀJ)·ε).
PROOF_MARGIN = 1e-3


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
    cholesky_solve(lower, rhs, step)


@kernel
def cholesky_solve(lower: np.ndarray, rhs: np.ndarray, out: np.ndarray) -> None:
    """``out`` (6) solving L·Lᵀ·out = rhs for ``cholesky``'s factor L (6, 6): L·y = rhs, then Lᵀ·out = y."""
    for i in range(6):
        value = rhs[i]
        for k in range(i):
            value -= lower[i, k] * out[k]
        out[i] = value / lower[i, i]
    for i in range(5, -1, -1):
        value = out[i]
        for k in range(i + 1, 6):
            value -= lower[k, i] * out[k]
        out[i] = value / lower[i, i]


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
def second_order(jacobian: np.ndarray, lower: np.ndarray) -> float:
    """β² = Σᵢⱼ |A·Fᵢⱼ|² for F = (p, r₁/√2, r₂/√2, r₃/√2) (flange position and rotation columns: then JᵀJ is
    normal_equations' matrix, ``lower`` its Cholesky factor, ``jacobian`` its rows [zₖ × ℓₖ, zₖ]), Fᵢⱼ its
    second derivatives and A = (JᵀJ)⁻¹Jᵀ. For i ≤ j, ∂²p/∂qᵢ∂qⱼ = zᵢ × (zⱼ × ℓⱼ) and ∂²r/∂qᵢ∂qⱼ = zᵢ × (zⱼ × r)
    (ℓⱼ = p − oⱼ: joint j turns what follows it about zⱼ, joint i ≤ j turns that and zⱼ about zᵢ), so row k of
    Jᵀ·Fᵢⱼ is (zₖ × ℓₖ)·(zᵢ × (zⱼ × ℓⱼ)) + ½·Σ_c (zₖ × r_c)·(zᵢ × (zⱼ × r_c)), that sum being (zᵢ × zⱼ)·zₖ
    (r_c orthonormal)."""
    row, solved, total = np.empty(6), np.empty(6), 0.0
    for j in range(6):
        axis, inner = (jacobian[j, 3], jacobian[j, 4], jacobian[j, 5]), (jacobian[j, 0], jacobian[j, 1], jacobian[j, 2])
        for i in range(j + 1):
            first = (jacobian[i, 3], jacobian[i, 4], jacobian[i, 5])
            moved, turned = cross(first, inner), cross(first, axis)
            for k in range(6):
                row[k] = (jacobian[k, 0] * moved[0] + jacobian[k, 1] * moved[1] + jacobian[k, 2] * moved[2] + 0.5
                          * (jacobian[k, 3] * turned[0] + jacobian[k, 4] * turned[1] + jacobian[k, 5] * turned[2]))
            cholesky_solve(lower, row, solved)
            total += (1.0 if i == j else 2.0) * (solved[0] ** 2 + solved[1] ** 2 + solved[2] ** 2 + solved[3] ** 2
                                                   + solved[4] ** 2 + solved[5] ** 2)
    return total


@kernel
def isolated(arm: np.ndarray, q: np.ndarray, reach: float, frames: np.ndarray) -> bool:
    """Whether no other solution accepted at CALIBRATED_TOLERANCE lies within ``reach`` (rad, Euclidean in joint
    space, any ±2π shift) of the solution q (6), other than its own copies within 2·a·SOLUTION_GAP (below).

    With F, J, A and β as in ``second_order``, Taylor's theorem at q gives F(q + d) − F(q) = J·d + ½·F″[d, d] + R
    with |R| ≤ M₃·|d|³/6 (arm.THIRD_DERIVATIVE). Another solution has |F(q + d) − F(q)| ≤ SOLUTION_GAP = g, and
    A·J = I, so d = A·(F(q + d) − F(q)) − ½·A·F″[d, d] − A·R; with t = |d|, a = √trace((JᵀJ)⁻¹) ≥ ‖A‖ and
    |A·F″[d, d]| ≤ β·t² (Cauchy–Schwarz over the pairs i, j):  1 ≤ a·g/t + ½·β·t + a·M₃·t²/6.  The right side is
    convex in t, so where it stays below 1 − PROOF_MARGIN at t = 2·a·g and at t = reach, no other solution lies
    between. β, taken at q, amplifies only the part of F″ along J's weak directions (a global bound of F″ times a
    holds far less often)."""
    normal, lower, jacobian, identity, column = np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)), np.eye(6), \
        np.empty(6)
    chain_frames(arm, q, frames)
    normal_equations(frames, np.zeros(6), normal, column, jacobian)
    if not cholesky(normal, 0.0, 0.0, lower):
        return False
    trace = 0.0   # trace((JᵀJ)⁻¹)
    for k in range(6):
        cholesky_solve(lower, identity[k], column)
        trace += column[k]
    a, beta = math.sqrt(trace), math.sqrt(second_order(jacobian, lower))
    near, cubic = 2.0 * a * SOLUTION_GAP, a * arm[THIRD_DERIVATIVE] / 6.0
    spare = [1.0 - PROOF_MARGIN - a * SOLUTION_GAP / t - 0.5 * beta * t - cubic * t * t for t in (near, reach)]
    return reach <= near or (spare[0] >= 0.0 and spare[1] >= 0.0)
