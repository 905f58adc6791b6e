"""Analytic inverse kinematics of the UR family, after the thesis' dual-quaternion derivation (seed 000, §4.3).

Frames: base = DH frame 0, flange = DH frame 6, standard DH (conventions.md); the pose asked for is the TCP
(flange · model.tcp). Angles in radians; every solution is returned canonical in (−π, π].

The thesis' equations, restated in the DH frames (its own frames differ by constant rotations):
  (4.9–4.11) wrist centre p5 = p − d6·z6 lies at distance d4 from the base axis along z1 = (sin θ1, −cos θ1, 0):
             x5·sin θ1 − y5·cos θ1 = d4, solved as θ1 = atan2(x5, −y5) ± atan2(√(x5² + y5² − d4²), d4).
  (4.13)     cos θ5 = z1·z6 (equal to (x6·sin θ1 − y6·cos θ1 − d4)/d6), two signs of θ5.
  (4.14–4.28) with r' = Rx(−π/2)·Rz(−θ1)·r (the thesis' N2 = Q1⁻¹·N1, rotation part) one gets the half-angle
             identities  w' = cos(θ5/2)·cos(Σ/2),  z' = cos(θ5/2)·sin(Σ/2),
                         x' = sin(θ5/2)·sin(Δ/2),  y' = −sin(θ5/2)·cos(Δ/2),
             Σ = θ234 + θ6, Δ = θ234 − θ6, θ234 = θ2 + θ3 + θ4, hence θ6 = (Σ − Δ)/2 and θ234 = (Σ + Δ)/2.
  (4.35–4.38) the planar 3R arm of joints 2–4: (x4, z4) = a2·(c2, s2) + a3·(c23, s23),
             cos θ3 = (x4² + z4² − a2² − a3²)/(2·a2·a3), two signs of θ3.
  (4.41)     θ2 = atan2(z4·(a2 + a3·c3) − x4·a3·s3, x4·(a2 + a3·c3) + z4·a3·s3).
  (4.44)     θ4 = θ234 − θ2 − θ3 (the thesis' half-angle form reduces to this: joints 2–4 are parallel).
  (4.45)     the FK filter: a branch is kept only if its forward kinematics reproduces the pose.

Up to 2 × 2 × 2 = 8 branches, ordered (θ1 sign, θ5 sign, θ3 sign) with the + sign first.

Singularities (defined behaviour, tested):
  wrist (θ5 ≈ 0 or π, |sin(θ5/2)| or |cos(θ5/2)| < WRIST_SINGULAR_TOLERANCE): axes 2, 3, 4 and 6 are parallel
      and the orientation fixes only Σ = θ234 + θ6 (or Δ = θ234 − θ6 at θ5 ≈ π): a one-parameter family. θ6 is
      set to the reference configuration's θ6 (0 without one: ik_all's documented choice) so wrist 3 does not
      jump; θ234 takes the rest and θ2, θ3 follow from the position. When the arm cannot reach with that split
      (the d5 offset turns with θ234), the nearest reachable split is used instead. The two θ5 signs merge.
      Near the singularity (< WRIST_NEAR_TOLERANCE) the computed split carries rounding of ~ε/θ5; a branch it
      pushes out of reach is moved back along the family the same way.
  shoulder (x5² + y5² = d4², the wrist centre's projection in the arm plane on the base axis): the two θ1 branches
      merge. UR arms have d4 > 0, so a wrist centre *on* the base axis is unreachable ("too close").
  stretched or folded elbow (cos θ3 = ±1): the two θ3 branches merge.
Values a rounding error outside their domain (|cos θ3| ≤ 1 + DOMAIN_TOLERANCE …) are clamped; the FK filter then
decides whether the pose is met. Unreachable poses raise UnreachablePoseError saying why.

Calibrated models (DH deltas): the nominal geometry (d1, a2, a3, d4, d5, d6 of the calibrated table) gives the
starting branches, then Newton steps on the calibrated FK converge each to CALIBRATED_TOLERANCE; the FK filter
still decides. Known limit: within ~0.05 rad of a wrist singularity or of the folded elbow, two nominal branches
can converge to the same calibrated solution, so ik_all may miss a neighbouring one there (whatever it returns
is FK-verified; ik then picks the nearest of those).

Single poses run in plain floats (no pyquaternion or numpy objects on the hot path); `ik` walks the branches
θ1 → wrist → elbow cheapest first, with the equations written out for a regular wrist, and stops solving a branch
that can no longer be the nearest; the ±2π variant nearest q_ref inside the limits is chosen per joint (the cost
is separable), and the FK filter checks the joints it returns. Batches of a
nominal model run a closed-form kernel (_regular_branches) in numpy over blocks of IK_BLOCK poses, all branches
at once (joint-major (6, 8, B) arrays): what the branches share is computed once (θ1 per pose, the wrist per θ1,
both θ5 signs from the same terms), and the FK filter evaluates the model's closed-form FK kernel on every
branch's final joints. Poses near a wrist or elbow singularity are redone by the general equations (_branches)
that single poses and calibrated models use, so the special cases above behave the same in every path.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics.models import BLOCK, URModel, _sincos_of_double, _ur_flange_rows

#: FK filter (thesis eq. 4.45): a branch is a solution when its FK is within these of the pose asked for.
#: Justification: the closed forms lose a few ulps on metre-sized arms (benchmarks/bench_kinematics.py measures the
#: residual of every solution of 10^5 random poses: ≈ 1e-15 m / 5e-15 rad), six orders below; near singular
#: points the clamped roots stay within 1e-10 (see below); and 1 nm / 1 nrad is four orders below any UR arm's
#: repeatability, so a branch that misses by more is not a solution of this pose.
FK_TOLERANCE_M = 1e-9
FK_TOLERANCE_RAD = 1e-9
#: Below this |sin(θ5/2)| (θ5 ≈ 0) or |cos(θ5/2)| (θ5 ≈ π) the wrist is treated as singular: setting θ5 to exactly
#: 0 (π) turns the flange by ≤ 2e-10 rad and moves it by ≤ d6·2e-10 m, inside the FK filter.
WRIST_SINGULAR_TOLERANCE = 1e-10
#: Below this |sin(θ5/2)| (or |cos(θ5/2)|) the θ234/θ6 split carries the rounding of θ1 (up to ~1e-14) divided by
#: it, which can push a stretched elbow out of reach (seen at θ5 = 1e-5); such a branch is moved along the
#: θ234 ± θ6 family back into reach. Only out-of-reach branches move, and the FK filter judges the result.
WRIST_NEAR_TOLERANCE = 1e-3
#: Below this |sin θ3| (elbow nearly stretched or folded) the batch kernel hands a pose to the general equations: θ3
#: there amplifies the rounding of cos θ3 by 1/sin θ3, and the single-pose solver's rounding is what to reproduce.
ELBOW_NEAR_TOLERANCE = 1e-3
#: Poses per block in the batch solver: its branch-level temporaries hold 8 rows per pose, so a block of BLOCK / 4
#: keeps them in the L2 cache like the FK's (measured best among 512–4096).
IK_BLOCK = BLOCK // 4
#: Relative rounding slack for the domains of the square roots / arccosines (shoulder, elbow); the clamped value
#: moves the wrist by < 1e-10 m, so the FK filter still judges the result.
DOMAIN_TOLERANCE = 1e-10
#: Two solutions closer than this in every joint (mod 2π) are the same solution.
DUPLICATE_TOLERANCE = 1e-9
#: Newton refinement on calibrated models stops below this pose error (metres + radians).
CALIBRATED_TOLERANCE = 1e-12
CALIBRATED_MAX_STEPS = 12
#: Domain slack of the nominal closed form on calibrated models: none — a calibrated arm reaches where its nominal
#: geometry cannot (near the stretched elbow), so every out-of-domain value is clamped and Newton (with the FK
#: filter) decides whether the branch exists.
CALIBRATED_DOMAIN_SLACK = math.inf
#: On calibrated models the clamped values stop this far inside the domain (θ3 = ±0.045 rad at the stretched
#: elbow): the two branches of a ± then start on their own sides of the singular point, beyond the nearby true
#: solutions, from where Newton on the (locally quadratic) reach runs monotonically to the one on its side.
CALIBRATED_DOMAIN_EDGE = 1e-3

_TWO_PI = 2.0 * math.pi
_CHORD_LIMIT = 2.0 * math.sin(0.25 * FK_TOLERANCE_RAD)   # chord |r1 ∓ r2| of a rotation by FK_TOLERANCE_RAD
_HALF_SQRT2 = math.sqrt(0.5)
_UNIT_WEIGHTS = (1.0,) * 6


# ------------------------------------------------------------------------------------------ model geometry
@dataclass(frozen=True)
class _Geometry:
    """What the solver needs of a model: the closed-form lengths, the full DH table and the TCP, as floats."""

    d1: float
    a2: float
    a3: float
    d4: float
    d5: float
    d6: float
    calibrated: bool      # some DH term beyond (d1, a2, a3, d4, d5, d6) is off nominal: refine with Newton
    domain_slack: float   # relative slack before a square root / arccosine argument counts as out of reach
    domain_edge: float    # relative margin kept inside the domain when clamping (0: clamp onto the boundary)
    joints: tuple         # per joint (a, d, θ offset, cos α/2, sin α/2): the full table, for FK
    tcp_inverse: tuple    # 8 floats of tcp⁻¹, or None for the identity TCP
    tcp_offset: tuple     # (rotation 4 floats, half translation 3 floats) of the TCP, or None for the identity
    half_lengths: tuple   # (d1, a2, a3, d4, d5, d6) / 2: what the closed-form FK kernel takes
    lower: tuple
    upper: tuple


_GEOMETRY_CACHE: dict = {}
_GEOMETRY_CACHE_SIZE = 64
_GEOMETRY_CACHE_LOCK = threading.Lock()   # drivers solve IK from their own threads


def _geometry(model) -> _Geometry:
    """The solver's view of ``model`` (cached per model object: models are immutable values)."""
    cached = _GEOMETRY_CACHE.get(id(model))
    if cached is not None and cached[0] is model:
        return cached[1]
    geometry = _build_geometry(model)
    with _GEOMETRY_CACHE_LOCK:
        if len(_GEOMETRY_CACHE) >= _GEOMETRY_CACHE_SIZE:
            _GEOMETRY_CACHE.pop(next(iter(_GEOMETRY_CACHE)))
        _GEOMETRY_CACHE[id(model)] = (model, geometry)   # the model is kept alive so its id cannot be reused
    return geometry


def _build_geometry(model) -> _Geometry:
    """Read DH (standard: a, d, α, θ offset), limits and TCP of ``model`` into plain floats."""
    dh = model.dh
    a, d, alpha, theta = (tuple(float(v) for v in column) for column in (dh.a, dh.d, dh.alpha, dh.theta))
    joints = tuple((a[i], d[i], theta[i], math.cos(0.5 * alpha[i]), math.sin(0.5 * alpha[i])) for i in range(6))
    tcp = tuple(float(v) for v in model.tcp.to_array())
    tcp_inverse = None if tcp == (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0) else _dq_conjugate(tcp)
    tcp_offset = None if tcp_inverse is None else (tcp[:4], tuple(0.5 * v for v in _translation_columns(tcp)))
    calibrated = not dh.is_nominal_structure()
    slack = CALIBRATED_DOMAIN_SLACK if calibrated else DOMAIN_TOLERANCE
    edge = CALIBRATED_DOMAIN_EDGE if calibrated else 0.0
    half_lengths = tuple(0.5 * v for v in (d[0], a[1], a[2], d[3], d[4], d[5]))
    return _Geometry(d[0], a[1], a[2], d[3], d[4], d[5], calibrated, slack, edge, joints, tcp_inverse, tcp_offset,
                     half_lengths,
                     tuple(float(v) for v in model.joint_lower), tuple(float(v) for v in model.joint_upper))


# --------------------------------------------------------------------------------- scalar / array backends
class _ScalarOps:
    """Plain-float math for single poses: no numpy object churn on the hot path."""

    sqrt = staticmethod(math.sqrt)
    atan2 = staticmethod(math.atan2)
    cos = staticmethod(math.cos)
    sin = staticmethod(math.sin)
    asin = staticmethod(math.asin)

    @staticmethod
    def where(condition, if_true, if_false):
        """Select like numpy.where, for floats."""
        return if_true if condition else if_false

    @staticmethod
    def clamp_or_nan(value, low, high, slack):
        """``value`` clipped into [low, high] if within ``slack`` of it, else NaN."""
        if value < low - slack or value > high + slack:
            return math.nan
        return min(max(value, low), high)

    @staticmethod
    def wrap(angle):
        """Angle into [−π, π] (either end: used for distances only; NaN stays NaN)."""
        return math.remainder(angle, _TWO_PI)

    any = staticmethod(bool)
    isnan = staticmethod(math.isnan)


class _ArrayOps:
    """numpy math over arrays of poses: every branch of every pose at once."""

    sqrt = staticmethod(np.sqrt)
    atan2 = staticmethod(np.arctan2)
    cos = staticmethod(np.cos)
    sin = staticmethod(np.sin)
    asin = staticmethod(np.arcsin)
    where = staticmethod(np.where)

    @staticmethod
    def clamp_or_nan(value, low, high, slack):
        """``value`` clipped into [low, high] where within ``slack`` of it, NaN elsewhere."""
        with np.errstate(invalid="ignore"):
            outside = (value < low - slack) | (value > high + slack)
        return np.where(outside, np.nan, np.clip(value, low, high))

    @staticmethod
    def wrap(angle):
        """Angles into [−π, π] (either end: used for distances only)."""
        return angle - _TWO_PI * np.round(angle / _TWO_PI)

    any = staticmethod(np.any)
    isnan = staticmethod(np.isnan)


# --------------------------------------------------------------------------------- the thesis' equations
def _wrist_centre(g: _Geometry, qw, qx, qy, qz, px, py):
    """(x5, y5) of the wrist centre p5 = p − d6·z6 in the base frame (z6 = third column of the flange rotation)."""
    z6x = 2.0 * (qx * qz + qw * qy)
    z6y = 2.0 * (qy * qz - qw * qx)
    return px - g.d6 * z6x, py - g.d6 * z6y


def _theta1_pair(ops, g: _Geometry, x5, y5):
    """The two θ1 (eqs. 4.10–4.11) solving x5·sin θ1 − y5·cos θ1 = d4; NaN when the wrist centre is too close."""
    d4 = g.d4
    radial2 = x5 * x5 + y5 * y5
    # cos of the shoulder offset angle = d4/ρ must be ≤ 1: ρ ≥ d4 (clamped within the domain slack).
    reach = ops.clamp_or_nan(radial2 - d4 * d4, g.domain_edge * d4 * d4, math.inf, g.domain_slack * d4 * d4)
    base = ops.atan2(x5, -y5)
    offset = ops.atan2(ops.sqrt(reach), d4)
    return base + offset, base - offset


def _reduced_rotation(ops, theta1, qw, qx, qy, qz):
    """(cos θ1, sin θ1, (w', x', y', z')): r' = Rx(−π/2)·Rz(−θ1)·r, what wrist joints 2…6 must produce."""
    ch, sh = ops.cos(0.5 * theta1), -ops.sin(0.5 * theta1)
    # Rz(−θ1)·r, with Rz(−θ1) = (ch, 0, 0, sh).
    w1, x1, y1, z1 = ch * qw - sh * qz, ch * qx - sh * qy, ch * qy + sh * qx, ch * qz + sh * qw
    # Rx(−π/2)·(…), with Rx(−π/2) = (h, −h, 0, 0).
    h = _HALF_SQRT2
    reduced = (h * (w1 + x1), h * (x1 - w1), h * (y1 + z1), h * (z1 - y1))
    return ch * ch - sh * sh, -2.0 * ch * sh, reduced


def _wrist_pair(ops, reduced, theta6_ref):
    """(θ5, θ6, θ234) for θ5 ≥ 0 and for θ5 ≤ 0 (eqs. 4.13–4.28 in half-angle form); singular: θ6 = theta6_ref.

    Also returns the flags (singular at 0, singular at π, near-singular, nearer 0 than π) used by _branches.
    """
    w, x, y, z = reduced
    sin_half5 = ops.sqrt(x * x + y * y)
    cos_half5 = ops.sqrt(w * w + z * z)
    half_sum = ops.atan2(z, w)          # Σ/2 = (θ234 + θ6)/2, eqs. 4.14 and 4.16
    half_diff = ops.atan2(x, -y)        # Δ/2 = (θ234 − θ6)/2 for sin(θ5/2) > 0, eqs. 4.15 and 4.17
    at_zero = sin_half5 < WRIST_SINGULAR_TOLERANCE
    at_pi = cos_half5 < WRIST_SINGULAR_TOLERANCE
    singular = at_zero | at_pi
    theta5 = ops.where(at_zero, 0.0, ops.where(at_pi, math.pi, 2.0 * ops.atan2(sin_half5, cos_half5)))
    theta6 = ops.where(singular, theta6_ref, half_sum - half_diff)
    theta234 = ops.where(at_zero, 2.0 * half_sum - theta6,
                         ops.where(at_pi, 2.0 * half_diff + theta6, half_sum + half_diff))
    # −θ5 turns Δ/2 by π (x', y' change sign): the wrist flip θ6 − π, θ234 + π; one solution when singular.
    flipped = (-theta5, ops.where(singular, theta6, theta6 - math.pi),
               ops.where(singular, theta234, theta234 + math.pi))
    near = (sin_half5 < WRIST_NEAR_TOLERANCE) | (cos_half5 < WRIST_NEAR_TOLERANCE)
    return (theta5, theta6, theta234), flipped, (singular, near, sin_half5 < cos_half5)


def _reachable_wrist_family(ops, g: _Geometry, cos1, sin1, theta5, theta234, px, py, pz):
    """The θ234 nearest ``theta234`` at which the planar arm reaches, for fixed θ1 and θ5 (NaN if none does).

    Eq. 4.34 gives (x4, z4) = P − ρ·(sin ψ, −cos ψ) with P = (c1 px + s1 py, pz − d1), ρ = |(d5, d6 s5)|,
    ψ = θ234 − atan2(d6 s5, d5): a circle. The elbow must span R² + ρ² − 2ρR·sin(ψ − φ) (R, φ: polar form of P),
    between the folded and the stretched arm; the allowed ψ form arcs whose ends have sin(ψ − φ) = low or high.
    """
    near_x, near_z = cos1 * px + sin1 * py, pz - g.d1
    radius = ops.sqrt(near_x * near_x + near_z * near_z)
    phase = ops.atan2(near_z, near_x)
    offset = g.d6 * ops.sin(theta5)
    rho = ops.sqrt(g.d5 * g.d5 + offset * offset)
    beta = ops.atan2(offset, g.d5)
    longest, shortest = abs(g.a2) + abs(g.a3), abs(abs(g.a2) - abs(g.a3))
    base2 = radius * radius + rho * rho
    low = (base2 - longest * longest) / (2.0 * rho * radius)
    high = (base2 - shortest * shortest) / (2.0 * rho * radius)
    psi = theta234 - beta
    sine = ops.sin(psi - phase)
    best = psi
    best_distance = ops.where((sine >= low) & (sine <= high), 0.0, math.inf)
    for bound in (low, high):
        arc_end = ops.asin(ops.clamp_or_nan(bound, -1.0, 1.0, 0.0))
        for candidate in (phase + arc_end, phase + math.pi - arc_end):
            distance = abs(ops.wrap(candidate - psi))
            nearer = distance < best_distance     # False for NaN: an arc end that does not exist
            best = ops.where(nearer, candidate, best)
            best_distance = ops.where(nearer, distance, best_distance)
    return ops.where(best_distance < math.inf, best + beta, math.nan)


def _planar_arm(ops, g: _Geometry, cos1, sin1, theta5, theta234, px, py, pz):
    """(x4, z4): where joints 2–3 must put the frame-4 origin, in the shoulder plane (eqs. 4.33–4.34)."""
    c234, s234 = ops.cos(theta234), ops.sin(theta234)
    s5 = ops.sin(theta5)
    x4 = cos1 * px + sin1 * py - s234 * g.d5 + c234 * s5 * g.d6
    z4 = pz - g.d1 + c234 * g.d5 + s234 * s5 * g.d6
    return x4, z4


def _elbow_cosine(ops, g: _Geometry, x4, z4):
    """cos θ3 of eq. 4.38, clamped within rounding of ±1 (stretched / folded elbow), NaN when out of reach."""
    cos3 = (x4 * x4 + z4 * z4 - g.a2 * g.a2 - g.a3 * g.a3) / (2.0 * g.a2 * g.a3)
    return ops.clamp_or_nan(cos3, g.domain_edge - 1.0, 1.0 - g.domain_edge, g.domain_slack)


def _shoulder_elbow_pair(ops, g: _Geometry, x4, z4, cos3):
    """((θ2, θ3) with θ3 ≥ 0, (θ2, θ3) with θ3 ≤ 0): θ3 from eq. 4.38, θ2 from eq. 4.41."""
    sin3 = ops.sqrt(1.0 - cos3 * cos3)
    theta3 = ops.atan2(sin3, cos3)
    along = g.a2 + g.a3 * cos3
    across = g.a3 * sin3
    near_x, near_z = x4 * along, z4 * along
    far_x, far_z = x4 * across, z4 * across
    return ((ops.atan2(near_z - far_x, near_x + far_z), theta3),
            (ops.atan2(near_z + far_x, near_x - far_z), -theta3))


def _elbow_for_wrist(ops, g: _Geometry, cos1, sin1, wrist, flags, px, py, pz):
    """(θ6, θ234, x4, z4, cos θ3) of one wrist branch (eqs. 4.33–4.38), moved along a singular wrist's family.

    At (or near) a singular wrist only θ234 + θ6 (θ5 ≈ 0) or θ234 − θ6 (θ5 ≈ π) is well determined; a split the
    arm cannot reach is moved to the nearest reachable one, θ6 compensating; the FK filter judges the result.
    """
    theta5, theta6, theta234 = wrist
    singular, near, nearer_zero = flags
    x4, z4 = _planar_arm(ops, g, cos1, sin1, theta5, theta234, px, py, pz)
    cos3 = _elbow_cosine(ops, g, x4, z4)
    move = singular | (near & ops.isnan(cos3))
    if ops.any(move):
        reachable = _reachable_wrist_family(ops, g, cos1, sin1, theta5, theta234, px, py, pz)
        shift = ops.where(move, reachable - theta234, 0.0)
        theta234 = theta234 + shift
        theta6 = theta6 + ops.where(nearer_zero, -shift, shift)
        x4, z4 = _planar_arm(ops, g, cos1, sin1, theta5, theta234, px, py, pz)
        cos3 = _elbow_cosine(ops, g, x4, z4)
    return theta6, theta234, x4, z4, cos3


def _branches(ops, g: _Geometry, target, theta6_ref):
    """The 8 analytic branches (θ1…θ6 tuples, NaN where one does not exist), by (θ1, θ5, θ3) sign, + first."""
    qw, qx, qy, qz, px, py, pz = target
    x5, y5 = _wrist_centre(g, qw, qx, qy, qz, px, py)
    branches = []
    for theta1 in _theta1_pair(ops, g, x5, y5):
        cos1, sin1, reduced = _reduced_rotation(ops, theta1, qw, qx, qy, qz)
        upper, lower, flags = _wrist_pair(ops, reduced, theta6_ref)
        for wrist in (upper, lower):
            theta6, theta234, x4, z4, cos3 = _elbow_for_wrist(ops, g, cos1, sin1, wrist, flags, px, py, pz)
            for theta2, theta3 in _shoulder_elbow_pair(ops, g, x4, z4, cos3):
                theta4 = theta234 - theta2 - theta3   # eq. 4.44
                branches.append((theta1, theta2, theta3, theta4, wrist[0], theta6))
    return branches


# ---------------------------------------------------------------------------------- plain-float pose helpers
def wrap_angle(angle):
    """Angle(s) mapped into (−π, π] (radians; floats or arrays, NaN stays NaN)."""
    angle = np.asarray(angle, dtype=float)
    wrapped = angle - _TWO_PI * np.rint(angle / _TWO_PI)
    # Rounding can land a hair outside [−π, π]: fold the ends back so the interval is exactly (−π, π].
    wrapped = np.where(wrapped <= -math.pi, wrapped + _TWO_PI, wrapped)
    return np.where(wrapped > math.pi, wrapped - _TWO_PI, wrapped)


def _wrap_float(angle: float) -> float:
    """A float angle mapped into (−π, π] (IEEE remainder: exact, then −π moved to π)."""
    wrapped = math.remainder(angle, _TWO_PI)
    return wrapped + _TWO_PI if wrapped <= -math.pi else wrapped


def _quaternion_product(a, b) -> tuple:
    """Hamilton product a·b of two (w, x, y, z) float tuples."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def _rotate(q, v) -> tuple:
    """Vector v rotated by unit quaternion q: v + 2w(u×v) + 2u×(u×v), u = vector part of q."""
    w, ux, uy, uz = q
    vx, vy, vz = v
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    return (vx + 2.0 * (w * cx + uy * cz - uz * cy), vy + 2.0 * (w * cy + uz * cx - ux * cz),
            vz + 2.0 * (w * cz + ux * cy - uy * cx))


def _dq_conjugate(c) -> tuple:
    """r* + ε d* of 8 floats: the inverse of a unit dual quaternion."""
    return (c[0], -c[1], -c[2], -c[3], c[4], -c[5], -c[6], -c[7])


def _dq_product(a, b) -> tuple:
    """(ra + ε da)(rb + ε db) = ra rb + ε(ra db + da rb) of two 8-float tuples."""
    real = _quaternion_product(a[:4], b[:4])
    left, right = _quaternion_product(a[:4], b[4:]), _quaternion_product(a[4:], b[:4])
    return real + tuple(x + y for x, y in zip(left, right))


def _pair_of(c) -> tuple:
    """(qw, qx, qy, qz, px, py, pz) — the thesis pair (q, p) — of a unit dual quaternion's 8 floats: p = 2·d·r*."""
    return tuple(c[:4]) + _translation_columns(c)


def _pose_coefficients(pose, name: str) -> tuple:
    """8 floats of a unit pose given as a DualQuaternion or 8 numbers; ValueError naming ``name`` otherwise."""
    if isinstance(pose, DualQuaternion):
        c = pose._c   # its 8 floats as they are: no array round trip on the single-pose path
    else:
        try:
            values = np.asarray(pose, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: expected a DualQuaternion or 8 coefficients, got {pose!r}") from exc
        if values.shape != (8,):
            raise ValueError(f"{name}: expected a DualQuaternion or 8 coefficients, got shape {values.shape}")
        c = tuple(values.tolist())
    norm2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]
    if not math.isfinite(norm2 + c[4] + c[5] + c[6] + c[7]):
        raise ValueError(f"{name}: contains NaN or infinite values")
    if abs(norm2 - 1.0) > 2.0 * dqarray.UNIT_TOLERANCE:
        raise ValueError(f"{name}: rotation part is not a unit quaternion (norm² {norm2:.6g})")
    orthogonality = c[0] * c[4] + c[1] * c[5] + c[2] * c[6] + c[3] * c[7]
    if abs(orthogonality) > dqarray.UNIT_TOLERANCE:
        raise ValueError(f"{name}: not a unit dual quaternion (real·dual = {orthogonality:.3g}, must be 0)")
    return c


def _targets(g: _Geometry, pose) -> tuple:
    """(TCP coefficients (8 floats), flange pair (qw, qx, qy, qz, px, py, pz)) of a TCP pose; flange = pose · tcp⁻¹."""
    c = _pose_coefficients(pose, "pose")
    return c, _pair_of(c if g.tcp_inverse is None else _dq_product(c, g.tcp_inverse))


def _within_fk_tolerance(fk, target) -> np.ndarray:
    """Whether poses fk and target (8 coefficient arrays each) agree: |Δt| ≤ FK_TOLERANCE_M and the rotation
    angle ≤ FK_TOLERANCE_RAD. The chord |r_fk ∓ r| = 2 sin(angle/4) decides the angle exactly, from squared
    differences: no cancellation-prone dot product near 1, no trigonometry per pose (_meets: the same for floats)."""
    fx, fy, fz = _translation_columns(fk)
    tx, ty, tz = _translation_columns(target)
    position_error2 = (fx - tx) ** 2 + (fy - ty) ** 2 + (fz - tz) ** 2
    sign = np.where(fk[0] * target[0] + fk[1] * target[1] + fk[2] * target[2] + fk[3] * target[3] < 0.0,
                    -1.0, 1.0)
    chord2 = ((fk[0] - sign * target[0]) ** 2 + (fk[1] - sign * target[1]) ** 2
              + (fk[2] - sign * target[2]) ** 2 + (fk[3] - sign * target[3]) ** 2)
    return (position_error2 <= FK_TOLERANCE_M ** 2) & (chord2 <= _CHORD_LIMIT ** 2)


def _translation_columns(c) -> tuple:
    """(x, y, z) = vector part of 2·d·r* of unit dual quaternion coefficients c (8 floats or 8 arrays)."""
    rw, rx, ry, rz, dw, dx, dy, dz = c
    return (2.0 * (-dw * rx + dx * rw - dy * rz + dz * ry), 2.0 * (-dw * ry + dx * rz + dy * rw - dz * rx),
            2.0 * (-dw * rz - dx * ry + dy * rx + dz * rw))


def _meets(model, q, tcp_coefficients) -> bool:
    """The thesis' FK filter (eq. 4.45) for one pose: the model's FK at the 6 floats ``q`` against the TCP pose's
    8 coefficients, with the tests of _within_fk_tolerance written out in floats (single-pose hot path)."""
    fk = model._fk_floats(q)
    fw, fx, fy, fz = fk[:4]
    tw, tx, ty, tz = tcp_coefficients[:4]
    if fw * tw + fx * tx + fy * ty + fz * tz < 0.0:   # σ ≡ −σ: compare with the nearer sign
        tw, tx, ty, tz = -tw, -tx, -ty, -tz
    if (fw - tw) ** 2 + (fx - tx) ** 2 + (fy - ty) ** 2 + (fz - tz) ** 2 > _CHORD_LIMIT ** 2:
        return False
    (fx, fy, fz), (tx, ty, tz) = _translation_columns(fk), _translation_columns(tcp_coefficients)
    return (fx - tx) ** 2 + (fy - ty) ** 2 + (fz - tz) ** 2 <= FK_TOLERANCE_M ** 2


# ------------------------------------------------------------------------------------------------ single pose
def _unreachable_reason(g: _Geometry, target, branches_existed: bool) -> str:
    """Why ``target`` (flange pair) has no solution: the first geometric constraint it violates, in words."""
    qw, qx, qy, qz, px, py, pz = target
    x5, y5 = _wrist_centre(g, qw, qx, qy, qz, px, py)
    radial = math.hypot(x5, y5)
    if radial < abs(g.d4) * (1.0 - DOMAIN_TOLERANCE):
        return (f"too close to the base axis: the wrist centre is {radial:.4f} m from it, "
                f"less than the shoulder offset d4 = {abs(g.d4):.4f} m")
    reach_max, reach_min = abs(g.a2) + abs(g.a3), abs(abs(g.a2) - abs(g.a3))
    needed, singular_wrist = [], []
    for theta1 in _theta1_pair(_ScalarOps, g, x5, y5):
        cos1, sin1, reduced = _reduced_rotation(_ScalarOps, theta1, qw, qx, qy, qz)
        upper, lower, (singular, _, _) = _wrist_pair(_ScalarOps, reduced, 0.0)
        singular_wrist.append(singular)
        for theta5, _, theta234 in (upper, lower):
            needed.append(math.hypot(*_planar_arm(_ScalarOps, g, cos1, sin1, theta5, theta234, px, py, pz)))
    prefix = "wrist singular (θ5 = 0 or π) and no θ4 ± θ6 split reaches: " if all(singular_wrist) else ""
    if all(n > reach_max for n in needed):
        return (f"{prefix}too far: the elbow would have to span {min(needed):.4f} m, "
                f"the upper and lower arm reach at most {reach_max:.4f} m")
    if all(n < reach_min for n in needed):
        return (f"{prefix}too close: the elbow would have to span {max(needed):.4f} m, "
                f"the folded arm reaches no closer than {reach_min:.4f} m")
    if branches_existed:
        return "no analytic branch passes the FK filter (numerically singular pose)"
    return "out of reach of every elbow branch for this wrist orientation"


def _refine_calibrated(g: _Geometry, branches: list, target) -> list:
    """Newton steps on the calibrated FK from the nominal branches; those that converge, as float tuples."""
    refined, residual = _refine_batch(g, np.array(branches, dtype=float), np.tile(np.array(target), (len(branches), 1)))
    return [tuple(q) for q, r in zip(refined.tolist(), residual.tolist()) if r <= CALIBRATED_TOLERANCE]


def _solution_candidates(g: _Geometry, target, theta6_ref: float) -> list:
    """Existing analytic branches of ``target`` (flange pair), refined if calibrated; unwrapped, not yet filtered."""
    candidates = [branch for branch in _branches(_ScalarOps, g, target, theta6_ref)
                  if branch[1] == branch[1] and branch[0] == branch[0]]   # NaN: the branch does not exist
    if g.calibrated and candidates:
        return _refine_calibrated(g, candidates, target)
    return candidates


def _is_new(solution, kept) -> bool:
    """True unless some kept solution agrees with ``solution`` within DUPLICATE_TOLERANCE in every joint (mod 2π)."""
    for other in kept:
        for x, y in zip(solution, other):
            if abs(math.remainder(x - y, _TWO_PI)) >= DUPLICATE_TOLERANCE:
                break
        else:
            return False
    return True


def _reference(q_ref, name: str = "q_ref") -> tuple:
    """Six finite floats of a joint reference (or weights); ValueError naming ``name`` otherwise."""
    return URModel._joint_floats(q_ref, name)


def ik_all(model, pose, q_ref=None) -> list:
    """Every FK-verified joint solution (radians, each in (−π, π]) of the TCP ``pose`` (base frame), up to 8.

    ``q_ref`` (optional) only resolves the wrist singularity: there θ6 is set to q_ref[5] (0 without a reference)
    when the arm can reach with it, θ2 + θ3 + θ4 takes the rest of the θ234 ± θ6 the orientation fixes (see the
    module notes). Raises UnreachablePoseError (a ValueError) saying why when no solution exists.
    """
    g = _geometry(model)
    tcp_coefficients, target = _targets(g, pose)
    theta6_ref = 0.0 if q_ref is None else _wrap_float(_reference(q_ref)[5])
    candidates = _solution_candidates(g, target, theta6_ref)
    solutions = []
    for candidate in candidates:
        if _is_new(candidate, solutions) and _meets(model, candidate, tcp_coefficients):
            solutions.append(candidate)
    if not solutions:
        raise UnreachablePoseError(f"pose unreachable for {model.name}: "
                                   f"{_unreachable_reason(g, target, bool(candidates))}")
    return [np.array([_wrap_float(v) for v in solution]) for solution in solutions]


def _closest_variant(angle: float, reference: float, lower: float, upper: float) -> float:
    """angle + 2πk inside [lower, upper] closest to ``reference`` (radians); inf when no variant fits the limits.

    Per joint on its own: the cost Σ wᵢ·Δqᵢ² has diagonal weights and the limits are per joint, so the nearest
    variant of a whole solution is the nearest variant of each joint — no product of variants to enumerate.
    """
    centre = reference + math.remainder(angle - reference, _TWO_PI)
    if lower <= centre <= upper:
        return centre   # the nearest variant of all: nothing inside the limits can be nearer
    # The in-limit variants run from the first above ``lower`` to the last below ``upper``; the nearest variant of
    # all lies beyond one end, and so does the reference (within π of it): that end is the nearest in-limit one.
    if centre < lower:
        end = angle + _TWO_PI * math.ceil((lower - angle) / _TWO_PI)
        end = end + _TWO_PI if end < lower else end   # rounding of the division
    else:
        end = angle + _TWO_PI * math.floor((upper - angle) / _TWO_PI)
        end = end - _TWO_PI if end > upper else end
    return end if lower <= end <= upper else math.inf


def _weights(weights) -> tuple:
    """Six positive finite joint weights (default all 1); ValueError naming ``weights`` otherwise."""
    if weights is None:
        return _UNIT_WEIGHTS
    values = _reference(weights, "weights")
    if any(w <= 0.0 for w in values):
        raise ValueError(f"weights: every joint weight must be > 0, got {list(values)}")
    return values


def _joint_cost(g: _Geometry, joint: int, angle: float, reference, weights) -> float:
    """wⱼ·(v − refⱼ)² for the ±2π variant v of ``angle`` inside joint ``joint``'s limits nearest refⱼ (inf: none)."""
    shift = _closest_variant(angle, reference[joint], g.lower[joint], g.upper[joint]) - reference[joint]
    return weights[joint] * shift * shift


def _nearest_candidate(g: _Geometry, candidates, reference, weights):
    """The candidate with the least Σ wᵢ·(qᵢ − refᵢ)² over in-limit ±2π variants, or None if none fits.

    Branch and bound: candidates are ranked by the joints that tell branches apart (θ1, θ5, θ3) and the other
    joints are only added while a candidate can still win (usually for one or two of them).
    """
    ranked = sorted((_joint_cost(g, 0, c[0], reference, weights) + _joint_cost(g, 4, c[4], reference, weights)
                     + _joint_cost(g, 2, c[2], reference, weights), index) for index, c in enumerate(candidates))
    best, best_cost = None, math.inf
    for partial, index in ranked:
        if partial >= best_cost:
            break
        candidate = candidates[index]
        cost = (partial + _joint_cost(g, 1, candidate[1], reference, weights)
                + _joint_cost(g, 3, candidate[3], reference, weights)
                + _joint_cost(g, 5, candidate[5], reference, weights))
        if cost < best_cost:
            best, best_cost = candidate, cost
    return best


def _nearest_branch(g: _Geometry, target, reference, weights):
    """The analytic solution of ``target`` (flange pair, nominal model) nearest ``reference``, as the in-limit
    ±2π variants of its joints nearest ``reference`` (6 floats); None when nothing fits the limits.

    The equations of _branches, walked θ1 → wrist → elbow sign, cheapest first (branch and bound): a θ1, wrist or
    elbow sign whose own joint costs already reach the best complete cost is not solved further, so usually one
    branch is solved in full. Written out in plain floats with the very expressions of _theta1_pair,
    _reduced_rotation, _planar_arm, _elbow_cosine and _shoulder_elbow_pair (each Python call costs as much as
    the arithmetic here); a (near-)singular wrist, a clamped shoulder or a clamped elbow go through those general
    functions, so every special case behaves exactly as in _branches (ik_all).
    """
    qw, qx, qy, qz, px, py, pz = target
    d1, a2, a3, d4, d5, d6 = g.d1, g.a2, g.a3, g.d4, g.d5, g.d6
    lower, upper = g.lower, g.upper
    ref1, ref2, ref3, ref4, ref5, ref6 = reference
    weight1, weight2, weight3, weight4, weight5, weight6 = weights
    cos, sin, atan2, sqrt = math.cos, math.sin, math.atan2, math.sqrt
    x5, y5 = _wrist_centre(g, qw, qx, qy, qz, px, py)
    reach = x5 * x5 + y5 * y5 - d4 * d4
    if reach > g.domain_edge * d4 * d4:
        base, offset = atan2(x5, -y5), atan2(sqrt(reach), d4)
        theta1_pair = (base + offset, base - offset)
    else:   # on or inside the shoulder circle: clamped within the domain slack, NaN beyond
        theta1_pair = _theta1_pair(_ScalarOps, g, x5, y5)
        if theta1_pair[0] != theta1_pair[0]:   # NaN: the wrist centre is too close to the base axis
            return None
    shoulders = []
    for theta1 in theta1_pair:
        variant1 = _closest_variant(theta1, ref1, lower[0], upper[0])
        shoulders.append((weight1 * (variant1 - ref1) ** 2, theta1, variant1))
    shoulders.sort()
    best, best_cost = None, math.inf
    for cost1, theta1, variant1 in shoulders:
        if cost1 >= best_cost:
            break
        # _reduced_rotation: r' = Rx(−π/2)·Rz(−θ1)·r.
        ch, sh = cos(0.5 * theta1), -sin(0.5 * theta1)
        w1, x1, y1, z1 = ch * qw - sh * qz, ch * qx - sh * qy, ch * qy + sh * qx, ch * qz + sh * qw
        h = _HALF_SQRT2
        w, x, y, z = h * (w1 + x1), h * (x1 - w1), h * (y1 + z1), h * (z1 - y1)
        cos1, sin1 = ch * ch - sh * sh, -2.0 * ch * sh
        sin_half5, cos_half5 = sqrt(x * x + y * y), sqrt(w * w + z * z)
        if sin_half5 < WRIST_NEAR_TOLERANCE or cos_half5 < WRIST_NEAR_TOLERANCE:
            upper_wrist, lower_wrist, flags = _wrist_pair(_ScalarOps, (w, x, y, z), _wrap_float(ref6))
        else:   # _wrist_pair's regular case
            half_sum, half_diff = atan2(z, w), atan2(x, -y)
            theta5 = 2.0 * atan2(sin_half5, cos_half5)
            upper_wrist = (theta5, half_sum - half_diff, half_sum + half_diff)
            lower_wrist = (-theta5, upper_wrist[1] - math.pi, upper_wrist[2] + math.pi)
            flags = None
        variant5_upper = _closest_variant(upper_wrist[0], ref5, lower[4], upper[4])
        variant5_lower = _closest_variant(lower_wrist[0], ref5, lower[4], upper[4])
        cost_upper = cost1 + weight5 * (variant5_upper - ref5) ** 2
        cost_lower = cost1 + weight5 * (variant5_lower - ref5) ** 2
        wrists = ((cost_upper, variant5_upper, upper_wrist), (cost_lower, variant5_lower, lower_wrist))
        if cost_lower < cost_upper:
            wrists = wrists[::-1]
        for cost15, variant5, wrist in wrists:
            if cost15 >= best_cost:
                break
            theta5, theta6, theta234 = wrist
            if flags is None:   # _planar_arm and _elbow_cosine
                c234, s234, s5 = cos(theta234), sin(theta234), sin(theta5)
                x4 = cos1 * px + sin1 * py - s234 * d5 + c234 * s5 * d6
                z4 = pz - d1 + c234 * d5 + s234 * s5 * d6
                cos3 = (x4 * x4 + z4 * z4 - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
                if not g.domain_edge - 1.0 <= cos3 <= 1.0 - g.domain_edge:
                    cos3 = _ScalarOps.clamp_or_nan(cos3, g.domain_edge - 1.0, 1.0 - g.domain_edge, g.domain_slack)
            else:
                theta6, theta234, x4, z4, cos3 = _elbow_for_wrist(_ScalarOps, g, cos1, sin1, wrist, flags,
                                                                  px, py, pz)
            if cos3 != cos3:   # NaN: the elbow cannot reach
                continue
            variant6 = _closest_variant(theta6, ref6, lower[5], upper[5])
            cost156 = cost15 + weight6 * (variant6 - ref6) ** 2
            if cost156 >= best_cost:
                continue
            # _shoulder_elbow_pair, one elbow sign at a time.
            sin3 = sqrt(1.0 - cos3 * cos3)
            theta3 = atan2(sin3, cos3)
            along, across = a2 + a3 * cos3, a3 * sin3
            near_x, near_z, far_x, far_z = x4 * along, z4 * along, x4 * across, z4 * across
            for theta3, sign in ((theta3, 1.0), (-theta3, -1.0)):
                variant3 = _closest_variant(theta3, ref3, lower[2], upper[2])
                cost = cost156 + weight3 * (variant3 - ref3) ** 2
                if cost >= best_cost:
                    continue
                theta2 = atan2(near_z - sign * far_x, near_x + sign * far_z)   # eq. 4.41
                theta4 = theta234 - theta2 - theta3   # eq. 4.44
                variant2 = _closest_variant(theta2, ref2, lower[1], upper[1])
                variant4 = _closest_variant(theta4, ref4, lower[3], upper[3])
                cost += weight2 * (variant2 - ref2) ** 2 + weight4 * (variant4 - ref4) ** 2
                if cost < best_cost:
                    best_cost = cost
                    best = (variant1, variant2, variant3, variant4, variant5, variant6)
    return best


def _nearest_joints(g: _Geometry, solution, reference) -> tuple:
    """The joints of ``solution`` moved by ±2π to the in-limit variants nearest ``reference`` (inf: none fits)."""
    return tuple(_closest_variant(angle, ref, low, high)
                 for angle, ref, low, high in zip(solution, reference, g.lower, g.upper))


def joint_variants(model, q) -> np.ndarray:
    """(M, 6) every q + 2πk (per joint) inside the model's limits; an unlimited joint is listed within ±2π."""
    g = _geometry(model)
    per_joint = []
    for angle, low, high in zip(_reference(q, "q"), g.lower, g.upper):
        low = -_TWO_PI if math.isinf(low) else low
        high = _TWO_PI if math.isinf(high) else high
        first = angle + _TWO_PI * math.ceil((low - angle) / _TWO_PI)
        per_joint.append(np.arange(first, high + 1e-12, _TWO_PI) if first <= high else np.empty(0))
    grids = np.meshgrid(*per_joint, indexing="ij")
    return np.stack([grid.ravel() for grid in grids], axis=-1)


def ik(model, pose, q_ref, weights=None) -> np.ndarray:
    """The joint solution of TCP ``pose`` nearest ``q_ref`` (Σ wᵢ·Δqᵢ², over all ±2π variants inside the limits).

    This is the choice a replay needs: the arm never flips branch while a nearer one exists. At the wrist
    singularity θ6 stays at q_ref[5] (unless the arm cannot reach with it). The FK filter runs on the winner
    (then on the runner-up if it fails). Raises UnreachablePoseError when no solution lies inside the joint limits.
    """
    g = _geometry(model)
    reference = _reference(q_ref)
    weight = _weights(weights)
    tcp_coefficients, target = _targets(g, pose)
    if not g.calibrated:
        best = _nearest_branch(g, target, reference, weight)
        if best is not None and _meets(model, best, tcp_coefficients):
            return np.array(best)
    # Calibrated models (Newton on every branch), or a winner the FK filter rejected: rank all candidates.
    candidates = _solution_candidates(g, target, _wrap_float(reference[5]))
    remaining = list(candidates)
    # Nearest first, FK filter only on the winner (usually one FK evaluation); a rejected winner is dropped.
    while remaining:
        best = _nearest_candidate(g, remaining, reference, weight)
        if best is None:
            break
        joints = _nearest_joints(g, best, reference)
        if _meets(model, joints, tcp_coefficients):
            return np.array(joints)
        remaining.remove(best)
    if any(_meets(model, c, tcp_coefficients) for c in candidates):
        raise UnreachablePoseError(f"pose unreachable for {model.name}: outside limits — every solution has a "
                                   "joint outside the joint limits")
    raise UnreachablePoseError(f"pose unreachable for {model.name}: "
                               f"{_unreachable_reason(g, target, bool(candidates))}")


# ----------------------------------------------------------------------------------------------------- batches
def _batch_poses(poses) -> np.ndarray:
    """(N, 8) unit dual quaternions; ValueError naming ``poses`` for a wrong shape, NaN/inf or non-unit rows."""
    array = np.asarray(poses, dtype=float)
    if array.ndim != 2 or array.shape[1] != 8:
        raise ValueError(f"poses: expected shape (N, 8), got {array.shape}")
    return dqarray.check_unit(array, "poses")


def _batch_flange_targets(g: _Geometry, poses: np.ndarray) -> tuple:
    """Seven (N,) arrays (qw, qx, qy, qz, px, py, pz): flange pairs of (N, 8) TCP poses (pose · tcp⁻¹)."""
    if g.tcp_inverse is not None:
        poses = dqarray.multiply_unchecked(poses, np.array(g.tcp_inverse))
    translation = dqarray.translation_unchecked(poses)
    return tuple(poses[:, i] for i in range(4)) + tuple(translation[:, i] for i in range(3))


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
        rotation = _quaternion_product(
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
    """Newton steps on the calibrated FK: (refined q (M, 6), final residual norm (M,)); rows of NaN stay NaN."""
    q = q.copy()
    for _ in range(CALIBRATED_MAX_STEPS):
        frames = _chain_frames(g, q)
        error = _pose_residual(frames[-1], targets)
        residual = np.linalg.norm(error, axis=-1)
        active = residual > 0.1 * CALIBRATED_TOLERANCE
        if not np.any(active):
            break
        jacobian = _geometric_jacobian(frames)
        # The pseudo-inverse keeps a near-singular row from spoiling the others (np.linalg.solve would raise).
        step = np.einsum("mij,mj->mi", np.linalg.pinv(jacobian, rcond=1e-12), error)
        q = q + np.where(active[:, None], step, 0.0)
    residual = np.linalg.norm(_pose_residual(_chain_frames(g, q)[-1], targets), axis=-1)
    return q, residual


def _batch_candidates(g: _Geometry, targets: tuple, theta6_ref) -> np.ndarray:
    """(6, 8, N) canonical analytic branches (joint, branch, pose) of flange targets (seven (N,) arrays).

    Joint-major layout: every joint of every branch is one contiguous run, which is what the elementwise
    kernels (and the model's fk_batch, reading columns) want; refined by Newton first on calibrated models.
    """
    count = len(targets[0])
    columns = np.empty((6, 8, count))
    for k, branch in enumerate(_branches(_ArrayOps, g, targets, theta6_ref)):
        for j, value in enumerate(branch):
            columns[j, k] = value
    if g.calibrated:
        flat = columns.reshape(6, -1).T
        repeated = np.tile(np.stack(targets, axis=-1), (8, 1))
        usable = np.all(np.isfinite(flat), axis=1)
        refined, residual = _refine_batch(g, flat[usable], repeated[usable])
        flat = flat.copy()
        flat[usable] = np.where((residual <= CALIBRATED_TOLERANCE)[:, None], refined, np.nan)
        columns = np.ascontiguousarray(flat.T).reshape(6, 8, count)
    # θ2, θ3 come from atan2 already in (−π, π]; θ1, θ4, θ6 are sums and θ5 may be −π.
    for j in (0, 3, 4, 5):
        columns[j] = wrap_angle(columns[j])
    return columns


def _fk_filter(model, columns: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """(8, N) mask of the branches (6, 8, N) whose FK meets poses (N, 8) (the thesis' filter, eq. 4.45)."""
    exists = ~np.isnan(columns).any(axis=0)
    fk = model.fk_batch(np.where(exists, columns, 0.0).reshape(6, -1).T)
    # One transposing copy makes every coefficient a contiguous run: the comparison then runs twice as fast.
    fk_columns = np.ascontiguousarray(fk.T).reshape((8,) + exists.shape)
    return exists & _within_fk_tolerance(fk_columns, np.ascontiguousarray(poses.T))


def _drop_duplicates(columns: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """``keep`` (8, N) with every branch that repeats (within DUPLICATE_TOLERANCE, mod 2π) a kept earlier one cleared.

    Joint by joint, only the poses still alike are compared further (most branch pairs differ in θ1 already).
    """
    keep = keep.copy()
    for later in range(1, 8):
        for earlier in range(later):
            alike = np.flatnonzero(keep[later] & keep[earlier])
            for joint in (0, 4, 2, 1, 3, 5):
                if alike.size == 0:
                    break
                difference = columns[joint, later, alike] - columns[joint, earlier, alike]
                difference -= _TWO_PI * np.rint(difference / _TWO_PI)
                alike = alike[np.abs(difference) < DUPLICATE_TOLERANCE]
            keep[later, alike] = False
    return keep


def _solved_blocks(model, g: _Geometry, poses: np.ndarray, theta6_ref: np.ndarray):
    """Per block of poses: (rows, branches (6, 8, B) canonical, FK-filter mask (8, B), ambiguous (B,)).

    Where the mask is False a branch may hold any value (NaN or the clamped values of a branch that does not exist).

    ``rows`` (slice or index array) says which poses a block holds; ``ambiguous`` marks the poses where two
    branches may coincide (merged θ1, θ5 or θ3 signs) and need the duplicate check. Nominal models take the
    closed-form kernel; its poses near a wrist or elbow singularity are collected and redone together, last,
    by the general equations (whose cost is mostly per call). Calibrated models take the general equations and
    Newton throughout.
    """
    if g.calibrated:
        columns = _batch_candidates(g, _batch_flange_targets(g, poses), theta6_ref)
        yield slice(0, len(poses)), columns, _fk_filter(model, columns, poses), np.ones(len(poses), dtype=bool)
        return
    redo = []
    for start in range(0, len(poses), IK_BLOCK):
        rows = slice(start, start + IK_BLOCK)
        coefficients = np.ascontiguousarray(poses[rows].T)
        pair = _pair_rows(coefficients)
        flange = pair if g.tcp_inverse is None else _pair_rows(_dq_product(coefficients, g.tcp_inverse))
        with np.errstate(divide="ignore", invalid="ignore"):   # exact singularities: those poses are redone
            columns, exists, merged, near_singular = _regular_branches(g, flange)
        valid = _regular_fk_filter(g, columns, pair, grouped=True)
        valid &= exists
        if near_singular.any():
            valid[:, near_singular] = False
            redo.append(start + np.flatnonzero(near_singular))
        yield rows, columns, valid, merged
    if redo:
        rows = np.concatenate(redo)
        columns = _batch_candidates(g, _batch_flange_targets(g, poses[rows]), theta6_ref[rows])
        valid = _regular_fk_filter(g, columns, _pair_rows(poses[rows].T), grouped=False)
        yield rows, columns, valid, np.ones(len(rows), dtype=bool)


def _pair_rows(coefficients) -> np.ndarray:
    """(7, B) thesis pairs (qw, qx, qy, qz, px, py, pz) of unit dual quaternions given as 8 rows of B: p = 2·d·r*."""
    return np.stack((*coefficients[:4], *_translation_columns(coefficients)))


def _regular_branches(g: _Geometry, target: np.ndarray) -> tuple:
    """(branches (6, 8, B), exists (8, B), merged (B,), near_singular (B,)) of flange pairs (7, B), nominal model.

    The equations of _branches with everything shared that can be: θ1's two values once per pose, the wrist and
    the planar arm once per θ1, both θ5 signs from the same terms (the flip turns θ234 by π and negates θ5, so
    cos θ234·sin θ5 and sin θ234·sin θ5 stay), and cos θ234, sin θ234, sin θ5 from the reduced rotation's half
    angles instead of trigonometry. Branches are canonical and finite: one that does not exist (shoulder or elbow
    out of reach) holds its clamped values and ``exists`` is False for it (NaN would send numpy's vectorised tan
    of the FK filter down a slow path). Valid away from the wrist singularity only: ``near_singular`` marks the
    poses (|sin θ5/2| or |cos θ5/2| < WRIST_NEAR_TOLERANCE for some θ1, or |sin θ3| < ELBOW_NEAR_TOLERANCE) whose
    branches the caller must redo with _branches. ``merged``: poses whose θ1 or θ3 branches may coincide.
    """
    qw, qx, qy, qz, px, py, pz = target
    count = target.shape[1]
    x5, y5 = _wrist_centre(g, qw, qx, qy, qz, px, py)
    d4_2 = g.d4 * g.d4
    reach = x5 * x5
    reach += y5 * y5
    reach -= d4_2
    shoulder_reaches = reach >= -g.domain_slack * d4_2
    np.maximum(reach, 0.0, out=reach)
    offset = np.arctan2(np.sqrt(reach, out=reach), g.d4)
    base = np.arctan2(x5, -y5)
    theta1 = np.stack((base + offset, base - offset))
    # cos, sin of θ1/2 scaled by √½ (the Rx(−π/2) factor of the reduced rotation, eq. 4.14 ff.).
    sin_half1, cos_half1 = _sincos_of_double(0.25 * theta1)
    cos1 = cos_half1 * cos_half1
    cos1 -= sin_half1 * sin_half1
    sin1 = sin_half1 * cos_half1
    sin1 *= 2.0
    cos_half1 *= _HALF_SQRT2
    sin_half1 *= _HALF_SQRT2
    # r' = Rx(−π/2)·Rz(−θ1)·r as in _reduced_rotation, with Rz(−θ1) = (c, 0, 0, −s).
    w1 = cos_half1 * qw + sin_half1 * qz
    x1 = cos_half1 * qx + sin_half1 * qy
    y1 = cos_half1 * qy - sin_half1 * qx
    z1 = cos_half1 * qz - sin_half1 * qw
    w, x, y, z = w1 + x1, x1 - w1, y1 + z1, z1 - y1
    sin_half5_2 = x * x
    sin_half5_2 += y * y
    cos_half5_2 = w * w
    cos_half5_2 += z * z
    sin_half5, cos_half5 = np.sqrt(sin_half5_2), np.sqrt(cos_half5_2)
    near_singular = np.any((sin_half5 < WRIST_NEAR_TOLERANCE) | (cos_half5 < WRIST_NEAR_TOLERANCE), axis=0)
    half_sum = np.arctan2(z, w)          # Σ/2, eqs. 4.14 and 4.16
    half_diff = np.arctan2(x, -y)        # Δ/2, eqs. 4.15 and 4.17
    theta5 = np.arctan2(sin_half5, cos_half5)
    theta5 *= 2.0
    # θ234 = Σ/2 + Δ/2: its cosine and sine times |w, z|·|x, y| (eqs. 4.14–4.17).
    cos234_scaled = w * y
    cos234_scaled += z * x
    np.negative(cos234_scaled, out=cos234_scaled)
    sin234_scaled = w * x
    sin234_scaled -= z * y
    # sin θ5 = 2·|x,y|·|w,z|/(|x,y|² + |w,z|²), so cos θ234·sin θ5 = 2·cos234_scaled/norm² (likewise for sin).
    norm2 = sin_half5_2
    norm2 += cos_half5_2
    np.divide(2.0 * g.d6, norm2, out=norm2)
    product = sin_half5
    product *= cos_half5
    np.divide(g.d5, product, out=product)
    # Planar arm target (x4, z4) for θ5 ≥ 0 and for the flipped wrist (eq. 4.34): axis 1 is the θ5 sign.
    reach_x = cos1 * px
    reach_x += sin1 * py
    reach_x += cos234_scaled * norm2
    reach_z = sin234_scaled * norm2
    reach_z += pz - g.d1
    wrist_x = sin234_scaled * product    # d5·sin θ234
    wrist_z = cos234_scaled * product    # d5·cos θ234
    x4 = np.stack((reach_x - wrist_x, reach_x + wrist_x), axis=1)
    z4 = np.stack((reach_z + wrist_z, reach_z - wrist_z), axis=1)
    cos3 = x4 * x4
    cos3 += z4 * z4
    cos3 -= g.a2 * g.a2 + g.a3 * g.a3
    cos3 *= 1.0 / (2.0 * g.a2 * g.a3)
    elbow_reaches = np.abs(cos3) <= 1.0 + g.domain_slack
    np.clip(cos3, -1.0, 1.0, out=cos3)
    sin3 = cos3 * cos3
    np.subtract(1.0, sin3, out=sin3)
    np.sqrt(sin3, out=sin3)
    theta3 = np.arctan2(sin3, cos3)
    # Near the stretched or folded elbow θ3 carries the rounding of cos θ3 divided by sin θ3: those poses are
    # redone with the very equations the single-pose solver uses, so both give the same branches there.
    near_singular |= np.any((sin3 < ELBOW_NEAR_TOLERANCE) & elbow_reaches, axis=(0, 1))
    near_singular &= shoulder_reaches
    along = cos3
    along *= g.a3
    along += g.a2
    across = sin3
    across *= g.a3
    near_x, near_z = x4 * along, z4 * along
    far_x, far_z = x4 * across, z4 * across

    columns = np.empty((6, 2, 2, 2, count))   # joint, θ1 sign, θ5 sign, θ3 sign, pose
    columns[0] = _wrap_in_place(theta1)[:, None, None]
    np.arctan2(near_z - far_x, near_x + far_z, out=columns[1, :, :, 0])
    np.arctan2(near_z + far_x, near_x - far_z, out=columns[1, :, :, 1])
    columns[2, :, :, 0] = theta3
    np.negative(theta3, out=columns[2, :, :, 1])
    # θ5 ∈ (0, π) away from the singularity: both signs are canonical as they are.
    columns[4, :, 0] = theta5[:, None]
    np.negative(columns[4, :, 0], out=columns[4, :, 1])
    theta6 = np.stack((half_sum - half_diff, half_sum - half_diff - math.pi), axis=1)
    columns[5] = _wrap_in_place(theta6)[:, :, None]
    theta234 = half_sum + half_diff
    columns[3, :, 0] = theta234[:, None]
    theta234 += math.pi
    columns[3, :, 1] = theta234[:, None]
    columns[3] -= columns[1]
    columns[3] -= columns[2]                 # θ4 = θ234 − θ2 − θ3, eq. 4.44
    _wrap_in_place(columns[3])
    exists = np.broadcast_to((elbow_reaches & shoulder_reaches[None, None, :])[:, :, None], (2, 2, 2, count))
    elbow_merged = (np.abs(theta3) < DUPLICATE_TOLERANCE) | (np.abs(theta3) > math.pi - DUPLICATE_TOLERANCE)
    merged = (offset < DUPLICATE_TOLERANCE) | np.any(elbow_merged & elbow_reaches, axis=(0, 1))
    return columns.reshape(6, 8, count), exists.reshape(8, count), merged, near_singular


def _wrap_in_place(angle: np.ndarray) -> np.ndarray:
    """Angles mapped into (−π, π] in place, as wrap_angle does (NaN stays NaN); returns ``angle``."""
    turns = angle * (1.0 / _TWO_PI)
    np.rint(turns, out=turns)
    turns *= _TWO_PI
    angle -= turns
    # Rounding can land a hair outside [−π, π]: fold the ends back (rarely needed, so tested first).
    low = angle <= -math.pi
    if low.any():
        angle[low] += _TWO_PI
    high = angle > math.pi
    if high.any():
        angle[high] -= _TWO_PI
    return angle


def _regular_fk_filter(g: _Geometry, columns: np.ndarray, target: np.ndarray, grouped: bool) -> np.ndarray:
    """(8, B) mask of the branches (6, 8, B) whose FK meets the TCP poses, given as pairs (7, B) (see _pair_rows):
    the thesis' filter (eq. 4.45).

    The model's closed-form FK (models._ur_flange_rows) of every branch's final joint angles, composed with the
    TCP, against the pose asked for, with the tolerances of _within_fk_tolerance (a NaN branch fails).
    ``grouped``: the caller built the branches with one θ1 value per four (θ1 sign) and one θ5, θ6 per pair
    (θ1, θ5 signs), as _regular_branches does; those values then enter the FK once per group.
    """
    count = target.shape[1]
    joints = columns.reshape(6, 2, 2, 2, count)
    q1, q5, q6 = joints[0], joints[4], joints[5]
    if grouped:
        q1, q5, q6 = q1[:, :1, :1], q5[:, :, :1], q6[:, :, :1]
    flange = _ur_flange_rows(g.half_lengths, q1, joints[1], joints[2], joints[3], q5, q6).reshape(7, 8, count)
    rotation, half_position = flange[:4], flange[4:]
    if g.tcp_offset is not None:
        rotation, half_position = _tool_rows(rotation, half_position, g.tcp_offset)
    error = half_position - 0.5 * target[4:, None, :]
    error *= error
    position_ok = error.sum(axis=0) <= (0.5 * FK_TOLERANCE_M) ** 2
    minus = rotation - target[:4, None, :]
    plus = rotation + target[:4, None, :]
    minus *= minus
    plus *= plus
    chord2 = np.minimum(minus.sum(axis=0), plus.sum(axis=0))   # the sign of σ ≡ −σ that is nearer
    return position_ok & (chord2 <= _CHORD_LIMIT ** 2)


def _tool_rows(rotation: np.ndarray, half_position: np.ndarray, tool) -> tuple:
    """(r·r_t, ½(p + r·t_t·r*)) rows of flange rows (r (4, M), ½p (3, M)) and a tool (r_t (4 floats), ½t_t (3))."""
    (tw, tx, ty, tz), (hx, hy, hz) = tool
    w, x, y, z = rotation
    composed = np.stack((w * tw - x * tx - y * ty - z * tz, w * tx + x * tw + y * tz - z * ty,
                         w * ty - x * tz + y * tw + z * tx, w * tz + x * ty - y * tx + z * tw))
    # v + 2w(u×v) + 2u×(u×v), u the vector part of r, v = ½t_t.
    cx, cy, cz = y * hz - z * hy, z * hx - x * hz, x * hy - y * hx
    moved = np.stack((hx + 2.0 * (w * cx + y * cz - z * cy), hy + 2.0 * (w * cy + z * cx - x * cz),
                      hz + 2.0 * (w * cz + x * cy - y * cx)))
    return composed, half_position + moved


def ik_all_batch(model, poses, q_ref=None) -> np.ndarray:
    """(N, 8, 6) every FK-verified solution of (N, 8) TCP poses, in (−π, π]; absent branches are rows of NaN.

    Branch k of every pose is the same sign choice (θ1, θ5, θ3) in that order, + first; duplicates are NaN.
    ``q_ref`` ((6,) or (N, 6), optional) only resolves the wrist singularity as in ik_all.
    The result is the transposed view of a joint-major (6, 8, N) array (each joint of each branch contiguous).
    """
    g = _geometry(model)
    poses = _batch_poses(poses)
    theta6_ref = np.zeros(len(poses)) if q_ref is None else wrap_angle(_batch_reference(q_ref, len(poses))[:, 5])
    out = np.empty((6, 8, len(poses)))
    for rows, columns, valid, ambiguous in _solved_blocks(model, g, poses, theta6_ref):
        keep = valid
        if ambiguous.any():   # only poses where two branches can coincide need the pairwise comparison
            keep = valid.copy()
            keep[:, ambiguous] = _drop_duplicates(columns[:, :, ambiguous], valid[:, ambiguous])
        columns += np.where(keep, 0.0, np.nan)   # + 0 keeps a value, + NaN blanks it (cheaper than a masked copy)
        out[:, :, rows] = columns
    return out.transpose(2, 1, 0)


def _batch_reference(q_ref, count: int) -> np.ndarray:
    """(count, 6) finite joint references from a (6,) or (count, 6) array; ValueError naming ``q_ref``."""
    reference = np.asarray(q_ref, dtype=float)
    if reference.shape == (6,):
        reference = np.broadcast_to(reference, (count, 6))
    if reference.shape != (count, 6):
        raise ValueError(f"q_ref: expected shape (6,) or ({count}, 6), got {reference.shape}")
    if not np.all(np.isfinite(reference)):
        raise ValueError("q_ref: contains NaN or infinite values")
    return reference


def _nearest_variants(g: _Geometry, columns: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(6, 8, N) ±2π variants of the branches nearest ``reference`` (6, 1, N) inside the limits; NaN if none fits.

    As _closest_variant: the nearest variant of all when it is inside, else the end of the in-limit run on its side.
    """
    centre = columns + _TWO_PI * np.rint((reference - columns) / _TWO_PI)
    lower, upper = np.array(g.lower)[:, None, None], np.array(g.upper)[:, None, None]
    with np.errstate(invalid="ignore"):   # ±inf limits: their end is never selected
        first = columns + _TWO_PI * np.ceil((lower - columns) / _TWO_PI)
        first = np.where(first < lower, first + _TWO_PI, first)
        last = columns + _TWO_PI * np.floor((upper - columns) / _TWO_PI)
        last = np.where(last > upper, last - _TWO_PI, last)
    best = np.where(centre < lower, first, np.where(centre > upper, last, centre))
    return np.where((best >= lower) & (best <= upper), best, np.nan)


def ik_batch(model, poses, q_ref, weights=None) -> np.ndarray:
    """(N, 6): for each (N, 8) TCP pose the solution nearest q_ref ((6,) or (N, 6)) as in ``ik``; NaN rows where
    the pose is unreachable or no solution lies inside the joint limits (no exception: batches keep going)."""
    poses = _batch_poses(poses)
    reference = _batch_reference(q_ref, len(poses))
    weight = np.array(_weights(weights))[:, None, None]
    g = _geometry(model)
    out = np.empty((len(poses), 6))
    for rows, columns, valid, _ in _solved_blocks(model, g, poses, wrap_angle(reference[:, 5])):
        # Duplicates cannot change which branch is nearest: only the FK filter is needed here.
        reference_columns = reference[rows].T[:, None, :]
        variants = _nearest_variants(g, columns, reference_columns)
        cost = np.sum(weight * (variants - reference_columns) ** 2, axis=0)
        cost = np.where(valid & ~np.isnan(cost), cost, np.inf)
        best = np.argmin(cost, axis=0)
        chosen = np.take_along_axis(variants, best[None, None, :], axis=1)[:, 0, :].T
        reachable = np.isfinite(np.take_along_axis(cost, best[None, :], axis=0)[0])
        out[rows] = np.where(reachable[:, None], chosen, np.nan)
    return out
