"""Compiled kernels of :mod:`ur3dq.kinematics.dls`: both modes' errors, Jacobians and loops, and the damped solve.

Shapes: n joints; a chain is its product form (constants (n + 1, 8), revolute (n,), offsets (n,)); poses are
8-tuples (rw rx ry rz dw dx dy dz); ``directions``/``points`` (n, 3) are the joint axes of
:func:`~ur3dq.kinematics.chain_kernels.chain_axes`. Functions ending in ``_into`` write their result into their last
argument. Every function is plain Python too (``NUMBA_DISABLE_JIT=1``); :mod:`ur3dq.kinematics.dls` is the API.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.dualquat import conjugate_coefficients, multiply_quaternion_coefficients
from ur3dq.kinematics.chain_kernels import chain_axes, multiply, translation_of
from ur3dq.kinematics.jit import kernel

conjugate = kernel(conjugate_coefficients)
multiply_quaternions = kernel(multiply_quaternion_coefficients)

#: Below this |vec(r)| a rotation vector or exp derivative uses its Taylor series (as dqarray's).
SMALL_VECTOR = 1e-4
#: A Cholesky pivot below this fraction of the largest diagonal entry (a condition number past ~1e8, which would
#: cost Cholesky ~1e-8 of relative accuracy) hands the solve to the SVD.
CHOLESKY_PIVOT = 1e-8
TWO_PI = 2.0 * math.pi
#: A search whose last step held a joint on a limit ends when its error fell by less than STALL_DECREASE (relative)
#: over STALL_PASSES passes: pinned there, it is the case the improved mode's second search is for.
STALL_PASSES = 5
STALL_DECREASE = 1e-3


# ------------------------------------------------------------------------------------------------ acceptance
@kernel
def well_posed(goal: np.ndarray, q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, unit_tolerance: float) -> bool:
    """True when ``goal`` (8,) is a unit dual quaternion within ``unit_tolerance`` (|r| = 1, r·d = 0) and every
    joint of q0 is finite and within [lower, upper] (a NaN limit, or lower > upper, fails): the solver's inputs
    as it needs them. The validators of :mod:`ur3dq.kinematics.dls` say what is wrong when this is False."""
    norm = math.sqrt(goal[0] * goal[0] + goal[1] * goal[1] + goal[2] * goal[2] + goal[3] * goal[3])
    dot = goal[0] * goal[4] + goal[1] * goal[5] + goal[2] * goal[6] + goal[3] * goal[7]
    if not (abs(norm - 1.0) <= unit_tolerance and abs(dot) <= unit_tolerance):
        return False
    for i in range(q0.shape[0]):
        if not (math.isfinite(q0[i]) and lower[i] <= q0[i] <= upper[i]):
            return False
    return True


# ------------------------------------------------------------------------------------------ the damped solve
@kernel
def cholesky_solve_into(matrix: np.ndarray, rhs: np.ndarray, out: np.ndarray) -> bool:
    """Solve the symmetric positive definite (n, n) ``matrix``·x = ``rhs`` into ``out`` by Cholesky; False (out
    unspecified) when a pivot falls below CHOLESKY_PIVOT of the largest diagonal entry (singular to working use)."""
    n = rhs.shape[0]
    lower = np.zeros((n, n))
    largest = 0.0
    for i in range(n):
        largest = max(largest, matrix[i, i])
    for j in range(n):
        pivot = matrix[j, j]
        for k in range(j):
            pivot -= lower[j, k] * lower[j, k]
        if not pivot > CHOLESKY_PIVOT * largest:
            return False
        lower[j, j] = math.sqrt(pivot)
        for i in range(j + 1, n):
            value = matrix[i, j]
            for k in range(j):
                value -= lower[i, k] * lower[j, k]
            lower[i, j] = value / lower[j, j]
    for i in range(n):                     # L·y = rhs
        value = rhs[i]
        for k in range(i):
            value -= lower[i, k] * out[k]
        out[i] = value / lower[i, i]
    for i in range(n - 1, -1, -1):         # Lᵀ·x = y
        value = out[i]
        for k in range(i + 1, n):
            value -= lower[k, i] * out[k]
        out[i] = value / lower[i, i]
    return True


@kernel
def svd_damped_solve_into(jacobian: np.ndarray, error: np.ndarray, damping: float, out: np.ndarray) -> None:
    """Σ s_i/(s_i² + damping)·v_i·u_iᵀ·error over J's singular triplets, into ``out`` (n,): the damped step, and
    the pseudo-inverse step for damping 0 (singular values at rounding level dropped as rank deficiency).

    One-sided Jacobi (Hestenes): rotate column pairs of B = J·V until they are orthogonal; then b_i = s_i·u_i and
    the step is Σ v_i·(b_i·error)/(s_i² + damping).
    """
    m, n = jacobian.shape
    b = jacobian.copy()
    v = np.eye(n)
    for _ in range(64):
        rotated = False
        for i in range(n - 1):
            for j in range(i + 1, n):
                alpha, beta, gamma = 0.0, 0.0, 0.0
                for k in range(m):
                    alpha += b[k, i] * b[k, i]
                    beta += b[k, j] * b[k, j]
                    gamma += b[k, i] * b[k, j]
                if abs(gamma) <= 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                root = math.sqrt(1.0 + zeta * zeta)
                t = 1.0 / (zeta + root) if zeta >= 0.0 else -1.0 / (root - zeta)
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for k in range(m):
                    bi, bj = b[k, i], b[k, j]
                    b[k, i], b[k, j] = c * bi - s * bj, s * bi + c * bj
                for k in range(n):
                    vi, vj = v[k, i], v[k, j]
                    v[k, i], v[k, j] = c * vi - s * vj, s * vi + c * vj
        if not rotated:
            break
    squares = np.zeros(n)
    for i in range(n):
        for k in range(m):
            squares[i] += b[k, i] * b[k, i]
    rounding = 2.220446049250313e-16 * max(math.sqrt(squares.max()), 1.0)
    out[:] = 0.0
    for i in range(n):
        denominator = squares[i] + damping
        if denominator > rounding * rounding:
            along = 0.0
            for k in range(m):
                along += b[k, i] * error[k]
            for k in range(n):
                out[k] += v[k, i] * along / denominator
    return None


@kernel
def damped_least_squares_into(jacobian: np.ndarray, error: np.ndarray, damping: float, out: np.ndarray) -> None:
    """The h minimising ‖J·h − error‖² + damping·‖h‖² into ``out`` (n,): (JᵀJ + damping·I)·h = Jᵀ·error by
    Cholesky, by the SVD (:func:`svd_damped_solve_into`) where that system is singular to working precision."""
    m, n = jacobian.shape
    normal = np.empty((n, n))
    gradient = np.zeros(n)
    for i in range(n):
        for k in range(m):
            gradient[i] += jacobian[k, i] * error[k]
        for j in range(i + 1):
            value = 0.0
            for k in range(m):
                value += jacobian[k, i] * jacobian[k, j]
            normal[i, j] = value
            normal[j, i] = value
        normal[i, i] += damping
    if not cholesky_solve_into(normal, gradient, out):
        svd_damped_solve_into(jacobian, error, damping, out)
    return None


# -------------------------------------------------------------------------------------------- improved mode
@kernel
def rotation_vector(r: tuple[float, ...]) -> tuple[float, ...]:
    """Rotation vector (3-tuple), angle in [0, π], of a unit quaternion 4-tuple (r ≡ −r)."""
    sign = -1.0 if r[0] < 0.0 else 1.0
    w, x, y, z = sign * r[0], sign * r[1], sign * r[2], sign * r[3]
    n = math.sqrt(x * x + y * y + z * z)
    if n < SMALL_VECTOR:
        factor = 2.0 / w * (1.0 - n * n / 3.0)   # angle / n near n = 0 (w ≈ 1 there)
    else:
        factor = 2.0 * math.atan2(n, w) / n
    return (factor * x, factor * y, factor * z)


@kernel
def pose_error(sigma: tuple[float, ...], goal: tuple[float, ...]) -> tuple[float, ...]:
    """(t_goal − t, rotation vector of r_goal·r*): the pose error at the end effector, base frame (σ ≡ −σ)."""
    t, t_goal = translation_of(sigma), translation_of(goal)
    relative = multiply_quaternions((goal[0], goal[1], goal[2], goal[3]),
                                    (sigma[0], -sigma[1], -sigma[2], -sigma[3]))
    rotation = rotation_vector(relative)
    return (t_goal[0] - t[0], t_goal[1] - t[1], t_goal[2] - t[2], rotation[0], rotation[1], rotation[2])


@kernel
def geometric_jacobian_into(directions: np.ndarray, points: np.ndarray, revolute: np.ndarray, sigma: tuple[float, ...],
                            out: np.ndarray) -> None:
    """(6, n) [ṫ; ω] per unit joint rate into ``out``: u × (t − p) and u for a revolute joint, u and 0 for a
    prismatic one (t the end point): the derivative of :func:`pose_error` at zero error, negated."""
    t = translation_of(sigma)
    for i in range(directions.shape[0]):
        ux, uy, uz = directions[i, 0], directions[i, 1], directions[i, 2]
        if revolute[i]:
            rx, ry, rz = t[0] - points[i, 0], t[1] - points[i, 1], t[2] - points[i, 2]
            out[0, i], out[1, i], out[2, i] = uy * rz - uz * ry, uz * rx - ux * rz, ux * ry - uy * rx
            out[3, i], out[4, i], out[5, i] = ux, uy, uz
        else:
            out[0, i], out[1, i], out[2, i] = ux, uy, uz
            out[3, i], out[4, i], out[5, i] = 0.0, 0.0, 0.0
    return None


@kernel
def reach(points: np.ndarray, sigma: tuple[float, ...]) -> float:
    """Length of the polyline joint 1 → … → joint n → end; 1 when it is 0 (all axes meet at the end point)."""
    t = translation_of(sigma)
    length = 0.0
    n = points.shape[0]
    for i in range(n):
        end = (t[0], t[1], t[2]) if i == n - 1 else (points[i + 1, 0], points[i + 1, 1], points[i + 1, 2])
        dx, dy, dz = end[0] - points[i, 0], end[1] - points[i, 1], end[2] - points[i, 2]
        length += math.sqrt(dx * dx + dy * dy + dz * dz)
    return length if length > 0.0 else 1.0


@kernel
def limited_step_into(jacobian: np.ndarray, residual: np.ndarray, q: np.ndarray, lower: np.ndarray,
                      upper: np.ndarray, out: np.ndarray) -> bool:
    """Levenberg–Marquardt step with Chan's damping ½‖residual‖², into ``out``; re-solved without the joints it
    would push further past a limit they sit on (they keep 0), so it stays a descent step of the joints that move.
    Returns whether a joint was held so."""
    damping = 0.0
    for k in range(residual.shape[0]):
        damping += 0.5 * residual[k] * residual[k]
    work = jacobian.copy()
    held = False
    while True:
        damped_least_squares_into(work, residual, damping, out)
        blocked = False
        for i in range(q.shape[0]):
            if (q[i] <= lower[i] and out[i] < 0.0) or (q[i] >= upper[i] and out[i] > 0.0):
                work[:, i] = 0.0
                blocked = True
        if not blocked:
            return held
        held = True


@kernel
def improved_search(constants: np.ndarray, revolute: np.ndarray, offsets: np.ndarray, goal: tuple[float, ...],
                    q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, length: float, tolerance: float,
                    joint_log: np.ndarray, pose_log: np.ndarray, error_log: np.ndarray) -> int:
    """One Levenberg–Marquardt search from q0, iterates clamped into [lower, upper], translation rows divided by
    ``length``; logs every pass (q, σ, ‖pose error‖) and returns their count. Stops below ``tolerance``, when the
    clamped step no longer moves q, when held on a limit without progress (STALL_PASSES), or when the logs are
    full."""
    n = q0.shape[0]
    directions, points = np.empty((n, 3)), np.empty((n, 3))
    jacobian, residual, step = np.empty((6, n)), np.empty(6), np.empty(n)
    q = q0.copy()
    count = 0
    pinned = False
    while True:
        sigma = chain_axes(constants, revolute, offsets, q, directions, points)
        error = pose_error(sigma, goal)
        squared = 0.0
        for k in range(6):
            residual[k] = error[k] / length if k < 3 else error[k]
            squared += error[k] * error[k]
        joint_log[count, :] = q
        for k in range(8):
            pose_log[count, k] = sigma[k]
        error_log[count] = math.sqrt(squared)
        count += 1
        if error_log[count - 1] < tolerance or count == error_log.shape[0]:
            return count
        if pinned and count > STALL_PASSES and (
                error_log[count - 1] > (1.0 - STALL_DECREASE) * error_log[count - 1 - STALL_PASSES]):
            return count
        geometric_jacobian_into(directions, points, revolute, sigma, jacobian)
        jacobian[:3, :] /= length
        pinned = limited_step_into(jacobian, residual, q, lower, upper, step)
        moved = False
        for i in range(n):
            value = min(max(q[i] + step[i], lower[i]), upper[i])
            moved = moved or value != q[i]
            q[i] = value
        if not moved:
            return count


@kernel
def turned_into_limits(q: np.ndarray, revolute: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> bool:
    """Move each revolute joint of q by the fewest whole turns into [lower, upper] (in place); True if every joint
    then lies within its limits (a whole turn leaves the pose unchanged)."""
    inside = True
    for i in range(q.shape[0]):
        if revolute[i] and q[i] < lower[i]:
            q[i] += TWO_PI * math.ceil((lower[i] - q[i]) / TWO_PI)
        elif revolute[i] and q[i] > upper[i]:
            q[i] -= TWO_PI * math.ceil((q[i] - upper[i]) / TWO_PI)
        inside = inside and lower[i] <= q[i] <= upper[i]
    return inside


@kernel
def improved_solve(constants: np.ndarray, revolute: np.ndarray, offsets: np.ndarray, goal_coefficients: np.ndarray,
                   q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float,
                   max_passes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """Improved mode: a search within the limits, then, if it failed, one free of them whose answer counts when
    whole turns bring it within. Returns (joint_log, pose_log, error_log, passes, searches), the logs of the search
    whose answer it is (the first unless the second's counts), passes of both."""
    goal = (goal_coefficients[0], goal_coefficients[1], goal_coefficients[2], goal_coefficients[3],
            goal_coefficients[4], goal_coefficients[5], goal_coefficients[6], goal_coefficients[7])
    n = q0.shape[0]
    directions, points = np.empty((n, 3)), np.empty((n, 3))
    length = reach(points, chain_axes(constants, revolute, offsets, q0, directions, points))
    joint_log, pose_log, error_log = np.empty((max_passes, n)), np.empty((max_passes, 8)), np.empty(max_passes)
    count = improved_search(constants, revolute, offsets, goal, q0, lower, upper, length, tolerance,
                            joint_log, pose_log, error_log)
    if error_log[count - 1] < tolerance:
        return joint_log[:count], pose_log[:count], error_log[:count], count, 1
    free_log, free_poses, free_errors = np.empty((max_passes, n)), np.empty((max_passes, 8)), np.empty(max_passes)
    free_count = improved_search(constants, revolute, offsets, goal, q0, np.full(n, -np.inf), np.full(n, np.inf),
                                 length, tolerance, free_log, free_poses, free_errors)
    last = free_count - 1
    if free_errors[last] < tolerance and turned_into_limits(free_log[last], revolute, lower, upper):
        sigma = chain_axes(constants, revolute, offsets, free_log[last], directions, points)
        for k in range(8):
            free_poses[last, k] = sigma[k]   # a whole turn may flip σ to −σ
        return free_log[:free_count], free_poses[:free_count], free_errors[:free_count], count + free_count, 2
    return joint_log[:count], pose_log[:count], error_log[:count], count + free_count, 2


# ----------------------------------------------------------------------------------------------- paper mode
@kernel
def paper_vector(sigma: tuple[float, ...]) -> tuple[float, ...]:
    """Seed 001's e = (p, φ): p = 2·σ_dual·r*, φ = 2·atan2(|v|, s)·v/|v| (no sheet flip), a 6-tuple."""
    t = translation_of(sigma)
    n = math.sqrt(sigma[1] * sigma[1] + sigma[2] * sigma[2] + sigma[3] * sigma[3])
    factor = 0.0 if n == 0.0 else 2.0 * math.atan2(n, sigma[0]) / n   # identity (or a full turn): φ = 0
    return (t[0], t[1], t[2], factor * sigma[1], factor * sigma[2], factor * sigma[3])


@kernel
def exp_derivative_into(w: np.ndarray, out: np.ndarray) -> None:
    """(4, 3) ∂e^w/∂w_k of the unit quaternion e^w = (cos|w|, sin|w|·w/|w|) into ``out`` (seed 001 eqs. 7–8)."""
    h = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if h < SMALL_VECTOR:
        # sinc(h) and (cos h − sinc h)/h² by their Taylor series, exact to double precision here.
        sinc, e = 1.0 - h * h / 6.0, -1.0 / 3.0 + h * h / 30.0
    else:
        sinc = math.sin(h) / h
        e = (math.cos(h) - sinc) / (h * h)
    for k in range(3):
        out[0, k] = -sinc * w[k]
        for i in range(3):
            out[1 + i, k] = e * w[i] * w[k] + (sinc if i == k else 0.0)
    return None


@kernel
def twist_of(directions: np.ndarray, points: np.ndarray, revolute: np.ndarray, i: int) -> tuple[float, ...]:
    """Joint i's unit screw as a pure 8-tuple: (0, u) + ε(0, p × u) revolute, ε(0, u) prismatic."""
    ux, uy, uz = directions[i, 0], directions[i, 1], directions[i, 2]
    if not revolute[i]:
        return (0.0, 0.0, 0.0, 0.0, 0.0, ux, uy, uz)
    px, py, pz = points[i, 0], points[i, 1], points[i, 2]
    return (0.0, ux, uy, uz, 0.0, py * uz - pz * uy, pz * ux - px * uz, px * uy - py * ux)


@kernel
def paper_jacobian_into(directions: np.ndarray, points: np.ndarray, revolute: np.ndarray, sigma: tuple[float, ...],
                        exact: bool, out: np.ndarray) -> None:
    """(6, n) seed 001's Jacobian of (p, log r) w.r.t. w = ½·q into ``out`` (quirks in dls' module doc); with
    ``exact`` the orientation rows are those of the true derivative of φ = 2·log r instead.

    Position rows ∂p/∂w_k = (2·D(∂σ) − p·R(∂σ))·r⁻¹, orientation rows S((∂r/∂σ_l)*·∂r/∂w_k) = D(log r)ᵀ·R(∂σ),
    with ∂σ/∂w_k = ξ_k·σ. The exact rows are 2·(DᵀD)⁻¹ times those, DᵀD = diag(1, s², s²) in the (radial,
    tangential) axes of log r, s = sin h / h.
    """
    r_conjugate = (sigma[0], -sigma[1], -sigma[2], -sigma[3])
    t = translation_of(sigma)
    vector = paper_vector(sigma)
    log_r = np.array((0.5 * vector[3], 0.5 * vector[4], 0.5 * vector[5]))
    derivative = np.empty((4, 3))
    exp_derivative_into(log_r, derivative)
    h = math.sqrt(log_r[0] * log_r[0] + log_r[1] * log_r[1] + log_r[2] * log_r[2])
    sinc = math.sin(h) / h if h > 0.0 else 1.0
    for k in range(directions.shape[0]):
        rate = multiply(twist_of(directions, points, revolute, k), sigma)
        real = (rate[0], rate[1], rate[2], rate[3])
        moved = multiply_quaternions((0.0, t[0], t[1], t[2]), real)
        position = multiply_quaternions((2.0 * rate[4] - moved[0], 2.0 * rate[5] - moved[1],
                                         2.0 * rate[6] - moved[2], 2.0 * rate[7] - moved[3]), r_conjugate)
        out[0, k], out[1, k], out[2, k] = position[1], position[2], position[3]
        for a in range(3):
            out[3 + a, k] = (derivative[0, a] * real[0] + derivative[1, a] * real[1] + derivative[2, a] * real[2]
                             + derivative[3, a] * real[3])
        if exact:
            radial = 0.0
            if h > 0.0:
                radial = (out[3, k] * log_r[0] + out[4, k] * log_r[1] + out[5, k] * log_r[2]) / (h * h)
            for a in range(3):
                along = radial * log_r[a]
                out[3 + a, k] = 2.0 * (along + (out[3 + a, k] - along) / (sinc * sinc))
    return None


@kernel
def paper_solve(constants: np.ndarray, revolute: np.ndarray, offsets: np.ndarray, goal_vector: np.ndarray,
                q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, alpha: float, gamma: float, tolerance: float,
                max_passes: int, exact: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seed 001's loop: pass k evaluates e_k, stops if ‖g − e_k‖ < tolerance, else steps w += Δw (q = 2w),
    Δw = Jᵀ(J·Jᵀ + γ²I)⁻¹·α·(g − e), q clamped into the limits. Returns (joint_log, pose_log, error_log)."""
    n = q0.shape[0]
    directions, points = np.empty((n, 3)), np.empty((n, 3))
    jacobian, difference, step = np.empty((6, n)), np.empty(6), np.empty(n)
    joint_log, pose_log, error_log = np.empty((max_passes, n)), np.empty((max_passes, 8)), np.empty(max_passes)
    q = q0.copy()
    count = 0
    while True:
        sigma = chain_axes(constants, revolute, offsets, q, directions, points)
        vector = paper_vector(sigma)
        squared = 0.0
        for k in range(6):
            difference[k] = goal_vector[k] - vector[k]
            squared += difference[k] * difference[k]
        joint_log[count, :] = q
        for k in range(8):
            pose_log[count, k] = sigma[k]
        error_log[count] = math.sqrt(squared)
        count += 1
        if error_log[count - 1] < tolerance or count == max_passes:
            return joint_log[:count], pose_log[:count], error_log[:count]
        paper_jacobian_into(directions, points, revolute, sigma, exact, jacobian)
        difference *= alpha
        damped_least_squares_into(jacobian, difference, gamma * gamma, step)
        for i in range(n):
            q[i] = min(max(q[i] + 2.0 * step[i], lower[i]), upper[i])
