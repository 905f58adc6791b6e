"""What the kernels need of a model, as one float vector (built once per model), and the IK's tolerances.

The kernels take a model as this vector (``arm_vector``): one array argument is the cheapest thing to pass to a
compiled function. The slices below name its parts.
"""
from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np

from ur3dq import dqarray
from ur3dq.kinematics.chain import SerialChain

#: FK filter (thesis eq. 4.45): a branch is a solution when its FK is within these of the pose asked for. The closed
#: forms lose a few ulps on metre-sized arms (≈ 1e-15 m / 5e-15 rad), six orders below; 1 nm / 1 nrad is four
#: orders below any UR arm's repeatability, so a branch that misses by more is not a solution of this pose.
FK_TOLERANCE_M = 1e-9
FK_TOLERANCE_RAD = 1e-9
#: Below this |sin(θ5/2)| (θ5 ≈ 0) or |cos(θ5/2)| (θ5 ≈ π) the wrist is singular: setting θ5 to exactly 0 (π) turns
#: the flange by ≤ 2e-10 rad and moves it by ≤ d6·2e-10 m, inside the FK filter.
WRIST_SINGULAR_TOLERANCE = 1e-10
#: Below this |sin(θ5/2)| (or |cos(θ5/2)|) the θ234/θ6 split carries the rounding of θ1 divided by it, which can
#: push a stretched elbow out of reach (seen at θ5 = 1e-5); such a branch moves along the θ234 ± θ6 family.
WRIST_NEAR_TOLERANCE = 1e-3
#: The same band on a calibrated arm's seeds: the calibration turns the wrist by milliradians, which moves a seed's
#: θ234/θ6 split by that over sin θ5, enough (below |sin θ5| ≈ 0.3) to put its elbow out of reach.
CALIBRATED_WRIST_NEAR = 0.15
#: Relative rounding slack of the square roots' and arccosines' domains (shoulder, elbow) on a nominal arm.
DOMAIN_TOLERANCE = 1e-10
#: A nominal elbow with 1 − |cos θ3| below this is taken as exactly stretched (folded): θ3 computed there is the
#: square root of rounding (~1.5e-8 rad for ~1e-16, ~2e-7 where a nearly singular wrist amplifies the split's
#: rounding), and the configuration θ3 = 0 (π) meets the pose to a3·θ3²/2 ≲ 1e-13 m. Both elbow branches then are
#: that one configuration.
ELBOW_ROUNDING = 1e-12
#: A solved joint angle this far (rad) past a joint limit may be taken as the limit: a joint at exactly ±2π comes back
#: as ±1e-15 past it, and on a calibrated arm Newton stops within ~1e-12/σ of the solution (σ the Jacobian's least
#: singular value: up to ~5e-10 rad a few degrees from a singularity). The clamp turns the flange by at most this
#: and moves it by at most this times ~1.3 m, inside the FK filter; the filter, which runs on the joints returned,
#: judges a long tool: where the clamped joints miss the pose, the variant strictly inside the limits is taken.
LIMIT_ROUNDING = 5e-10
#: Two solutions closer than this in every joint (mod 2π) are the same solution: near a singularity the two branches
#: of one configuration come out up to ~1e-8 rad apart. Two configurations 1e-6 rad apart put the TCP within 1 µm.
DUPLICATE_TOLERANCE = 1e-6
#: Newton on calibrated arms accepts a row below this pose error (metres + radians): 10× under the FK filter and
#: above the rounding floor of a factory table (≈ 3e-13 with its ±440 m cancelling d offsets).
CALIBRATED_TOLERANCE = 1e-10
#: Domain slack of the nominal closed form when it seeds a calibrated arm: the calibrated arm reaches where the
#: nominal one cannot (near the stretched elbow), so values within this slack are clamped and Newton decides.
CALIBRATED_DOMAIN_SLACK = 0.1
#: On calibrated arms clamped values stop this far inside the domain (θ3 = ±0.045 rad at the stretched elbow): the
#: two branches of a ± then start on their own sides of the singular point.
CALIBRATED_DOMAIN_EDGE = 1e-3

# The vector's parts (start indices; lengths in the comments).
LENGTHS = 0        # d1, a2, a3, d4, d5, d6 (6): the closed form's lengths (a calibrated arm's catalogue ones)
SLACK = 6          # relative domain slack of the closed form (1)
EDGE = 7           # relative margin kept inside the domain when clamping (1)
CALIBRATED = 8     # 1.0 when Newton on the full DH chain refines the closed form (1)
DH = 9             # per joint i at DH + 5·i: a, d, θ offset, cos α, sin α (30)
TCP = 39           # the TCP's dual quaternion in the flange frame (8)
LOWER = 47         # joint limits (6)
UPPER = 53         # joint limits (6)
THIRD_DERIVATIVE = 59  # M₃ of newton.isolated: |F‴(x)(d, d, d)| ≤ M₃·|d|³ for the chain (1)
WRIST_NEAR = 60    # |sin(θ5/2)| or |cos(θ5/2)| below which an unreachable split moves along the wrist's family (1)
SIZE = 61

_CACHE: dict[int, tuple[Any, np.ndarray]] = {}
_CACHE_LOCK = threading.Lock()   # drivers solve IK from their own threads


def arm_vector(model: Any) -> np.ndarray:
    """The kernels' view of ``model`` (a URModel), cached per model object (models are immutable values)."""
    cached = _CACHE.get(id(model))
    if cached is not None and cached[0] is model:
        return cached[1]
    vector = _build(model)
    with _CACHE_LOCK:
        if len(_CACHE) >= 64:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[id(model)] = (model, vector)   # the model is kept alive so its id cannot be reused
    return vector


def _build(model: Any) -> np.ndarray:
    """The vector of a URModel: its DH, closed-form lengths (a calibrated arm's catalogue ones), TCP and limits."""
    dh = model.dh
    lengths = (dh.d[0], dh.a[1], dh.a[2], dh.d[3], dh.d[4], dh.d[5])
    return vector(dh.a, dh.d, dh.alpha, dh.theta, lengths if dh.is_nominal_structure() else model.seed_lengths,
                  model.tcp.to_array(), model.joint_lower, model.joint_upper)


def vector(a: Any, d: Any, alpha: Any, theta: Any, lengths: Any, tcp: Any, lower: Any, upper: Any) -> np.ndarray:
    """The kernels' vector of an arm given by its standard DH columns (6 each: a, d, α, θ offset), the closed form's
    lengths (d1, a2, a3, d4, d5, d6), the TCP's 8 coefficients and the joint limits. The arm is calibrated (Newton
    refines the closed form) where its table differs from the closed form's structure or lengths."""
    vector = np.zeros(SIZE)
    table = np.stack((a, d, theta, np.cos(alpha), np.sin(alpha)), axis=1).astype(float)
    structure = (tuple(np.asarray(alpha, dtype=float)) == (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
                 and not np.any(theta) and not np.any(np.asarray(a)[[0, 3, 4, 5]]) and not np.any(np.asarray(d)[[1, 2]])
                 and tuple(map(float, lengths)) == (d[0], a[1], a[2], d[3], d[4], d[5]))
    vector[LENGTHS:LENGTHS + 6] = lengths
    vector[SLACK] = DOMAIN_TOLERANCE if structure else CALIBRATED_DOMAIN_SLACK
    vector[EDGE] = 0.0 if structure else CALIBRATED_DOMAIN_EDGE
    vector[CALIBRATED] = 0.0 if structure else 1.0
    vector[DH:DH + 30] = table.ravel()
    vector[TCP:TCP + 8] = tcp
    vector[LOWER:LOWER + 6] = lower
    vector[UPPER:UPPER + 6] = upper
    vector[THIRD_DERIVATIVE] = _third_derivative_bound(a, d, alpha, theta)
    vector[WRIST_NEAR] = WRIST_NEAR_TOLERANCE if structure else CALIBRATED_WRIST_NEAR
    vector.flags.writeable = False
    return vector


def _third_derivative_bound(a: Any, d: Any, alpha: Any, theta: Any) -> float:
    """M₃: |F‴(x)(d, d, d)| ≤ M₃·|d|³ for every x and d (6,), F = (flange position, its rotation columns / √2).

    For joints i ≤ j ≤ k, ∂³F/∂θi∂θj∂θk = z_i × (z_j × (z_k × (v − o_k))), v the position (or a rotation column,
    with o_k = 0): joint k turns what follows it about axis k, and each earlier joint turns that and the later axes.
    Its position part is at most the distance of the flange from axis k, at most R = Σ |P_k − P_k−1| + |flange −
    P_6|, P_1 the base origin and P_k the foot of P_k−1 on axis k: P_k lies on axis k and is fixed in link k−1's
    frame, hence in link k's, so every term is a constant of the arm (evaluated at q = 0; ~a2 + a3 + d4 + d5 + d6,
    whatever the table's cancelling d offsets). Its three columns / √2 are ‖[z_i]×[z_j]×[z_k]×·R‖_F / √2 ≤ 1. With
    (Σ|dᵢ|)³ ≤ 6^1.5·|d|³, M₃ = 6^1.5·√(R² + 1).
    """
    frames = SerialChain.from_dh(a, d, alpha, theta).frames(np.zeros(6))   # DH frames 0..6
    axes = dqarray.transform_points(frames[:6], np.array([0.0, 0.0, 1.0])) - dqarray.translation(frames[:6])
    origins = dqarray.translation(frames)
    foot, reach = np.zeros(3), 0.0
    for axis, origin in zip(axes, origins[:6], strict=False):
        step = axis * np.dot(foot - origin, axis) + origin - foot   # to the foot of ``foot`` on this axis
        foot, reach = foot + step, reach + float(np.linalg.norm(step))
    reach += float(np.linalg.norm(origins[6] - foot))
    return math.sqrt(216.0 * (reach * reach + 1.0))   # 6^1.5·√(R² + 1)
