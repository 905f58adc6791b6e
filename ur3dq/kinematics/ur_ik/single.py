"""Every solution of one pose (`ik_all`) and why a pose has none."""
from __future__ import annotations

import math

import numpy as np

from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics.ur_ik.calibrated import _refine_calibrated
from ur3dq.kinematics.ur_ik.equations import (
    _ScalarOps,
    _branches,
    _planar_arm,
    _reduced_rotation,
    _theta1_pair,
    _wrap_float,
    _wrist_centre,
    _wrist_pair,
)
from ur3dq.kinematics.ur_ik.fk_filter import _is_new, _meets, _reference, _targets
from ur3dq.kinematics.ur_ik.geometry import DOMAIN_TOLERANCE, _Geometry, _geometry


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


def _solution_candidates(g: _Geometry, target, theta6_ref: float, reference=None) -> list:
    """Existing analytic branches of ``target`` (flange pair), refined if calibrated; unwrapped, not yet filtered.

    On a calibrated arm ``reference`` (6 floats, optional) seeds one more Newton solve: near a singularity two
    nominal branches can converge to the same calibrated solution and miss the one beside the reference, which a
    solve started at the reference finds (so ``ik(fk(q), q)`` gives q back).
    """
    candidates = [branch for branch in _branches(_ScalarOps, g, target, theta6_ref)
                  if branch[1] == branch[1] and branch[0] == branch[0]]   # NaN: the branch does not exist
    if g.calibrated:
        seeds = candidates + ([tuple(reference)] if reference is not None else [])
        return _refine_calibrated(g, seeds, target) if seeds else []
    return candidates


def _verified(model, candidates: list, tcp_coefficients) -> list:
    """Per candidate (6 floats, NaN where the branch does not exist): kept, i.e. it exists, repeats no earlier kept
    candidate (DUPLICATE_TOLERANCE) and meets the FK filter. The one merge rule of ik_all and ik_all_batch."""
    kept, mask = [], []
    for candidate in candidates:
        ok = (candidate[0] == candidate[0] and candidate[1] == candidate[1] and _is_new(candidate, kept)
              and _meets(model, candidate, tcp_coefficients))
        if ok:
            kept.append(candidate)
        mask.append(ok)
    return mask


def _branch_table(model, pose, theta6_ref: float) -> tuple:
    """(branches (8, 6) in (−π, π], NaN where absent; kept (8,) bools) of one TCP pose on a nominal model, computed
    exactly as ik_all computes them (same float operations, same merge rule), in branch order.

    ik_all_batch takes its poses near a wrist or elbow singularity from here: there the elbow pair's separation is
    rounding noise amplified up to ~1e-3 rad (θ6 is ill-conditioned at θ5 ≈ 0 and moves the wrist centre), so two
    implementations that round differently merge different pairs whatever the tolerance; one implementation cannot.
    """
    g = _geometry(model)
    tcp_coefficients, target = _targets(g, pose)
    candidates = list(_branches(_ScalarOps, g, target, theta6_ref))
    kept = _verified(model, candidates, tcp_coefficients)
    table = np.array([[_wrap_float(v) for v in c] if ok else [math.nan] * 6 for c, ok in zip(candidates, kept)])
    return table, np.array(kept)


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
    solutions = [c for c, kept in zip(candidates, _verified(model, candidates, tcp_coefficients)) if kept]
    if not solutions:
        raise UnreachablePoseError(f"pose unreachable for {model.name}: "
                                   f"{_unreachable_reason(g, target, bool(candidates))}")
    return [np.array([_wrap_float(v) for v in solution]) for solution in solutions]
