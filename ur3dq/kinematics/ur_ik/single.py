"""Every solution of one pose (`ik_all`) and why a pose has none."""
from __future__ import annotations

import math
from itertools import compress

import numpy as np

from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics.ur_ik.calibrated import _fk_implied, _refine_batch
from ur3dq.kinematics.ur_ik.equations import (
    _elbow_for_wrist,
    _planar_arm,
    _reduced_rotation,
    _ScalarOps,
    _shoulder_elbow_pair,
    _theta1_floats,
    _theta1_pair,
    _wrap_float,
    _wrist_centre,
    _wrist_pair,
)
from ur3dq.kinematics.ur_ik.fk_filter import (
    _fk_check,
    _fk_target,
    _is_new,
    _nominal_check,
    _nominal_meets,
    _reference,
    _targets,
)
from ur3dq.kinematics.ur_ik.geometry import (
    _HALF_SQRT2,
    _TWO_PI,
    CALIBRATED_TOLERANCE,
    DOMAIN_TOLERANCE,
    DUPLICATE_TOLERANCE,
    WRIST_NEAR_TOLERANCE,
    _Geometry,
    _geometry,
)
from ur3dq.kinematics.ur_ik.wrist_turns import PATIENT_SINE, beside_singular_wrist, turned


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


def _solution_candidates(g: _Geometry, target, theta6_ref: float, reference_row=None, reference=None) -> list:
    """Existing analytic branches of ``target`` (flange pair), refined if calibrated; unwrapped, not yet filtered.

    On a calibrated arm ``reference_row`` (6 floats, optional) is one more candidate, last: the converged Newton
    solve from ik's reference (nearest._reference_solution runs it first, alone: rows are refined independently).
    Near a singularity two nominal branches can converge to the same calibrated solution and miss the one beside
    the reference, which a solve started at the reference finds (so ``ik(fk(q), q)`` gives q back). ``reference``
    (6 floats, optional, instead of ``reference_row``): that solve is not done yet; it runs here, in the branches'
    batch (nearest._proof_expected), its converged row last alike.
    """
    if not g.calibrated:
        return [branch for branch in _nominal_branches(g, target, theta6_ref) if _exists(branch)]
    slots, reference_solve = _calibrated_slots(g, target, theta6_ref, reference)
    extra = [row for row in (reference_solve, reference_row) if row is not None]
    return [row for row in slots if _exists(row)] + extra


def _exists(branch) -> bool:
    """Whether a branch of _nominal_branches, or a slot of _calibrated_slots, exists (its first two joints are not
    NaN)."""
    return branch[1] == branch[1] and branch[0] == branch[0]


def _calibrated_slots(g: _Geometry, target, theta6_ref: float, reference=None) -> tuple:
    """(8 rows (6 floats each) in branch order, NaN where the branch is absent or Newton did not converge; the
    converged row from ``reference`` (6 floats, optional) or None) of a calibrated model's flange pair ``target``.

    All starting rows are refined in one _refine_batch call, the reference's last. A wandering seed gives up early
    unless a seed lies beside a singular wrist (PATIENT_SINE); the reference's row never does. Nearer the wrist
    singularity (TURN_SINE) a pair's seeds may miss its solutions: Newton again from their turns where they did
    (wrist_turns.turned). ik_all_batch and ik_batch take such poses from here, pose by pose (batch.py): the rows
    there depend on the rounding of every step, and one implementation gives one answer.
    """
    branches = _nominal_branches(g, target, theta6_ref)
    exists = [_exists(branch) for branch in branches]
    seeds = list(compress(branches, exists))
    starts = seeds + ([tuple(reference)] if reference is not None else [])
    if not starts:
        return [_ABSENT] * 8, None
    patient = [beside_singular_wrist(branches, PATIENT_SINE)] * len(seeds) + [True] * (reference is not None)
    refined, residual = _refine_batch(g, np.array(starts, dtype=float), np.array(target)[None], patient=patient)
    converged = [tuple(row) if error <= CALIBRATED_TOLERANCE else _ABSENT
                 for row, error in zip(refined.tolist(), residual.tolist())]
    rows = iter(converged)
    slots = [next(rows) if present else _ABSENT for present in exists]
    if beside_singular_wrist(branches):
        slots = [tuple(row) for row in turned(g, np.array(branches), np.array(slots), target).tolist()]
    reference_solve = converged[-1] if reference is not None and converged[-1] is not _ABSENT else None
    return slots, reference_solve


#: A slot of _calibrated_slots without a solution.
_ABSENT = (math.nan,) * 6


def _nominal_branches(g: _Geometry, target, theta6_ref: float) -> list:
    """The 8 branches of equations._branches(_ScalarOps, g, target, theta6_ref): the same floats, in the same
    order, NaN where a branch does not exist (all eight NaN beyond the shoulder's reach); a calibrated model's
    Newton seeds too (its domain slack and edge go through the same clamps, ~6 µs against ~13).

    Written out in plain floats with the very expressions of _theta1_pair, _reduced_rotation, _wrist_pair,
    _planar_arm, _elbow_cosine and _shoulder_elbow_pair for a regular wrist (each Python call there costs as much
    as its arithmetic); a clamped shoulder or elbow and a (near-)singular wrist go through those general
    functions, so every special case behaves as in _branches. Cross-checked by tests/kinematics/test_ur_ik.py
    (nominal models) and test_calibrated_fast_paths.py (factory tables).
    """
    qw, qx, qy, qz, px, py, pz = target
    d1, a2, a3, d5, d6 = g.d1, g.a2, g.a3, g.d5, g.d6
    cos, sin, atan2, sqrt = math.cos, math.sin, math.atan2, math.sqrt
    theta1_pair = _theta1_floats(g, qw, qx, qy, qz, px, py)
    if theta1_pair is None:
        return [(math.nan,) * 6] * 8
    low, high = g.domain_edge - 1.0, 1.0 - g.domain_edge
    elbow_scale, elbow_offset = 2.0 * a2 * a3, a2 * a2
    branches = []
    for theta1 in theta1_pair:
        # _reduced_rotation: r' = Rx(−π/2)·Rz(−θ1)·r.
        ch, sh = cos(0.5 * theta1), -sin(0.5 * theta1)
        w1, x1, y1, z1 = ch * qw - sh * qz, ch * qx - sh * qy, ch * qy + sh * qx, ch * qz + sh * qw
        h = _HALF_SQRT2
        reduced = w, x, y, z = h * (w1 + x1), h * (x1 - w1), h * (y1 + z1), h * (z1 - y1)
        cos1, sin1 = ch * ch - sh * sh, -2.0 * ch * sh
        sin_half5, cos_half5 = sqrt(x * x + y * y), sqrt(w * w + z * z)
        if sin_half5 < WRIST_NEAR_TOLERANCE or cos_half5 < WRIST_NEAR_TOLERANCE:
            branches += _general_wrist_branches(g, theta1, cos1, sin1, reduced, theta6_ref, px, py, pz)
            continue
        half_sum, half_diff = atan2(z, w), atan2(x, -y)
        theta5 = 2.0 * atan2(sin_half5, cos_half5)
        upper = (theta5, half_sum - half_diff, half_sum + half_diff)
        for theta5, theta6, theta234 in (upper, (-theta5, upper[1] - math.pi, upper[2] + math.pi)):  # noqa: B020
            c234, s234, s5 = cos(theta234), sin(theta234), sin(theta5)   # _planar_arm
            x4 = cos1 * px + sin1 * py - s234 * d5 + c234 * s5 * d6
            z4 = pz - d1 + c234 * d5 + s234 * s5 * d6
            cos3 = (x4 * x4 + z4 * z4 - elbow_offset - a3 * a3) / elbow_scale   # _elbow_cosine
            if not low <= cos3 <= high:
                cos3 = _ScalarOps.clamp_or_nan(cos3, low, high, g.domain_slack)
            sin3 = sqrt(1.0 - cos3 * cos3)   # _shoulder_elbow_pair
            theta3 = atan2(sin3, cos3)
            along, across = a2 + a3 * cos3, a3 * sin3
            near_x, near_z, far_x, far_z = x4 * along, z4 * along, x4 * across, z4 * across
            theta2 = atan2(near_z - far_x, near_x + far_z)
            branches.append((theta1, theta2, theta3, theta234 - theta2 - theta3, theta5, theta6))   # eq. 4.44
            theta2 = atan2(near_z + far_x, near_x - far_z)
            branches.append((theta1, theta2, -theta3, theta234 - theta2 + theta3, theta5, theta6))
    return branches


def _general_wrist_branches(g: _Geometry, theta1, cos1, sin1, reduced, theta6_ref, px, py, pz) -> list:
    """The 4 branches of one θ1 at a (near-)singular wrist, by the general functions (the loop body of _branches)."""
    branches = []
    upper, lower, flags = _wrist_pair(_ScalarOps, reduced, theta6_ref)
    for wrist in (upper, lower):
        theta6, theta234, x4, z4, cos3 = _elbow_for_wrist(_ScalarOps, g, cos1, sin1, wrist, flags, px, py, pz)
        for theta2, theta3 in _shoulder_elbow_pair(_ScalarOps, g, x4, z4, cos3):
            branches.append((theta1, theta2, theta3, theta234 - theta2 - theta3, wrist[0], theta6))
    return branches


def _verified(candidates: list, meets) -> list:
    """Per candidate (6 floats, NaN where the branch does not exist): kept, i.e. it exists, repeats no earlier kept
    candidate (DUPLICATE_TOLERANCE) and meets the FK filter ``meets`` (fk_filter._fk_check of the pose). The one
    merge rule of ik_all and ik_all_batch (_nominal_kept skips the comparisons where no two candidates can repeat)."""
    kept, mask = [], []
    for candidate in candidates:
        ok = (candidate[0] == candidate[0] and candidate[1] == candidate[1]
              and _is_new(candidate, kept) and meets(candidate))
        if ok:
            kept.append(candidate)
        mask.append(ok)
    return mask


def _always(_candidate) -> bool:
    """The FK filter's verdict where it is known to pass (calibrated._fk_implied)."""
    return True


def _nominal_kept(g: _Geometry, candidates: list, tcp_coefficients) -> list:
    """_verified for the 8 branches of _nominal_branches (branch order): when no two can repeat (_may_repeat),
    fk_filter._nominal_meets judges all 8 at once with what they share; otherwise the pairwise merge rule with
    _nominal_check per candidate (the same verdicts)."""
    target = _fk_target(tcp_coefficients)
    if _may_repeat(candidates):
        return _verified(candidates, lambda candidate: _nominal_check(g, candidate, target))
    return _nominal_meets(g, candidates, target)


def _may_repeat(branches: list) -> bool:
    """Whether two of the 8 branches of _nominal_branches (in its order, NaN where absent) can agree within
    DUPLICATE_TOLERANCE in every joint (mod 2π), as _is_new compares them.

    Two branches differ in the sign choice of θ1, θ5 or θ3, and each sign pair is exactly ±: θ1 = base ± offset,
    the second θ5 and θ3 are the negated first. So unless the two θ1 are within twice the tolerance (mod 2π), or
    some |θ5| or |θ3| lies within it of 0 or π, every two branches differ by at least twice it in one joint (the
    batch kernel's ``merged`` rule). The odd branches negate their even neighbour's θ3: the even ones hold every
    |θ3| and |θ5|.
    """
    tolerance, far = DUPLICATE_TOLERANCE, math.pi - DUPLICATE_TOLERANCE
    if not abs(math.remainder(branches[0][0] - branches[4][0], _TWO_PI)) >= 2.0 * tolerance:
        return True
    for _, _, theta3, _, theta5, _ in branches[0::2]:
        theta3, theta5 = abs(theta3), abs(theta5)
        if theta3 < tolerance or theta3 > far or theta5 < tolerance or theta5 > far:   # False for NaN
            return True
    return False


def _canonical(solutions: list) -> np.ndarray:
    """(k, 6) the joints of k solutions (6 floats each) in (−π, π] (_wrap_float's arithmetic, for the joints
    outside only), as one array: one numpy call instead of one per solution."""
    low, pi2, two_pi, remainder = -math.pi, math.pi * math.pi, _TWO_PI, math.remainder
    # _wrap_float written out (a call per wrapped joint costs more than its arithmetic), for the joints outside
    # |v| < π only: v·v < π² implies it (rounding is monotonic); ±π and NaN take _wrap_float's way.
    flat = [v if v * v < pi2 else (w + two_pi if (w := remainder(v, two_pi)) <= low else w)
            for solution in solutions for v in solution]
    return np.fromiter(flat, float, len(flat)).reshape(len(solutions), 6)


def _branch_table(model, pose, theta6_ref: float) -> tuple:
    """(branches (8, 6) in (−π, π], NaN where absent; kept (8,) bools) of one TCP pose, computed exactly as ik_all
    computes them (same float operations, same merge rule), in branch order (a calibrated model's Newton rows in
    their seeds' slots, _calibrated_slots).

    ik_all_batch takes its poses near a singularity from here: on a nominal model near a wrist or elbow singularity
    the elbow pair's separation is rounding noise amplified up to ~1e-3 rad (θ6 is ill-conditioned at θ5 ≈ 0 and
    moves the wrist centre), on a calibrated one beside a singular wrist Newton's seeds wander for several steps and
    where they land depends on every rounding; two implementations that round differently merge different pairs or
    reach different solutions whatever the tolerance, one implementation cannot.
    """
    g = _geometry(model)
    tcp_coefficients, target = _targets(g, pose)
    candidates, kept = _kept_branches(model, g, target, tcp_coefficients, theta6_ref)
    table = _canonical([c if ok else (math.nan,) * 6 for c, ok in zip(candidates, kept)])
    return table, np.array(kept)


def _kept_branches(model, g: _Geometry, target, tcp_coefficients, theta6_ref: float) -> tuple:
    """(8 candidates in branch order, NaN where absent; kept (8 bools), _verified's rule) of flange pair ``target``:
    the nominal branches, or on a calibrated model their Newton rows (_calibrated_slots)."""
    if g.calibrated:
        candidates = _calibrated_slots(g, target, theta6_ref)[0]
        # Newton's acceptance usually implies the FK filter's (calibrated._fk_implied): ~10 µs a candidate saved.
        return candidates, _verified(candidates, _always if _fk_implied(g) else _fk_check(model, g, tcp_coefficients))
    # All 8 in branch order (NaN where absent): _nominal_kept reads the pairs from their places.
    candidates = _nominal_branches(g, target, theta6_ref)
    return candidates, _nominal_kept(g, candidates, tcp_coefficients)


def ik_all(model, pose, q_ref=None) -> list:
    """Every FK-verified joint solution (radians, each in (−π, π]) of the TCP ``pose`` (base frame), up to 8.

    ``q_ref`` (optional) only resolves the wrist singularity: there θ6 is set to q_ref[5] (0 without a reference)
    when the arm can reach with it, θ2 + θ3 + θ4 takes the rest of the θ234 ± θ6 the orientation fixes (see the
    module notes). Raises UnreachablePoseError (a ValueError) saying why when no solution exists.
    """
    g = _geometry(model)
    tcp_coefficients, target = _targets(g, pose)
    theta6_ref = 0.0 if q_ref is None else _wrap_float(_reference(q_ref)[5])
    candidates, kept = _kept_branches(model, g, target, tcp_coefficients, theta6_ref)
    solutions = list(compress(candidates, kept))
    if not solutions:
        existed = any(_exists(c) for c in candidates)
        raise UnreachablePoseError(f"pose unreachable for {model.name}: {_unreachable_reason(g, target, existed)}")
    return list(_canonical(solutions))   # one (6,) row per solution
