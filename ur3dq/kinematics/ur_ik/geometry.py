"""What the analytic IK needs of a model, as plain floats (cached per model), and its tolerances."""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass

from ur3dq.dualquat import conjugate_coefficients, multiply_quaternion_coefficients
from ur3dq.kinematics.ur_fk import BLOCK

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
#: Poses per block in ik_batch: it keeps 34 variants per pose (not 48 branch joints twice) and runs the FK of one
#: branch per pose, so its ~250 numpy calls per block cover fewer elements each; blocks of BLOCK amortise them
#: (measured on 10^5 poses: 1.68 µs/pose at 4096 against 1.91 at 1024 and 2.55 at 512).
NEAREST_BLOCK = BLOCK
#: Relative rounding slack for the domains of the square roots / arccosines (shoulder, elbow); the clamped value
#: moves the wrist by < 1e-10 m, so the FK filter still judges the result.
DOMAIN_TOLERANCE = 1e-10
#: A solved joint angle this far (rad) past a joint limit is taken as the limit: a joint at exactly ±2π comes back
#: from the equations as ±1e-15 and its 2π variant rounds past the limit; on a calibrated arm Newton stops within
#: ~1e-12/σ of the solution (σ the Jacobian's least singular value), up to ~5e-10 rad a few degrees from a
#: singularity, where 1e-10 let ik drop the solution at the limit for another configuration. Moves the TCP by
#: ~1e-9 m at most, the FK filter's tolerance.
LIMIT_ROUNDING = 1e-10
#: Two solutions closer than this in every joint (mod 2π) are the same solution (one rule: ik_all_batch takes its
#: near-singular poses from ik_all's own code, single._branch_table). Near a singularity the two branches of one
#: configuration come out up to ~1e-8 rad apart (√ε amplification of rounding): at 1e-6, a hundred times that,
#: they are reported once. Two configurations 1e-6 rad apart in every joint put the TCP within ~1 µm.
DUPLICATE_TOLERANCE = 1e-6
#: Newton refinement on calibrated models accepts a branch below this pose error (metres + radians): 10× under the FK
#: filter, and above the rounding floor of a factory table (≈ 3e-13 with its ±440 m cancelling d offsets, measured).
CALIBRATED_TOLERANCE = 1e-10
#: Newton steps at most: a seed beside a singularity, or one that first moves away from its basin, may need 13
#: (a UR5e seed at |sin θ5| = 0.06 reached 2e-11 at step 12 and 1e-16 at 13, measured); converged rows stop early.
CALIBRATED_MAX_STEPS = 16
#: Domain slack of the nominal closed form on calibrated models: a calibrated arm reaches where its nominal geometry
#: cannot (near the stretched elbow), so out-of-domain values within this slack are clamped and Newton (with the FK
#: filter) decides whether the branch exists. Beyond it (|cos θ3| > 1.1, or the wrist centre inside 0.95·d4 of the
#: base axis: centimetres past the nominal reach, a hundred times a factory calibration's millimetres) the branch is
#: absent. Measured on 2800 factory-table poses (every model, 40 % within 0.05 rad of a singularity): of the 2598
#: seeds beyond it 34 converged, each onto a solution another branch found too; the rest ran Newton's full
#: CALIBRATED_MAX_STEPS for nothing (a straggler keeps a whole ik/ik_all call stepping).
CALIBRATED_DOMAIN_SLACK = 0.1
#: On calibrated models the clamped values stop this far inside the domain (θ3 = ±0.045 rad at the stretched
#: elbow): the two branches of a ± then start on their own sides of the singular point, beyond the nearby true
#: solutions, from where Newton on the (locally quadratic) reach runs monotonically to the one on its side.
CALIBRATED_DOMAIN_EDGE = 1e-3
_TWO_PI = 2.0 * math.pi


_CHORD_LIMIT = 2.0 * math.sin(0.25 * FK_TOLERANCE_RAD)   # chord |r1 ∓ r2| of a rotation by FK_TOLERANCE_RAD


_HALF_SQRT2 = math.sqrt(0.5)


_UNIT_WEIGHTS = (1.0,) * 6


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
    tcp_inverse = None if tcp == (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0) else conjugate_coefficients(tcp)
    tcp_offset = None if tcp_inverse is None else (tcp[:4], tuple(0.5 * v for v in _translation_columns(tcp)))
    calibrated = not dh.is_nominal_structure()
    slack = CALIBRATED_DOMAIN_SLACK if calibrated else DOMAIN_TOLERANCE
    edge = CALIBRATED_DOMAIN_EDGE if calibrated else 0.0
    lengths = model.seed_lengths if calibrated else (d[0], a[1], a[2], d[3], d[4], d[5])
    half_lengths = tuple(0.5 * v for v in lengths)
    return _Geometry(*lengths, calibrated, slack, edge, joints, tcp_inverse, tcp_offset,
                     half_lengths,
                     tuple(float(v) for v in model.joint_lower), tuple(float(v) for v in model.joint_upper))


def _translation_columns(c) -> tuple:
    """(x, y, z) = vector part of 2·d·r* of unit dual quaternion coefficients c (8 floats or 8 arrays)."""
    rw, rx, ry, rz, dw, dx, dy, dz = c
    return (2.0 * (-dw * rx + dx * rw - dy * rz + dz * ry), 2.0 * (-dw * ry + dx * rz + dy * rw - dz * rx),
            2.0 * (-dw * rz - dx * ry + dy * rx + dz * rw))


def _flange_of(c, tcp_inverse) -> tuple:
    """pose · tcp⁻¹ of 8 coefficients (floats or arrays) as real·real + ε(real·dual + dual·real).

    The sum is grouped per part (not as in dualquat.multiply_coefficients) on purpose: near an elbow or wrist
    singularity the branches amplify an ulp of the flange pose, and single poses and batches must round alike.
    """
    real = multiply_quaternion_coefficients(c[:4], tcp_inverse[:4])
    left = multiply_quaternion_coefficients(c[:4], tcp_inverse[4:])
    right = multiply_quaternion_coefficients(c[4:], tcp_inverse[:4])
    return real + tuple(x + y for x, y in zip(left, right))
