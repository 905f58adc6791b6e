"""The solution nearest a reference (``ik``), and the compiled loops over poses that every public call runs.

``nearest`` ranks the solutions' in-limit ±2π variants by Σ wᵢ·(vᵢ − refᵢ)² and returns the first that passes the
FK filter. At a singular wrist on a nominal arm the split θ234 / θ6 is a free parameter: where θ6 = q_ref[5] puts
θ4 past a limit, the split moves along the family until θ4 is at the limit, before another branch is considered.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.arm import CALIBRATED, CALIBRATED_TOLERANCE, LENGTHS, LIMIT_ROUNDING, LOWER, UPPER, WRIST_NEAR
from ur3dq.kinematics.jit import kernel
from ur3dq.kinematics.ur_ik import equations, frames, newton, solve
from ur3dq.kinematics.ur_ik.equations import TWO_PI
from ur3dq.kinematics.ur_ik.solve import FOUND, OUTSIDE_LIMITS, UNREACHABLE

#: Secant steps at most when a singular wrist's split is moved to put θ4 at its limit, and how near (rad).
SPLIT_STEPS = 8
SPLIT_TOLERANCE = 1e-12


@kernel
def limit_excess(arm: np.ndarray, angle: float, reference: float, joint: int) -> float:
    """How far (rad, signed towards the inside) the variant of ``angle`` nearest ``reference`` lies past joint
    ``joint``'s limits beyond LIMIT_ROUNDING; 0 inside."""
    centre = reference + equations.remainder(angle - reference, TWO_PI)
    lower, upper = float(arm[LOWER + joint]), float(arm[UPPER + joint])
    if centre < lower - LIMIT_ROUNDING:
        return lower - centre
    if centre > upper + LIMIT_ROUNDING:
        return upper - centre
    return 0.0


@kernel
def split_within_limits(arm: np.ndarray, goal: np.ndarray, row: np.ndarray, slot: int, reference: np.ndarray) -> None:
    """At a singular wrist (θ5 exactly 0 or ±π), move ``row``'s split along the family (θ234 + s, θ6 ∓ s) until θ4's
    variant nearest the reference is at its limit, if θ6 = q_ref[5] put it past one (secant on s; the row is kept
    as it is where the moved split does not reach)."""
    if not (row[4] == 0.0 or abs(row[4]) == math.pi):
        return
    excess = limit_excess(arm, row[3], reference[3], 3)
    if excess == 0.0:
        return
    cos1, sin1 = math.cos(row[0]), math.sin(row[0])
    theta234, sense = row[1] + row[2] + row[3], -1.0 if row[4] == 0.0 else 1.0
    moved, shift, last_shift, last_excess = row.copy(), excess, 0.0, excess
    for _ in range(SPLIT_STEPS):
        x4, z4 = equations.planar_arm(arm, cos1, sin1, row[4], theta234 + shift, goal)
        cos3 = equations.elbow_cosine(arm, x4, z4)
        if cos3 != cos3:
            return
        moved[1], moved[2] = equations.shoulder_elbow(arm, x4, z4, cos3, 1.0 - 2.0 * (slot % 2))
        moved[3], moved[5] = theta234 + shift - moved[1] - moved[2], row[5] + sense * shift
        centre = reference[3] + equations.remainder(moved[3] - reference[3], TWO_PI)
        limit = arm[LOWER + 3] if excess > 0.0 else arm[UPPER + 3]
        remaining = limit - centre
        if abs(remaining) <= SPLIT_TOLERANCE:
            row[:] = moved
            return
        slope = (last_excess - remaining) / (shift - last_shift)
        last_shift, last_excess = shift, remaining
        shift += remaining / slope if slope != 0.0 else remaining


@kernel
def nearest(arm: np.ndarray, goal: np.ndarray, reference: np.ndarray, weights: np.ndarray, out: np.ndarray,
            chain: np.ndarray, rows: np.ndarray, costs: np.ndarray) -> int:
    """The solution of the goal nearest ``reference`` into ``out`` (6): the least-cost in-limit variants that pass
    the FK filter. Returns FOUND, OUTSIDE_LIMITS (solutions exist, none inside the limits) or UNREACHABLE.
    ``chain`` (7, 12), ``rows`` (9, 6) and ``costs`` (9, 2) are work space."""
    rows[:] = math.nan
    least_weight = weights.min()
    if arm[CALIBRATED] != 0.0:   # Newton from the reference: usually the answer, provably
        rows[8] = reference
        if newton.refine(arm, rows[8], goal, chain) <= CALIBRATED_TOLERANCE:
            cost = solve.variants(arm, rows[8], reference, weights, LIMIT_ROUNDING, out)[0]
            if cost < math.inf and (cost == 0.0 or newton.isolated(arm, rows[8], newton.proof_span(
                    cost, least_weight), chain)) and solve.meets(arm, out, goal, chain):
                return FOUND
        else:
            rows[8] = math.nan
    solve.candidates(arm, goal, solve.wrap(reference[5]), rows[:8], chain)
    # Per candidate its variants within LIMIT_ROUNDING of the limits, and (where that clamps) strictly inside.
    costs[:] = math.inf
    for slot in range(9):
        if rows[slot, 0] == rows[slot, 0] and rows[slot, 1] == rows[slot, 1]:
            if arm[CALIBRATED] == 0.0:
                split_within_limits(arm, goal, rows[slot], slot, reference)
            costs[slot, 0], clamped = solve.variants(arm, rows[slot], reference, weights, LIMIT_ROUNDING, out)
            if clamped:
                costs[slot, 1] = solve.variants(arm, rows[slot], reference, weights, 0.0, out)[0]
    for _ in range(18):   # the nearest first; the FK filter on each winner
        best = int(np.argmin(costs))
        slot, inside = best // 2, best % 2
        if not costs[slot, inside] < math.inf:
            break
        solve.variants(arm, rows[slot], reference, weights, 0.0 if inside else LIMIT_ROUNDING, out)
        if solve.meets(arm, out, goal, chain):
            return FOUND
        costs[slot, inside] = math.inf
    for slot in range(9):
        if rows[slot, 0] == rows[slot, 0] and rows[slot, 1] == rows[slot, 1] and solve.meets(arm, rows[slot], goal,
                                                                                              chain):
            return OUTSIDE_LIMITS
    return UNREACHABLE


@kernel
def all_rows(arm: np.ndarray, poses: np.ndarray, theta6_refs: np.ndarray, out: np.ndarray) -> None:
    """Per pose (N, 8) every solution in its branch slot of out (N, 8, 6), NaN elsewhere (solve.solutions); at a
    singular wrist θ6 = theta6_refs (N,)."""
    goal, chain = np.empty(frames.GOAL_SIZE), np.empty((7, 12))
    for index in range(len(poses)):
        frames.goal_of(arm, poses[index], goal)
        solve.solutions(arm, goal, theta6_refs[index], out[index], chain)


@kernel
def nearest_rows(arm: np.ndarray, poses: np.ndarray, references: np.ndarray, weights: np.ndarray,
                 out: np.ndarray, status: np.ndarray) -> None:
    """Per pose (N, 8) the solution nearest its reference (N, 6) into out (N, 6) and nearest's status into
    status (N,); NaN rows where there is none."""
    goal, chain, rows, costs = np.empty(frames.GOAL_SIZE), np.empty((7, 12)), np.empty((9, 6)), np.empty((9, 2))
    for index in range(len(poses)):
        frames.goal_of(arm, poses[index], goal)
        status[index] = nearest(arm, goal, references[index], weights, out[index], chain, rows, costs)
        if status[index] != FOUND:
            out[index] = math.nan


@kernel
def reach_figures(arm: np.ndarray, pose: np.ndarray, out: np.ndarray) -> None:
    """What an unreachable pose's reason needs, into out (6): the wrist centre's distance from the base axis, the
    spans the elbow would need (4: per θ1 and θ5 sign, NaN where θ1 does not exist), and 1.0 when every wrist is
    singular."""
    goal = np.empty(frames.GOAL_SIZE)
    frames.goal_of(arm, pose, goal)
    d6 = arm[LENGTHS + 5]
    x5 = goal[4] - d6 * 2.0 * (goal[1] * goal[3] + goal[0] * goal[2])
    y5 = goal[5] - d6 * 2.0 * (goal[2] * goal[3] - goal[0] * goal[1])
    out[0], out[5] = math.hypot(x5, y5), 1.0
    pair = equations.theta1_pair(arm, goal)
    for i1 in range(2):
        cos1, sin1, w, x, y, z = equations.reduced_rotation(pair[i1], goal)
        theta5, _, theta234, singular = equations.wrist(w, x, y, z, 0.0, arm[WRIST_NEAR])
        out[5] = out[5] if singular >= 3 else 0.0
        for i5 in range(2):
            flip = math.pi * i5 if singular < 3 else 0.0   # a singular wrist's two signs are one family
            x4, z4 = equations.planar_arm(arm, cos1, sin1, theta5 * (1 - 2 * i5), theta234 + flip, goal)
            out[1 + 2 * i1 + i5] = math.hypot(x4, z4)
