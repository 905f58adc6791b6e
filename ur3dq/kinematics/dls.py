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
* the goal's sign matters: φ = 2·log(r) is not hemisphere-flipped, so σ and −σ (the same pose) are goals 2π apart
  in φ, and paper mode converges far less often towards the sheet the FK is not on. Give paper mode the goal on
  the FK's sheet (r·r_FK ≥ 0); improved mode's pose error treats σ ≡ −σ and does not depend on the sign.

Improved mode (ours): Levenberg–Marquardt on the pose error at the end effector, e = (t_goal − t, rotation vector
of r_goal·r*) (shortest, so σ ≡ −σ), whose Jacobian is the geometric one ([u × (t − p); u] per revolute joint:
exact to first order at the solution, so convergence is quadratic there), translation rows divided by the chain's
reach so metres (or millimetres) and radians weigh alike, and Chan's damping μ = ½‖e‖² (Chan & Lawrence 1988: large
far from the goal, vanishing at it), every step taken. It runs as two searches. The first keeps every iterate
within the joint limits (steps clamped, a joint that sits on a limit and would be pushed past it held there);
projection can pin it at a point where the limits stop every descent direction, short of the goal. Then a second
search from q0 ignores the limits on the way, and its answer counts if whole turns of its revolute joints bring it
within them (a whole turn leaves the pose unchanged).

Units are the chain's: a chain in millimetres (the paper's example) gives errors in millimetres. γ is in those
units too: the paper's 0.22 is negligible against millimetre position rows and dominates metre ones.

Both modes are local: from a far start they may stop in a local minimum or at a saddle (a start where the error's
gradient vanishes exactly); that, and running out of iterations, is reported as ``converged=False``, never raised.
At a singular goal the Jacobian loses rank there and the improved mode's convergence slows to linear.

The loops run compiled (:mod:`ur3dq.kinematics.dls_kernels`); the functions here validate, and give the kernels'
building blocks numpy shapes.

Example
-------
>>> import numpy as np
>>> from ur3dq.kinematics import robot_model
>>> from ur3dq.kinematics.dls import dls_ik
>>> ur3 = robot_model("ur3")
>>> goal = ur3.fk([0.1, -1.2, 1.0, -0.5, 0.3, 0.2])
>>> result = dls_ik(ur3, goal, [0.0, -1.0, 1.1, -0.6, 0.2, 0.0], mode="improved")
>>> result.converged, bool(ur3.fk(result.q).is_close(goal))
(True, True)
"""
from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import chain_kernels, dls_kernels, jit
from ur3dq.kinematics.chain import SerialChain
from ur3dq.real_numbers import real_array

Array = NDArray[np.float64]

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
#: Passes per search of the improved mode (it may run two).
IMPROVED_MAX_ITERATIONS = 50

#: Paper mode's Jacobians by name (the ``jacobian`` argument of :func:`dls_ik`): its §3.3 formulas, or exact.
PAPER_JACOBIANS = ("paper", "exact")


# ---------------------------------------------------------------------------------------------- the kernels
_warmed = False


def kernels() -> ModuleType:
    """The compiled DLS kernels (dls_kernels): the first use after an install compiles them into numba's cache, once
    per cache, saying so in one line on stderr (ur3dq.kinematics.jit); later processes load them."""
    global _warmed
    if not _warmed:
        _warmed = True   # before warming: warm() runs the API, which comes back here
        sources = (dls_kernels.__file__, chain_kernels.__file__, inspect.getsourcefile(SerialChain),
                   inspect.getsourcefile(DualQuaternion), jit.__file__)
        jit.warm_once("dls", tuple(str(source) for source in sources), warm)
    return dls_kernels


# ----------------------------------------------------------------------------------------- building blocks
def _geometry(chain: SerialChain, q: ArrayLike) -> tuple[Array, Array, tuple[float, ...]]:
    """(directions (n, 3), points (n, 3), σ as an 8-tuple) of the chain at q (validated, ValueError naming q)."""
    q = chain.check_q(q)
    directions, points = np.empty((chain.n_joints, 3)), np.empty((chain.n_joints, 3))
    constants, revolute, offsets = chain.product_form()
    return directions, points, kernels().chain_axes(constants, revolute, offsets, q, directions, points)


def joint_twists(chain: SerialChain, q: ArrayLike) -> Array:
    """(n, 8) unit screws ξ_i of the joints at q, base frame, as pure dual quaternions: σ̇ = ½·(Σ ξ_i q̇_i)·σ.

    Revolute: ξ = (0, u) + ε(0, p × u) (u the axis, p a point on it); prismatic: ξ = ε(0, u).
    """
    directions, points, _ = _geometry(chain, q)
    revolute = chain.product_form()[1]
    return np.array([kernels().twist_of(directions, points, revolute, i) for i in range(chain.n_joints)])


def pose_jacobian(chain: SerialChain, q: ArrayLike) -> Array:
    """(8, n) dual-quaternion pose Jacobian ∂σ/∂q_i = ½·ξ_i·σ of the chain's end pose σ(q) (coefficient order
    [rw rx ry rz dw dx dy dz], the sign of σ the chain's FK produces)."""
    directions, points, sigma = _geometry(chain, q)
    revolute = chain.product_form()[1]
    compiled = kernels()
    rates = [compiled.multiply(compiled.twist_of(directions, points, revolute, i), sigma)
             for i in range(chain.n_joints)]
    jacobian: Array = 0.5 * np.array(rates).T
    return jacobian


def screw_jacobian(chain: SerialChain, q: ArrayLike) -> Array:
    """(6, n) joint twists as columns [u; p × u] (revolute) or [0; u] (prismatic), base frame: to first order
    σ(q + Δq) = exp(½·Σ ξ_i Δq_i)·σ(q), so 2·log(σ_goal·σ*) ≈ J·Δq (exactly so when one joint moves)."""
    twists = joint_twists(chain, q)
    return np.vstack((twists[:, 1:4].T, twists[:, 5:8].T))


def geometric_jacobian(chain: SerialChain, q: ArrayLike) -> Array:
    """(6, n) [ṫ; ω] of the end point per unit joint rate, base frame: the improved mode's Jacobian (unweighted).

    Example
    -------
    >>> from ur3dq.kinematics import robot_model
    >>> geometric_jacobian(robot_model("ur3").chain, [0.0] * 6).shape
    (6, 6)
    """
    directions, points, sigma = _geometry(chain, q)
    jacobian = np.empty((6, chain.n_joints))
    kernels().geometric_jacobian_into(directions, points, chain.product_form()[1], sigma, jacobian)
    return jacobian


def paper_pose_vector(sigma: ArrayLike) -> Array:
    """Seed 001's e = (p, φ): p = 2·σ_dual·r*, φ = 2·atan2(|v|, s)·v/|v| (= 2·arccos(s)·v/|v|, no sheet flip)."""
    array = dqarray.check_unit(sigma, "sigma")
    if array.shape != (8,):
        raise ValueError(f"sigma: expected 8 coefficients, got shape {array.shape}")
    return np.array(kernels().paper_vector(tuple(array.tolist())))


def paper_vector_to_dual_quaternion(vector: ArrayLike) -> Array:
    """(8,) σ of a seed 001 vector e = (p, φ): r = (cos(|φ|/2), sin(|φ|/2)·φ/|φ|), any |φ| (so its inverse too)."""
    array = dqarray.as_array(vector, 6, "vector")
    if array.shape != (6,):
        raise ValueError(f"vector: expected 6 values (p, φ), got shape {array.shape}")
    return dqarray.from_rotation_translation(dqarray.rotation_vector_to_quaternion(array[3:]), array[:3])


def exp_derivative(w: ArrayLike) -> Array:
    """(4, 3) ∂e^w/∂w_k of the unit quaternion e^w = (cos|w|, sin|w|·w/|w|) (seed 001 eqs. 7–8; columns k)."""
    array = dqarray.as_array(w, 3, "w")
    if array.shape != (3,):
        raise ValueError(f"w: expected 3 values, got shape {array.shape}")
    derivative = np.empty((4, 3))
    kernels().exp_derivative_into(array, derivative)
    return derivative


def paper_jacobian(chain: SerialChain, q: ArrayLike) -> Array:
    """(6, n) seed 001's Jacobian of (p, log r) w.r.t. the log variables w = ½·q (§3.3, quirks in the module doc).

    Position rows ∂p/∂w_k = (2·D(∂σ) − p·R(∂σ))·r⁻¹, orientation rows ∂σ_l/∂w_k = S((∂r/∂σ_l)*·∂r/∂w_k).
    """
    return _paper_jacobian(chain, q, exact=False)


def exact_paper_jacobian(chain: SerialChain, q: ArrayLike) -> Array:
    """(6, n) the exact Jacobian of seed 001's e = (p, φ = 2·log r) w.r.t. w = ½·q: the paper's position rows, and
    orientation rows 2·(DᵀD)⁻¹·(paper's rows), D = ∂e^σ/∂σ at σ = log r (undoing the projection and the ½)."""
    return _paper_jacobian(chain, q, exact=True)


def _paper_jacobian(chain: SerialChain, q: ArrayLike, exact: bool) -> Array:
    directions, points, sigma = _geometry(chain, q)
    jacobian = np.empty((6, chain.n_joints))
    kernels().paper_jacobian_into(directions, points, chain.product_form()[1], sigma, exact, jacobian)
    return jacobian


def damped_least_squares_step(jacobian: ArrayLike, error: ArrayLike, alpha: float, gamma: float) -> Array:
    """Δ = Jᵀ(J·Jᵀ + γ²I)⁻¹·α·error, the minimiser of ‖J·Δ − α·error‖² + γ²‖Δ‖² (seed 001 §3.2.1).

    Solved as (JᵀJ + γ²I)·Δ = Jᵀ·α·error, which is the same for γ > 0; where that system is singular to working
    precision (γ = 0 and J short of rank), the pseudo-inverse step from J's singular triplets.
    """
    matrix = np.ascontiguousarray(real_array(jacobian))
    scaled = alpha * np.ascontiguousarray(real_array(error))
    step = np.empty(matrix.shape[1])
    kernels().damped_least_squares_into(matrix, scaled, float(gamma) ** 2, step)
    return step


def screw_error(sigma: ArrayLike, goal: ArrayLike) -> Array:
    """(6,) 2·log(σ_goal·σ*) = [angle·axis, v]: the screw motion (base frame) taking σ to σ_goal, shortest (σ ≡ −σ)."""
    return 2.0 * dqarray.log(dqarray.multiply_unchecked(np.asarray(goal, dtype=float), dqarray.conjugate(sigma)))


def pose_error(sigma: ArrayLike, goal: ArrayLike) -> Array:
    """(6,) (t_goal − t, rotation vector of r_goal·r*) between unit 8-arrays: base frame, shortest (σ ≡ −σ); the
    improved mode's error (unweighted)."""
    return np.array(kernels().pose_error(_floats(sigma), _floats(goal)))


def _floats(coefficients: ArrayLike) -> tuple[float, ...]:
    """An 8-tuple of floats of 8 coefficients (not validated)."""
    return tuple(float(c) for c in np.asarray(coefficients, dtype=float).reshape(8))


def characteristic_length(chain: SerialChain, q: ArrayLike) -> float:
    """Length of the polyline joint 1 → … → joint n → end at q (the reach); 1 when it is 0 (all axes meet)."""
    _, points, sigma = _geometry(chain, q)
    return float(kernels().reach(points, sigma))


def project_to_limits(q: Array, lower: Array, upper: Array) -> Array:
    """q clamped joint by joint into [lower, upper] (the Euclidean projection onto the box)."""
    return np.minimum(np.maximum(q, lower), upper)


# --------------------------------------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class DLSResult:
    """Outcome of :func:`dls_ik`; the logs hold every pose of the answer's search, the start first (for plots).

    ``iterations`` counts loop passes as seed 001 does, i.e. poses evaluated with the start included; in improved
    mode it counts the passes of both searches when a second one ran (``searches`` = 2), while the logs hold the
    search whose answer ``q`` is (the second's if it converged within the limits, else the first's).
    """

    q: Array                        # final joint values (n,)
    converged: bool
    iterations: int
    error: float                    # final error norm: ‖g − e‖ (paper) or ‖pose_error‖ (improved), chain units
    mode: str
    joint_log: Array                # (k, n) joint trajectory
    pose_log: Array                 # (k, 8) end-effector dual quaternions
    error_log: Array                # (k,) error norm at each logged pose
    goal: Array = field(repr=False)     # (8,) goal as used (paper mode: on the sheet of its vector g)
    searches: int = 1

    @property
    def pose(self) -> DualQuaternion:
        """Final end-effector pose."""
        return DualQuaternion.from_array(self.pose_log[-1])

    @property
    def steps(self) -> int:
        """Joint updates of the logged search."""
        return len(self.joint_log) - 1

    @property
    def positions(self) -> Array:
        """(k, 3) end-effector trajectory (positions of the logged poses)."""
        return dqarray.translation_unchecked(self.pose_log)

    @property
    def paper_vectors(self) -> Array:
        """(k, 6) seed 001 vectors e = (p, φ) of the logged poses (φ on each pose's own sheet)."""
        return np.array([paper_pose_vector(pose) for pose in self.pose_log])


# ----------------------------------------------------------------------------------------------------- solver
def dls_ik(chain: object, goal: DualQuaternion | ArrayLike, q0: ArrayLike, *, mode: str = PAPER,
           alpha: float | None = None, gamma: float | None = None, tolerance: float | None = None,
           max_iterations: int | None = None, lower: ArrayLike | None = None, upper: ArrayLike | None = None,
           jacobian: str = "paper") -> DLSResult:
    """Joint values bringing ``chain``'s end pose to ``goal`` from ``q0`` by damped least squares.

    Parameters
    ----------
    chain
        A SerialChain, or a model with ``.chain`` and ``.joint_lower``/``.joint_upper`` (e.g.
        ``robot_model("ur3")``), whose limits are then the default ``lower``/``upper``.
    goal
        A DualQuaternion, 8 coefficients, or seed 001's 6-vector (p, φ) — which is a UR pose vector, the rotation
        vector φ allowed beyond π. Paper mode compares φ without sheet flipping, so the sign of a given dual
        quaternion's real part matters there.
    q0
        The start (n joint values, within the limits).
    mode
        "paper" (seed 001, α default 0.55, γ default 0.22) or "improved" (Levenberg–Marquardt, α and γ unused: it
        sizes its own steps).
    tolerance, max_iterations
        Stop when the error norm falls below ``tolerance`` (chain units; paper 1e-3, improved 1e-10), or after
        ``max_iterations`` passes (paper 100; improved 50 per search).
    lower, upper
        Joint limits (n each, ±inf allowed); iterates stay within them (improved mode: see the module doc).
    jacobian
        Paper mode: "paper" (its §3.3 formulas, which reproduce its numbers) or "exact" (the true derivative of e,
        see :func:`exact_paper_jacobian`: the paper's method made sound on spatial chains).

    Returns
    -------
    DLSResult
        Not converging within ``max_iterations`` is reported there (``converged=False``), not raised; bad input
        raises ValueError naming the argument.

    Example
    -------
    >>> from ur3dq.kinematics import robot_model
    >>> ur3 = robot_model("ur3")
    >>> result = dls_ik(ur3, ur3.fk([0.5] * 6), [0.4] * 6, mode="improved")
    >>> result.converged, result.error < 1e-10
    (True, True)
    """
    serial, model_lower, model_upper = _chain_and_limits(chain)
    stop, cap = _stopping(mode, tolerance, max_iterations)
    n = serial.n_joints
    start = _joint_values(serial, q0)
    low = _limits(model_lower if lower is None else lower, n, -np.inf, "lower")
    high = _limits(model_upper if upper is None else upper, n, np.inf, "upper")
    if not isinstance(jacobian, str) or jacobian not in PAPER_JACOBIANS:
        raise ValueError(f"jacobian: expected one of {PAPER_JACOBIANS}, got {jacobian!r}")
    constants, revolute, offsets = serial.product_form()
    if mode == PAPER:
        step_fraction, damping = _paper_parameters(alpha, gamma)
        goal_vector = np.array(_goal_vector(goal), dtype=float)
        goal_coefficients = paper_vector_to_dual_quaternion(goal_vector)
        _check_problem(goal_coefficients, start, low, high)
        joint_log, pose_log, error_log = kernels().paper_solve(
            constants, revolute, offsets, goal_vector, start, low, high, step_fraction, damping, stop, cap,
            jacobian == "exact")
        passes, searches = len(joint_log), 1
    else:
        if alpha is not None or gamma is not None:
            name = "alpha" if alpha is not None else "gamma"
            raise ValueError(f"{name}: applies to mode='paper' only; the improved mode sizes its own steps")
        if jacobian != "paper":
            raise ValueError("jacobian: applies to mode='paper' only; the improved mode uses the geometric Jacobian")
        goal_coefficients = _goal_coefficients(goal)
        _check_problem(goal_coefficients, start, low, high)
        joint_log, pose_log, error_log, passes, searches = kernels().improved_solve(
            constants, revolute, offsets, goal_coefficients, start, low, high, stop, cap)
    return DLSResult(q=joint_log[-1], converged=bool(error_log[-1] < stop), iterations=int(passes),
                     error=float(error_log[-1]), mode=mode, joint_log=joint_log, pose_log=pose_log,
                     error_log=error_log, goal=goal_coefficients, searches=int(searches))


def warm() -> None:
    """Run every DLS kernel once (both modes, a second search, the building blocks): compiles them into numba's
    cache, or loads them from it."""
    planar = SerialChain.from_dh(a=[0.6, 1.0, 0.8], d=[0.0] * 3, alpha=[0.0] * 3)
    goal = planar.fk([-1.95, -1.05, 0.38])
    dls_ik(planar, goal, [0.0, -1.0, 0.3], mode=IMPROVED, lower=[0.0, -np.inf, -np.inf], upper=[6.0, np.inf, np.inf])
    dls_ik(planar, goal, np.zeros(3), jacobian="exact")
    dls_ik(planar, goal, np.zeros(3))
    for building_block in (pose_jacobian, geometric_jacobian, paper_jacobian, characteristic_length):
        building_block(planar, np.zeros(3))
    pose_error(goal.to_array(), goal.to_array())
    damped_least_squares_step(np.eye(3), np.ones(3), 1.0, 0.0)


# ------------------------------------------------------------------------------------------------ validation
def _chain_and_limits(chain: object) -> tuple[SerialChain, ArrayLike | None, ArrayLike | None]:
    """(SerialChain, lower, upper) from a SerialChain (no limits) or a model with .chain and joint limits."""
    if isinstance(chain, SerialChain):
        return chain, None, None
    inner = getattr(chain, "chain", None)
    if isinstance(inner, SerialChain):
        return inner, getattr(chain, "joint_lower", None), getattr(chain, "joint_upper", None)
    raise ValueError(f"chain: expected a SerialChain or a robot model with .chain, got {type(chain).__name__}")


def _stopping(mode: str, tolerance: float | None, max_iterations: int | None) -> tuple[float, int]:
    """(tolerance, passes) of ``mode``, its defaults for None; ValueError naming the argument."""
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    default_tolerance, default_cap = (
        (PAPER_TOLERANCE, PAPER_MAX_ITERATIONS) if mode == PAPER else (IMPROVED_TOLERANCE, IMPROVED_MAX_ITERATIONS)
    )
    stop = default_tolerance if tolerance is None else _number(tolerance, "tolerance")
    if stop <= 0.0:
        raise ValueError(f"tolerance: must be > 0, got {stop}")
    return stop, default_cap if max_iterations is None else _count(max_iterations, "max_iterations")


def _joint_values(chain: SerialChain, q0: ArrayLike) -> Array:
    """q0 as a fresh (n,) float array: a float array as it is (its finiteness checked with the limits), anything
    else through the chain's validation (ValueError naming q0)."""
    values: Array = (q0 if isinstance(q0, np.ndarray) and q0.dtype == np.float64 and q0.shape == (chain.n_joints,)
                     else chain.check_q(q0, "q0")).copy()
    return values


def _limits(values: ArrayLike | None, n: int, default: float, name: str) -> Array:
    """n joint limits as a fresh float array (±inf allowed; NaN is refused by :func:`_check_problem`), or all
    ``default`` when None; ValueError naming ``name``."""
    if values is None:
        return np.full(n, default)
    try:
        array = np.array(values if isinstance(values, np.ndarray) else real_array(values), dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected {n} numbers, got {values!r}") from exc
    if array.shape != (n,):
        raise ValueError(f"{name}: expected {n} joint limits, got shape {array.shape}")
    return array


def _check_problem(goal: Array, q0: Array, lower: Array, upper: Array) -> None:
    """ValueError naming the argument unless the goal is a unit dual quaternion and q0 finite and within limits
    that are numbers with lower ≤ upper (one compiled test; the reasons only when it fails)."""
    if kernels().well_posed(goal, q0, lower, upper, dqarray.UNIT_TOLERANCE):
        return
    dqarray.check_unit(goal, "goal")
    if not np.all(np.isfinite(q0)):
        raise ValueError("q0: contains NaN or infinite values")
    for name, limits in (("lower", lower), ("upper", upper)):
        if np.any(np.isnan(limits)):
            raise ValueError(f"{name}: contains NaN")
    if np.any(lower > upper):
        raise ValueError(f"lower: joint {int(np.argmax(lower > upper)) + 1} has lower limit above its upper limit")
    outside = (q0 < lower) | (q0 > upper)
    raise ValueError(f"q0: joint {int(np.argmax(outside)) + 1} is outside the joint limits")


def _paper_parameters(alpha: float | None, gamma: float | None) -> tuple[float, float]:
    """(α, γ) with the paper's defaults for None; ValueError unless 0 < α ≤ 1 and γ ≥ 0."""
    step_fraction = PAPER_ALPHA if alpha is None else _number(alpha, "alpha")
    damping = PAPER_GAMMA if gamma is None else _number(gamma, "gamma")
    if not 0.0 < step_fraction <= 1.0:
        raise ValueError(f"alpha: the step fraction must lie in (0, 1], got {step_fraction}")
    if damping < 0.0:
        raise ValueError(f"gamma: the damping must be ≥ 0, got {damping}")
    return step_fraction, damping


def _number(value: object, name: str) -> float:
    """A finite float; ValueError naming ``name``."""
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a number, got {value!r}") from exc
    if not np.isfinite(number):
        raise ValueError(f"{name}: must be finite, got {number}")
    return number


def _count(value: object, name: str) -> int:
    """An int ≥ 1; ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name}: expected a whole number ≥ 1, got {value!r}")
    return int(value)


def _goal_coefficients(goal: DualQuaternion | ArrayLike) -> Array:
    """(8,) coefficients of a goal given as DualQuaternion, 8 coefficients or a 6-vector (p, φ) (the unit check
    is :func:`_check_problem`'s)."""
    if isinstance(goal, DualQuaternion):
        return goal.to_array()
    array = dqarray.as_array(goal, (), "goal")
    if array.shape == (6,):
        return paper_vector_to_dual_quaternion(array)
    if array.shape != (8,):
        raise ValueError(f"goal: expected a DualQuaternion, 8 coefficients or 6 values (p, φ), got {array.shape}")
    return np.array(array, dtype=float)


def _goal_vector(goal: DualQuaternion | ArrayLike) -> Array:
    """Seed 001's goal vector g = (p, φ): a given 6-vector as is, a dual quaternion on the sheet it is given on."""
    if not isinstance(goal, DualQuaternion):
        array = dqarray.as_array(goal, (), "goal")
        if array.shape == (6,):
            return array
    return paper_pose_vector(dqarray.check_unit(_goal_coefficients(goal), "goal"))
