"""Damped-least-squares Jacobian IK on dual quaternions (seed 001) for any :class:`SerialChain`, and an improved mode.

Seed 001 (Vergara-Hernández et al., 2023) works in **log variables**: joint i contributes w_i = ½·q_i (the
coefficient of its unit screw in the dual-quaternion logarithm of the joint's motion; for a revolute joint the
paper's Φ_i = ½·u_i·θ_i, for a prismatic joint the dual log ½·d). The end effector is the 6-vector

    e = (p, φ),  p = 2·σ_dual·r*,  φ = 2·log(r) = 2·arccos(s)·v/|v|   (r = (s, v), never hemisphere-flipped),

so a rotation of 210° stays φ = 3.6652 as long as the FK keeps r on that sheet. Each pass of the paper's loop
evaluates e, stops when ‖g − e‖ < tolerance, else steps Δw = Jᵀ(J·Jᵀ + γ²I)⁻¹·α·(g − e).

Paper mode reproduces the paper's numbers, quirks included: its example and every entry of tables 1–2 to the
printed digits, but for the one run stopped by the iteration cap (α = 0.1), where the paper prints the error of the
pass before the last. Its conventions, recovered by that comparison:

* J's orientation rows are ∂log(r)/∂w (the paper's §3.3), half of ∂φ/∂w for the φ = 2·log(r) in e;
* those rows use the paper's projection ∂σ_l/∂w_k = S((∂r/∂σ_l)*·∂r/∂w_k), which is the exact derivative when the
  rotation only changes about its own axis (planar chains such as the example); for spatial chains it weights the
  off-axis components by (sin h / h)² (h = |log r|), so there paper mode follows the paper, not the exact Jacobian;
* the iteration count is the number of loop passes, i.e. of poses evaluated, the start included (steps + 1).
* the goal's sign matters (issue 11, item 7, kept as documented behaviour): φ = 2·log(r) is not hemisphere-flipped,
  so σ and −σ (the same pose) are goals 2π apart in φ, and paper mode converges far less often towards the sheet
  the FK is not on (measured 58/60 vs 25/60 runs). Give paper mode the goal on the FK's sheet (r·r_FK ≥ 0);
  improved mode's screw error treats σ ≡ −σ and does not depend on the sign.

Improved mode (ours): Levenberg–Marquardt on the exact screw error 2·log(σ_goal·σ*) (the screw motion from the
current pose to the goal, shortest, so σ ≡ −σ), whose Jacobian is the joint twists ξ_i themselves (exact when a
single joint moves, so a misaligned base or wrist is corrected in one step instead of along a chord), rotation rows
weighted by the chain's reach, damping μ = θ·‖error‖² adapted by the gain ratio, steps projected onto the joint
limits. The twists differ from the true error Jacobian by O(|error|), so the convergence becomes quadratic.

Units are the chain's: a chain in millimetres (the paper's example) gives errors in millimetres. γ is in those
units too: the paper's 0.22 is negligible against millimetre position rows and dominates metre ones.

Both modes are local: from a far start they may stop in a local minimum or at a saddle (a start where the error's
gradient vanishes exactly); that, and running out of iterations, is reported as ``converged=False``, never raised.
At a singular goal the Jacobian loses rank there and the improved mode's convergence slows to linear.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion, conjugate_coefficients, multiply_coefficients
from ur3dq.kinematics.chain import REVOLUTE, SerialChain
from ur3dq.real_numbers import real_array

PAPER = "paper"
IMPROVED = "improved"
MODES = (PAPER, IMPROVED)

#: Seed 001's chosen step fraction α and damping γ (§4), its stopping threshold on ‖g − e‖ (every converged entry of
#: its tables 1–2 ends just below 1e-3) and its iteration cap (table 2, α = 0.1).
PAPER_ALPHA = 0.55
PAPER_GAMMA = 0.22
PAPER_TOLERANCE = 1e-3
PAPER_MAX_ITERATIONS = 100

IMPROVED_TOLERANCE = 1e-10
IMPROVED_MAX_ITERATIONS = 50
#: Initial Levenberg–Marquardt damping relative to the largest diagonal entry of JᵀJ (Madsen–Nielsen–Tingleff's τ,
#: their value for a start believed close to the solution).
IMPROVED_INITIAL_DAMPING = 1e-3
# Damping this many times the largest diagonal entry of JᵀJ leaves steps ~1e-12 of the gradient step: stalled.
_STALLED = 1e12
#: Below this |vec(r)| the screw log uses its Taylor series (as dqarray's _SMALL).
_SMALL_VECTOR = 1e-4


# ----------------------------------------------------------------------------------------- pure building blocks
def joint_twists(chain: SerialChain, q) -> np.ndarray:
    """(n, 8) unit screws ξ_i of the joints at q, base frame, as pure dual quaternions: σ̇ = ½·(Σ ξ_i q̇_i)·σ.

    Revolute: ξ = (0, u) + ε(0, p × u) (u the axis, p a point on it); prismatic: ξ = ε(0, u).
    """
    directions, points = chain.joint_axes(q)
    revolute = np.array([kind == REVOLUTE for kind in chain.joint_types])
    twists = np.zeros((chain.n_joints, 8))
    twists[revolute, 1:4] = directions[revolute]
    p, u = points[revolute], directions[revolute]
    # p × u written out: np.cross on (6, 3) costs more than the rest of this function.
    twists[revolute, 5] = p[:, 1] * u[:, 2] - p[:, 2] * u[:, 1]
    twists[revolute, 6] = p[:, 2] * u[:, 0] - p[:, 0] * u[:, 2]
    twists[revolute, 7] = p[:, 0] * u[:, 1] - p[:, 1] * u[:, 0]
    twists[~revolute, 5:8] = directions[~revolute]
    return twists


def pose_jacobian(chain: SerialChain, q) -> np.ndarray:
    """(8, n) dual-quaternion pose Jacobian ∂σ/∂q_i = ½·ξ_i·σ of the chain's end pose σ(q) (coefficient order
    [rw rx ry rz dw dx dy dz], the sign of σ the chain's FK produces)."""
    sigma = chain.fk(q).to_array()
    return 0.5 * dqarray.multiply_unchecked(joint_twists(chain, q), sigma).T


def paper_pose_vector(sigma) -> np.ndarray:
    """Seed 001's e = (p, φ): p = 2·σ_dual·r*, φ = 2·atan2(|v|, s)·v/|v| (= 2·arccos(s)·v/|v|, no sheet flip)."""
    sigma = dqarray.check_unit(sigma, "sigma")
    if sigma.shape != (8,):
        raise ValueError(f"sigma: expected 8 coefficients, got shape {sigma.shape}")
    return np.concatenate((dqarray.translation_unchecked(sigma), 2.0 * _paper_log(sigma[:4])))


def paper_vector_to_dual_quaternion(vector) -> np.ndarray:
    """(8,) σ of a seed 001 vector e = (p, φ): r = (cos(|φ|/2), sin(|φ|/2)·φ/|φ|), any |φ| (so its inverse too)."""
    vector = dqarray.as_array(vector, 6, "vector")
    if vector.shape != (6,):
        raise ValueError(f"vector: expected 6 values (p, φ), got shape {vector.shape}")
    return dqarray.from_rotation_translation(dqarray.rotation_vector_to_quaternion(vector[3:]), vector[:3])


def _paper_log(r: np.ndarray) -> np.ndarray:
    """log(r) = atan2(|v|, s)·v/|v| for a unit quaternion r = (s, v): ½·angle·axis, angle in [0, 2π]."""
    n = float(np.linalg.norm(r[1:]))
    if n == 0.0:
        return np.zeros(3)  # identity (or a full turn, whose axis is undefined)
    return np.arctan2(n, r[0]) / n * r[1:]


def exp_derivative(w) -> np.ndarray:
    """(4, 3) ∂e^w/∂w_k of the unit quaternion e^w = (cos|w|, sin|w|·w/|w|) (seed 001 eqs. 7–8; columns k)."""
    w = dqarray.as_array(w, 3, "w")
    h = float(np.linalg.norm(w))
    if h < 1e-4:
        # sinc(h) and (cos h − sinc h)/h² by their Taylor series, exact to double precision here.
        sinc = 1.0 - h * h / 6.0
        e = -1.0 / 3.0 + h * h / 30.0
    else:
        sinc = np.sin(h) / h
        e = (np.cos(h) - sinc) / (h * h)
    derivative = np.zeros((4, 3))
    derivative[0] = -sinc * w
    derivative[1:] = sinc * np.eye(3) + e * np.outer(w, w)
    return derivative


def paper_jacobian(chain: SerialChain, q) -> np.ndarray:
    """(6, n) seed 001's Jacobian of (p, log r) w.r.t. the log variables w = ½·q (§3.3, quirks in the module doc).

    Position rows ∂p/∂w_k = (2·D(∂σ) − p·R(∂σ))·r⁻¹, orientation rows ∂σ_l/∂w_k = S((∂r/∂σ_l)*·∂r/∂w_k).
    """
    sigma = chain.fk(q).to_array()
    d_sigma = 2.0 * pose_jacobian(chain, q).T  # (n, 8): ∂σ/∂w_k = 2·∂σ/∂q_k
    r = sigma[:4]
    p_pure = np.concatenate(([0.0], dqarray.translation_unchecked(sigma)))
    position_rate = dqarray.quaternion_multiply(
        2.0 * d_sigma[:, 4:] - dqarray.quaternion_multiply(p_pure, d_sigma[:, :4]), dqarray.quaternion_conjugate(r)
    )[:, 1:]
    # S(a*·b) is the 4-D dot product a·b.
    log_rate = exp_derivative(_paper_log(r)).T @ d_sigma[:, :4].T
    return np.vstack((position_rate.T, log_rate))


def exact_paper_jacobian(chain: SerialChain, q) -> np.ndarray:
    """(6, n) the exact Jacobian of seed 001's e = (p, φ = 2·log r) w.r.t. w = ½·q: the paper's position rows, and
    orientation rows 2·(DᵀD)⁻¹·(paper's rows), D = ∂e^σ/∂σ at σ = log r (undoing the projection and the ½)."""
    jacobian = paper_jacobian(chain, q)
    d = exp_derivative(_paper_log(chain.fk(q).to_array()[:4]))
    # DᵀD = diag(1, s², s²) in the (radial, tangential) axes, s = sin h / h: singular only at a full turn.
    jacobian[3:] = 2.0 * np.linalg.solve(d.T @ d, jacobian[3:])
    return jacobian


def damped_least_squares_step(jacobian, error, alpha: float, gamma: float) -> np.ndarray:
    """Δ = Jᵀ(J·Jᵀ + γ²I)⁻¹·α·error, the minimiser of ‖J·Δ − α·error‖² + γ²‖Δ‖² (seed 001 §3.2.1).

    Computed as Σ s_i/(s_i² + γ²)·v_i·u_iᵀ·α·error over J's singular triplets, which is the same for γ > 0 and is
    the pseudo-inverse step for γ = 0 even where J·Jᵀ is singular (6 rows, fewer joints: the planar example).
    """
    u, singular, vt = np.linalg.svd(np.asarray(jacobian, dtype=float), full_matrices=False)
    denominator = singular * singular + gamma * gamma
    # With γ = 0, singular values at rounding level are rank deficiency, not directions to divide by.
    kept = denominator > (np.finfo(float).eps * max(float(singular.max(initial=0.0)), 1.0)) ** 2
    gains = np.divide(singular, denominator, out=np.zeros_like(singular), where=kept)
    return vt.T @ (gains * (u.T @ (alpha * np.asarray(error, dtype=float))))


def screw_jacobian(chain: SerialChain, q) -> np.ndarray:
    """(6, n) joint twists as columns [u; p × u] (revolute) or [0; u] (prismatic), base frame: to first order
    σ(q + Δq) = exp(½·Σ ξ_i Δq_i)·σ(q), so 2·log(σ_goal·σ*) ≈ J·Δq (exactly so when one joint moves)."""
    twists = joint_twists(chain, q)
    return np.vstack((twists[:, 1:4].T, twists[:, 5:8].T))


def screw_error(sigma, goal) -> np.ndarray:
    """(6,) 2·log(σ_goal·σ*) = [angle·axis, v]: the screw motion (base frame) taking σ to σ_goal, shortest (σ ≡ −σ)."""
    return 2.0 * dqarray.log(dqarray.multiply_unchecked(goal, dqarray.conjugate(sigma)))


def pose_error(sigma, goal) -> np.ndarray:
    """(6,) (t_goal − t, rotation vector of r_goal·r*) between unit 8-arrays: base frame, shortest (σ ≡ −σ)."""
    relative = dqarray.quaternion_multiply(goal[:4], dqarray.quaternion_conjugate(sigma[:4]))
    return np.concatenate(
        (dqarray.translation_unchecked(goal) - dqarray.translation_unchecked(sigma),
         dqarray.quaternion_to_rotation_vector(relative))
    )


def _translation_of(c: tuple) -> tuple:
    """t = vec(2·d·r*) of an 8-tuple of floats (as dqarray.translation_unchecked)."""
    rw, rx, ry, rz, dw, dx, dy, dz = c
    return (2.0 * (-dw * rx + dx * rw - dy * rz + dz * ry), 2.0 * (-dw * ry + dx * rz + dy * rw - dz * rx),
            2.0 * (-dw * rz - dx * ry + dy * rx + dz * rw))


def _errors_of_floats(sigma: tuple, goal: tuple) -> tuple:
    """(screw_error, pose_error) of 8-tuples of floats, as (6,) arrays: the improved loop's hot path.

    Both from one relative pose goal·σ* on its w ≥ 0 sheet: its screw logarithm (dqarray.log) doubled, and
    (t_goal − t, its rotation vector), the rotation vector being twice the log's ω. The numpy forms
    (screw_error, pose_error) are the reference the tests hold this to; ~30 small numpy calls per pass cost
    the loop more than the step itself.
    """
    relative = multiply_coefficients(goal, conjugate_coefficients(sigma))
    if relative[0] < 0.0:
        relative = tuple(-v for v in relative)
    r_w, rx, ry, rz, s_w, sx, sy, sz = relative
    n = math.sqrt(rx * rx + ry * ry + rz * rz)
    half_angle = math.atan2(n, r_w)
    if n < _SMALL_VECTOR:
        h2 = half_angle * half_angle
        k, c = 1.0 + h2 / 6.0, -2.0 / 3.0 - h2 / 5.0
    else:
        k = half_angle / n
        c = (r_w - k) / (n * n)
    along = c * (sx * rx + sy * ry + sz * rz) - s_w
    omega = (k * rx, k * ry, k * rz)
    screw = np.array((2.0 * omega[0], 2.0 * omega[1], 2.0 * omega[2],
                      2.0 * (k * sx + along * rx), 2.0 * (k * sy + along * ry), 2.0 * (k * sz + along * rz)))
    goal_t, sigma_t = _translation_of(goal), _translation_of(sigma)
    pose = np.array((goal_t[0] - sigma_t[0], goal_t[1] - sigma_t[1], goal_t[2] - sigma_t[2], *screw[:3]))
    return screw, pose


def characteristic_length(chain: SerialChain, q) -> float:
    """Length of the polyline joint 1 → … → joint n → end at q (the reach); 1 when it is 0 (all axes meet)."""
    _, points = chain.joint_axes(q)
    polyline = np.vstack((points, chain.fk(q).translation))
    length = float(np.sum(np.linalg.norm(np.diff(polyline, axis=0), axis=1)))
    return length if length > 0.0 else 1.0


def project_to_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """q clamped joint by joint into [lower, upper] (the Euclidean projection onto the box)."""
    return np.minimum(np.maximum(q, lower), upper)


# --------------------------------------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class DLSResult:
    """Outcome of :func:`dls_ik`; the logs hold every accepted pose, the start first (for plots).

    ``iterations`` counts loop passes as seed 001 does, i.e. poses evaluated with the start included; in improved
    mode a rejected Levenberg–Marquardt trial is a pass too (it costs an FK), though it is not in the logs.
    """

    q: np.ndarray                   # final joint values (n,)
    converged: bool
    iterations: int
    error: float                    # final error norm: ‖g − e‖ (paper) or ‖pose_error‖ (improved), chain units
    mode: str
    joint_log: np.ndarray           # (k, n) joint trajectory
    pose_log: np.ndarray            # (k, 8) end-effector dual quaternions
    error_log: np.ndarray           # (k,) error norm at each logged pose
    goal: np.ndarray = field(repr=False)   # (8,) goal as used (paper mode: on the sheet of its vector g)

    @property
    def pose(self) -> DualQuaternion:
        """Final end-effector pose."""
        return DualQuaternion.from_array(self.pose_log[-1])

    @property
    def steps(self) -> int:
        """Accepted joint updates."""
        return len(self.joint_log) - 1

    @property
    def positions(self) -> np.ndarray:
        """(k, 3) end-effector trajectory (positions of the logged poses)."""
        return dqarray.translation_unchecked(self.pose_log)

    @property
    def paper_vectors(self) -> np.ndarray:
        """(k, 6) seed 001 vectors e = (p, φ) of the logged poses (φ on each pose's own sheet)."""
        return np.array([paper_pose_vector(pose) for pose in self.pose_log])


# ----------------------------------------------------------------------------------------------------- solver
def dls_ik(chain, goal, q0, *, mode: str = PAPER, alpha: float | None = None, gamma: float | None = None,
           tolerance: float | None = None, max_iterations: int | None = None, lower=None, upper=None,
           jacobian: str = "paper") -> DLSResult:
    """Joint values bringing ``chain``'s end pose to ``goal`` from ``q0`` by damped least squares.

    ``chain``: a SerialChain, or a model with ``.chain`` and ``.joint_lower``/``.joint_upper`` (e.g.
    ``robot_model("ur3")``), whose limits are then the default ``lower``/``upper``. ``goal``: a DualQuaternion, 8
    coefficients, or seed 001's 6-vector (p, φ) — which is a UR pose vector, the rotation vector φ allowed beyond π.
    Paper mode compares φ without sheet flipping, so the sign of a given dual quaternion's real part matters there.
    ``mode``: "paper" (seed 001, α default 0.55, γ default 0.22) or "improved" (Levenberg–Marquardt, α and γ
    unused: it sizes its own steps). ``lower``/``upper``: joint limits (n each, ±inf allowed); every step is
    projected into them. ``jacobian`` (paper mode): "paper" (its §3.3 formulas, which reproduce its numbers) or
    "exact" (the true derivative of e, see :func:`exact_paper_jacobian`: the paper's method made sound on spatial
    chains). Returns a :class:`DLSResult`; not converging within ``max_iterations`` is reported there, not raised.
    """
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    chain, model_lower, model_upper = _chain_and_limits(chain)
    n = chain.n_joints
    q0 = chain.check_q(q0, "q0")
    lower = _limits(model_lower if lower is None else lower, n, -np.inf, "lower")
    upper = _limits(model_upper if upper is None else upper, n, np.inf, "upper")
    if np.any(lower > upper):
        raise ValueError(f"lower: joint {int(np.argmax(lower > upper)) + 1} has lower limit above its upper limit")
    outside = (q0 < lower) | (q0 > upper)
    if np.any(outside):
        raise ValueError(f"q0: joint {int(np.argmax(outside)) + 1} is outside the joint limits")
    if mode == PAPER:
        alpha, gamma = _paper_parameters(alpha, gamma)
    elif alpha is not None or gamma is not None:
        name = "alpha" if alpha is not None else "gamma"
        raise ValueError(f"{name}: applies to mode='paper' only; the improved mode sizes its own steps")
    default_tolerance, default_cap = (
        (PAPER_TOLERANCE, PAPER_MAX_ITERATIONS) if mode == PAPER else (IMPROVED_TOLERANCE, IMPROVED_MAX_ITERATIONS)
    )
    tolerance = default_tolerance if tolerance is None else _number(tolerance, "tolerance")
    if tolerance <= 0.0:
        raise ValueError(f"tolerance: must be > 0, got {tolerance}")
    max_iterations = default_cap if max_iterations is None else _count(max_iterations, "max_iterations")
    if not isinstance(jacobian, str) or jacobian not in PAPER_JACOBIANS:
        raise ValueError(f"jacobian: expected one of {tuple(PAPER_JACOBIANS)}, got {jacobian!r}")
    if mode == PAPER:
        goal_vector = _goal_vector(goal)
        return _solve_paper(chain, goal_vector, q0, alpha, gamma, tolerance, max_iterations, lower, upper,
                            PAPER_JACOBIANS[jacobian])
    if jacobian != "paper":
        raise ValueError("jacobian: applies to mode='paper' only; the improved mode uses the joint twists")
    return _solve_improved(chain, _goal_coefficients(goal), q0, tolerance, max_iterations, lower, upper)


def _solve_paper(chain, goal_vector, q0, alpha, gamma, tolerance, max_iterations, lower, upper,
                 jacobian_of) -> DLSResult:
    """Seed 001's loop: pass k evaluates e_k, stops if ‖g − e_k‖ < tolerance, else steps w += Δw (q = 2w)."""
    q = q0
    joints, poses, errors = [], [], []
    for _ in range(max_iterations):
        sigma = chain.fk(q).to_array()
        difference = goal_vector - paper_pose_vector(sigma)
        joints.append(q)
        poses.append(sigma)
        errors.append(float(np.linalg.norm(difference)))
        if errors[-1] < tolerance or len(joints) == max_iterations:
            break
        step = damped_least_squares_step(jacobian_of(chain, q), difference, alpha, gamma)
        q = project_to_limits(q + 2.0 * step, lower, upper)
    return DLSResult(q=joints[-1], converged=errors[-1] < tolerance, iterations=len(joints), error=errors[-1],
                     mode=PAPER, joint_log=np.array(joints), pose_log=np.array(poses), error_log=np.array(errors),
                     goal=paper_vector_to_dual_quaternion(goal_vector))


def _solve_improved(chain, goal, q0, tolerance, max_iterations, lower, upper) -> DLSResult:
    """Levenberg–Marquardt on the screw error, rotation rows weighted by the chain's reach so metres (or
    millimetres) and radians weigh alike; steps projected onto the limits.

    The damping is μ = θ·‖residual‖² (Yamashita & Fukushima 2001: it vanishes quadratically near a zero-residual
    solution, so the steps become Gauss–Newton's and convergence quadratic), with θ adapted by Nielsen's gain-ratio
    rule (Madsen, Nielsen & Tingleff 2004, alg. 3.16): θ·max(1/3, 1 − (2ρ − 1)³) after a good step, ×2, ×4… after
    a rejected one.
    """
    weights = np.concatenate((np.full(3, characteristic_length(chain, q0)), np.ones(3)))

    goal_floats = tuple(float(v) for v in goal)

    def evaluate(q):
        sigma = chain.end_coefficients(tuple(float(v) for v in q))
        screw, pose = _errors_of_floats(sigma, goal_floats)
        return np.array(sigma), weights * screw, float(np.linalg.norm(pose))

    q = q0
    sigma, residual, error = evaluate(q)
    joints, poses, errors = [q], [sigma], [error]
    passes = 1
    damping, growth = None, 2.0
    while error >= tolerance and passes < max_iterations:
        jacobian = weights[:, None] * screw_jacobian(chain, q)
        normal = jacobian.T @ jacobian
        gradient = jacobian.T @ residual
        squared = float(residual @ residual)
        if damping is None:
            damping = IMPROVED_INITIAL_DAMPING * float(np.max(np.diag(normal))) / squared
        step = _damped_step(normal, gradient, damping * squared, q, lower, upper)
        trial_q = project_to_limits(q + step, lower, upper)
        trial_sigma, trial_residual, trial_error = evaluate(trial_q)
        passes += 1
        # Gain ratio: actual over predicted decrease of ½‖residual‖², predicted by the linear model for the step
        # actually taken (after projection onto the limits).
        taken = trial_q - q
        predicted = 0.5 * (squared - np.sum((residual - jacobian @ taken) ** 2))
        actual = 0.5 * (squared - trial_residual @ trial_residual)
        if predicted > 0.0 and actual > 0.0:
            ratio = actual / predicted
            q, sigma, residual, error = trial_q, trial_sigma, trial_residual, trial_error
            joints.append(q)
            poses.append(sigma)
            errors.append(error)
            damping *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
            growth = 2.0
        elif np.all(taken == 0.0) or damping * squared > _STALLED * float(np.max(np.diag(normal))):
            break  # pinned against the limits, or damped to a standstill: no step left to try
        else:
            damping *= growth
            growth *= 2.0
    return DLSResult(q=q, converged=error < tolerance, iterations=passes, error=error, mode=IMPROVED,
                     joint_log=np.array(joints), pose_log=np.array(poses), error_log=np.array(errors), goal=goal)


def _damped_step(normal, gradient, damping, q, lower, upper) -> np.ndarray:
    """Solution of (JᵀJ + μI)·h = Jᵀr, re-solved without the joints it would push further past a limit they sit on
    (they keep h = 0), so the step stays a descent step of the joints that can move."""
    free = np.ones(len(q), dtype=bool)
    while True:
        step = np.zeros(len(q))
        system = normal[np.ix_(free, free)] + damping * np.eye(int(free.sum()))
        # lstsq, not solve: with μ ≈ 0 at a singular solution the system may be singular to working precision.
        step[free] = np.linalg.lstsq(system, gradient[free], rcond=None)[0]
        blocked = free & (((q <= lower) & (step < 0.0)) | ((q >= upper) & (step > 0.0)))
        if not blocked.any():
            return step
        free &= ~blocked


#: Paper mode's Jacobians by name (the ``jacobian`` argument of :func:`dls_ik`).
PAPER_JACOBIANS = {"paper": paper_jacobian, "exact": exact_paper_jacobian}


# ------------------------------------------------------------------------------------------------ validation
def _chain_and_limits(chain):
    """(SerialChain, lower, upper) from a SerialChain (no limits) or a model with .chain and joint limits."""
    if isinstance(chain, SerialChain):
        return chain, None, None
    inner = getattr(chain, "chain", None)
    if isinstance(inner, SerialChain):
        return inner, getattr(chain, "joint_lower", None), getattr(chain, "joint_upper", None)
    raise ValueError(f"chain: expected a SerialChain or a robot model with .chain, got {type(chain).__name__}")


def _limits(values, n: int, default: float, name: str) -> np.ndarray:
    """n joint limits (±inf allowed, NaN not), or all ``default`` when None; ValueError naming ``name``."""
    if values is None:
        return np.full(n, default)
    try:
        array = real_array(values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected {n} numbers, got {values!r}") from exc
    if array.shape != (n,):
        raise ValueError(f"{name}: expected {n} joint limits, got shape {array.shape}")
    if np.any(np.isnan(array)):
        raise ValueError(f"{name}: contains NaN")
    return array


def _paper_parameters(alpha, gamma) -> tuple[float, float]:
    """(α, γ) with the paper's defaults for None; ValueError unless 0 < α ≤ 1 and γ ≥ 0."""
    alpha = PAPER_ALPHA if alpha is None else _number(alpha, "alpha")
    gamma = PAPER_GAMMA if gamma is None else _number(gamma, "gamma")
    if not 0.0 < alpha <= 1.0:
        raise ValueError(f"alpha: the step fraction must lie in (0, 1], got {alpha}")
    if gamma < 0.0:
        raise ValueError(f"gamma: the damping must be ≥ 0, got {gamma}")
    return alpha, gamma


def _number(value, name: str) -> float:
    """A finite float; ValueError naming ``name``."""
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a number, got {value!r}") from exc
    if not np.isfinite(number):
        raise ValueError(f"{name}: must be finite, got {number}")
    return number


def _count(value, name: str) -> int:
    """An int ≥ 1; ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name}: expected a whole number ≥ 1, got {value!r}")
    return int(value)


def _goal_coefficients(goal) -> np.ndarray:
    """(8,) unit coefficients of a goal given as DualQuaternion, 8 coefficients or a 6-vector (p, φ)."""
    if isinstance(goal, DualQuaternion):
        array = goal.to_array()
    else:
        array = dqarray.as_array(goal, (), "goal")
        if array.shape == (6,):
            return paper_vector_to_dual_quaternion(array)
    if array.shape != (8,):
        raise ValueError(f"goal: expected a DualQuaternion, 8 coefficients or 6 values (p, φ), got {array.shape}")
    return dqarray.check_unit(array, "goal")


def _goal_vector(goal) -> np.ndarray:
    """Seed 001's goal vector g = (p, φ): a given 6-vector as is, a dual quaternion on the sheet it is given on."""
    if not isinstance(goal, DualQuaternion):
        array = dqarray.as_array(goal, (), "goal")
        if array.shape == (6,):
            return array
    return paper_pose_vector(_goal_coefficients(goal))
