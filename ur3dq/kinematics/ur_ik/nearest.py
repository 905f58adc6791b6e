"""The solution nearest a reference (`ik`): branch and bound over the branches, ±2π variants per joint."""
from __future__ import annotations

import math

import numpy as np

from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics.ur_ik.calibrated import (
    VARIANT_SHIFT,
    _cached_terms,
    _fk_implied,
    _float_pair,
    _isolated,
    _largest_isolation_radius,
    _proof_span,
    _radius_of_sigma,
    _refine_batch,
    _target_matrices,
)
from ur3dq.kinematics.ur_ik.equations import _elbow_for_wrist, _ScalarOps, _theta1_floats, _wrap_float, _wrist_pair
from ur3dq.kinematics.ur_ik.fk_filter import _fk_check, _meets, _reference, _targets
from ur3dq.kinematics.ur_ik.geometry import (
    _HALF_SQRT2,
    _TWO_PI,
    _UNIT_WEIGHTS,
    CALIBRATED_TOLERANCE,
    LIMIT_ROUNDING,
    WRIST_NEAR_TOLERANCE,
    _Geometry,
    _geometry,
)
from ur3dq.kinematics.ur_ik.newton_floats import DAMPING_MATRIX, float_frames, float_residual, float_step_and_normal
from ur3dq.kinematics.ur_ik.single import _solution_candidates, _unreachable_reason


def _closest_variant(angle: float, reference: float, lower: float, upper: float) -> float:
    """angle + 2πk inside [lower, upper] closest to ``reference`` (radians); inf when no variant fits the limits.

    Per joint on its own: the cost Σ wᵢ·Δqᵢ² has diagonal weights and the limits are per joint, so the nearest
    variant of a whole solution is the nearest variant of each joint — no product of variants to enumerate.
    """
    centre = reference + math.remainder(angle - reference, _TWO_PI)
    if lower <= centre <= upper:
        return centre   # the nearest variant of all: nothing inside the limits can be nearer
    if lower - LIMIT_ROUNDING <= centre <= upper + LIMIT_ROUNDING:
        return min(max(centre, lower), upper)   # a joint at its limit (2π) whose solved angle rounded past it
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
    d1, a2, a3, d5, d6 = g.d1, g.a2, g.a3, g.d5, g.d6
    lower, upper = g.lower, g.upper
    ref1, ref2, ref3, ref4, ref5, ref6 = reference
    weight1, weight2, weight3, weight4, weight5, weight6 = weights
    cos, sin, atan2, sqrt = math.cos, math.sin, math.atan2, math.sqrt
    theta1_pair = _theta1_floats(g, qw, qx, qy, qz, px, py)
    if theta1_pair is None:   # the wrist centre is too close to the base axis
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
            for theta3, sign in ((theta3, 1.0), (-theta3, -1.0)):   # noqa: B020  (both signs of theta3)
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


def _reference_solution(g: _Geometry, target, reference, weights) -> tuple:
    """(joints, row): the solution Newton reaches from ``reference`` (calibrated model, flange pair ``target``) as
    its in-limit ±2π variants nearest ``reference`` when it is provably the one ``ik``'s full ranking picks, else
    None; and that Newton row (6 floats; None unless it converged) for the ranking to reuse.

    The full ranking refines every nominal branch (single._solution_candidates), adds the row from ``reference``
    computed here and returns the nearest converged candidate. That row's result x, at cost c, is the nearest of
    all when every other converged solution nearer than c would lie within 2·√(c / min w) of x in joint space
    (both within √(c / min w) of the reference, up to LIMIT_ROUNDING per joint), which _isolated rules out: no
    other solution lies that close. Half the radius is required, for the rounding of σ. Typical of a reference at
    or beside the answer (``ik(fk(q), q)``, a path of small steps); anything else, a singularity included, takes
    the full ranking, except a reference that is itself a solution (c = 0: x's variants are the
    reference to the bit, as when Newton takes no step from an exact ``ik(fk(q), q)``): no candidate costs less
    than 0, and one that costs 0 has these very variants, so the ranking's answer is these joints whatever it
    ranks (beside a singularity, where _isolated cannot tell, that ranking costs milliseconds).
    """
    refined, residual = _refine_batch(g, np.array([reference]), np.array(target)[None])
    if not residual[0] <= CALIBRATED_TOLERANCE:
        return None, None
    row = tuple(refined[0].tolist())
    joints = _nearest_joints(g, row, reference)
    cost = sum(w * (v - r) ** 2 for w, v, r in zip(weights, joints, reference))
    if not cost < math.inf:
        return None, row
    if cost == 0.0:   # the reference itself: the answer whatever the ranking (see above)
        return joints, row
    return (joints if _isolated(g, refined, np.array([_proof_span(cost, min(weights))]))[0] else None), row


def _proof_expected(g: _Geometry, target, reference, weights) -> bool:
    """Whether _reference_solution's proof is expected to hold for ``reference`` (calibrated model, flange pair
    ``target``), judged from Newton's first step Δ from it: refined alone, a row costs ~40 µs a step, as much as a
    batched step of the nine rows the full ranking refines anyway, so a proof that fails doubles ik's time.

    The proof needs calibrated._proof_span, 4·(√(c / min w) + √6·LIMIT_ROUNDING), below the answer's isolation
    radius (_isolated). To first order c = Σ wᵢ·Δᵢ² and the answer's least singular value σ is the reference's, whose
    radius (calibrated._radius_of_sigma) stands in. A reference that is a solution already (error ≤ 1e-12: the
    row stops before a step, c = 0) needs no radius. The answer is the full ranking's either way (the proof only
    ever returns that answer): this is a choice of path, a wrong guess costs time only. Measured on 1,920
    references 0.0005–0.05 rad from their answers (4 models, factory tables): 502 expected, 501 of them proved,
    and none of the others would have been.
    """
    rotation, position = _target_matrices(np.array(target)[None])
    end, frames = float_frames(_cached_terms(g)[2], reference)
    error = float_residual(end, frames, _float_pair(rotation[0], position[0]))[:6]
    if math.sqrt(sum(e * e for e in error)) <= 0.01 * CALIBRATED_TOLERANCE:   # going_on's first test: no step
        return True
    step, normal = float_step_and_normal(frames, error, DAMPING_MATRIX)
    cost = sum(w * v * v for w, v in zip(weights, step))
    span = _proof_span(cost, min(weights))
    if span >= _largest_isolation_radius(g):   # beyond every radius: no eigenvalues needed
        return False
    sigma = math.sqrt(max(float(np.linalg.eigvalsh(normal)[0]), 0.0))
    return span < float(_radius_of_sigma(g, sigma))


def joint_variants(model, q) -> np.ndarray:
    """(M, 6) every q + 2πk (per joint) inside the model's limits; an unlimited joint is listed within ±2π.

    A variant within LIMIT_ROUNDING past a limit is listed at the limit, as ``ik`` takes it."""
    g = _geometry(model)
    per_joint = []
    for angle, low, high in zip(_reference(q, "q"), g.lower, g.upper):
        low = -_TWO_PI if math.isinf(low) else low
        high = _TWO_PI if math.isinf(high) else high
        first = angle + _TWO_PI * math.ceil((low - LIMIT_ROUNDING - angle) / _TWO_PI)
        values = np.arange(first, high + LIMIT_ROUNDING, _TWO_PI) if first <= high + LIMIT_ROUNDING else np.empty(0)
        per_joint.append(np.clip(values, low, high))
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
        if best is not None and _meets(model, best, tcp_coefficients):   # usually the only FK evaluation
            return np.array(best)
    meets = _fk_check(model, g, tcp_coefficients)
    row = start = None
    if g.calibrated and not _proof_expected(g, target, reference, weight):
        start = reference   # refined with the nominal branches, in one batch
    elif g.calibrated:   # usually one Newton row, from the reference
        best, row = _reference_solution(g, target, reference, weight)
        if best is not None and _passes(g, meets, best, row):
            return np.array(best)
    candidates = _solution_candidates(g, target, _wrap_float(reference[5]), row, start)
    return _ranked_solution(model, g, target, meets, candidates, reference, weight)


def _passes(g: _Geometry, meets, joints: tuple, candidate: tuple) -> bool:
    """The FK filter ``meets`` of ``joints``, the in-limit variants of ``candidate`` (6 floats each): on a calibrated
    model, where each joint is within VARIANT_SHIFT of a 2π shift of the candidate's (Newton's accepted row, as
    every calibrated candidate is) and calibrated._fk_implied, known to pass without an FK (~10 µs); else checked
    (a joint clamped onto a limit, a nominal model's branch)."""
    if g.calibrated and _fk_implied(g) and all(abs(math.remainder(v - c, _TWO_PI)) <= VARIANT_SHIFT
                                               for v, c in zip(joints, candidate)):
        return True
    return meets(joints)


def _ranked_solution(model, g: _Geometry, target, meets, candidates: list, reference, weight) -> np.ndarray:
    """``ik``'s answer by ranking every candidate (single._solution_candidates: on calibrated models Newton from
    every nominal branch and from ``reference``): the nearest one the FK filter ``meets`` accepts. The path of
    calibrated models without a _reference_solution, and of a nominal winner the FK filter rejected."""
    remaining = list(candidates)
    # Nearest first, FK filter only on the winner (usually one FK evaluation); a rejected winner is dropped.
    while remaining:
        best = _nearest_candidate(g, remaining, reference, weight)
        if best is None:
            break
        joints = _nearest_joints(g, best, reference)
        if _passes(g, meets, joints, best):
            return np.array(joints)
        remaining.remove(best)
    if any(meets(c) for c in candidates):
        raise UnreachablePoseError(f"pose unreachable for {model.name}: outside limits — every solution has a "
                                   "joint outside the joint limits")
    raise UnreachablePoseError(f"pose unreachable for {model.name}: "
                               f"{_unreachable_reason(g, target, bool(candidates))}")
