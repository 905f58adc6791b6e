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

#: The columns of ``nearest``'s nodes, one per wrist branch (θ1 sign i1, θ5 sign i5: node 2·i1 + i5, slots
#: 2·node and 2·node + 1): a lower bound of its branches' costs, θ1, and once solved its wrist (cos θ1, sin θ1, θ5,
#: θ6, θ234, singularity code), and how far it got.
BOUND, THETA1, COS1, SIN1, THETA5, THETA6, THETA234, SINGULAR, STATE, NODE_SIZE = range(10)
UNSOLVED, WRIST_SOLVED, RANKED = 0.0, 1.0, 2.0
#: Secant steps at most when a singular wrist's split is moved to put θ4 at its limit, and how near (rad).
SPLIT_STEPS = 8
SPLIT_TOLERANCE = 1e-12


@kernel
def limit_excess(arm: np.ndarray, angle: float, reference: float, joint: int) -> float:
    """How far (rad, signed towards the inside) the variant of ``angle`` nearest ``reference`` lies past joint
    ``joint``'s limits beyond LIMIT_ROUNDING; 0 inside."""
    centre = solve.nearest_turn(angle, reference)
    lower, upper = float(arm[LOWER + joint]), float(arm[UPPER + joint])
    if centre < lower - LIMIT_ROUNDING:
        return lower - centre
    if centre > upper + LIMIT_ROUNDING:
        return upper - centre
    return 0.0


@kernel
def exactly_singular(theta5: float) -> bool:
    """Whether a branch's θ5 is that of a singular wrist (exactly 0 or ±π: equations.wrist sets it so)."""
    return theta5 == 0.0 or abs(theta5) == math.pi


@kernel
def split_within_limits(arm: np.ndarray, goal: np.ndarray, row: np.ndarray, slot: int, reference: np.ndarray) -> None:
    """At a singular wrist (``exactly_singular``), move ``row``'s split along the family (θ234 + s, θ6 ∓ s) until
    θ4's variant nearest the reference is at its limit, if θ6 = q_ref[5] put it past one (secant on s; the row is
    kept as it is where the moved split does not reach)."""
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
        centre = solve.nearest_turn(moved[3], reference[3])
        limit = arm[LOWER + 3] if excess > 0.0 else arm[UPPER + 3]
        remaining = limit - centre
        if abs(remaining) <= SPLIT_TOLERANCE:
            row[:] = moved
            return
        slope = (last_excess - remaining) / (shift - last_shift)
        last_shift, last_excess = shift, remaining
        shift += remaining / slope if slope != 0.0 else remaining


@kernel
def cost_bound(angle: float, reference: float, weight: float) -> float:
    """A lower bound of one joint's term wᵢ·(vᵢ − refᵢ)² in ``variants``' cost, whatever variant vᵢ of ``angle`` it
    takes (a clamp onto a limit moves it by at most LIMIT_ROUNDING); inf for NaN."""
    distance = abs(equations.remainder(angle - reference, TWO_PI)) - 2.0 * LIMIT_ROUNDING
    if distance != distance:
        return math.inf
    return weight * distance * distance if distance > 0.0 else 0.0


@kernel
def rank(arm: np.ndarray, goal: np.ndarray, rows: np.ndarray, slot: int, reference: np.ndarray,
         weights: np.ndarray, costs: np.ndarray, out: np.ndarray) -> None:
    """costs[slot] of rows[slot]: its in-limit variants' cost within LIMIT_ROUNDING of the limits and, where that
    clamps, strictly inside (inf where a branch is absent); a nominal singular wrist's split first kept in θ4's
    limits (split_within_limits)."""
    if rows[slot, 0] == rows[slot, 0] and rows[slot, 1] == rows[slot, 1]:
        if arm[CALIBRATED] == 0.0 and exactly_singular(rows[slot, 4]):
            split_within_limits(arm, goal, rows[slot], slot, reference)
        costs[slot, 0], clamped = solve.variants(arm, rows[slot], reference, weights, LIMIT_ROUNDING, out)
        if clamped:
            costs[slot, 1] = solve.variants(arm, rows[slot], reference, weights, 0.0, out)[0]


@kernel
def advance(arm: np.ndarray, goal: np.ndarray, node: int, reference: np.ndarray, weights: np.ndarray,
            rows: np.ndarray, costs: np.ndarray, nodes: np.ndarray, out: np.ndarray) -> None:
    """One step of a node: unsolved, the wrist of its θ1 into both nodes of that θ1 (θ5 signs), each bound raised
    by the costs of θ5 and θ6 (θ6 only on a regular wrist: a singular one's split, and θ6 with it, moves later);
    solved, its two elbow branches into slots 2·node and 2·node + 1, ranked."""
    n = nodes[node]
    if n[STATE] == UNSOLVED:
        cos1, sin1, theta5, theta6, theta234, singular = equations.wrist_of(arm, goal, n[THETA1],
                                                                            solve.wrap(reference[5]))
        for sibling in range(node - node % 2, node - node % 2 + 2):
            m = nodes[sibling]
            m[THETA5], m[THETA6], m[THETA234] = equations.flipped(theta5, theta6, theta234, singular, sibling % 2)
            m[COS1], m[SIN1], m[SINGULAR], m[STATE] = cos1, sin1, singular, WRIST_SOLVED
            m[BOUND] += cost_bound(m[THETA5], reference[4], weights[4])
            if singular == 0:
                m[BOUND] += cost_bound(m[THETA6], reference[5], weights[5])
        return
    equations.elbow_branches(arm, goal, n[THETA1], n[COS1], n[SIN1], n[THETA5], n[THETA6], n[THETA234],
                             int(n[SINGULAR]), rows[2 * node:2 * node + 2])
    for slot in range(2 * node, 2 * node + 2):
        rank(arm, goal, rows, slot, reference, weights, costs, out)
    n[STATE] = RANKED


@kernel
def least_open_node(nodes: np.ndarray) -> int:
    """The node not yet ranked with the least bound (−1 when every node is ranked)."""
    least = -1
    for node in range(4):
        if nodes[node, STATE] != RANKED and (least < 0 or nodes[node, BOUND] < nodes[least, BOUND]):
            least = node
    return least


@kernel
def nearest(arm: np.ndarray, goal: np.ndarray, reference: np.ndarray, weights: np.ndarray, out: np.ndarray,
            chain: np.ndarray, rows: np.ndarray, costs: np.ndarray, nodes: np.ndarray) -> int:
    """The solution of the goal nearest ``reference`` into ``out`` (6): the least-cost in-limit variants that pass
    the FK filter. Returns FOUND, OUTSIDE_LIMITS (solutions exist, none inside the limits) or UNREACHABLE.
    ``chain`` (7, 12), ``rows`` (9, 6), ``costs`` (9, 2) and ``nodes`` (4, NODE_SIZE) are work space.

    A nominal arm solves branches as the ranking needs them (branch and bound): the least-cost candidate found is
    checked only once every node whose bound could undercut it is ranked, so the answer is the full ranking's."""
    rows[:] = math.nan
    costs[:] = math.inf
    if arm[CALIBRATED] != 0.0:
        if reference_row(arm, goal, reference, weights, out, chain, rows[8]):
            return FOUND
        solve.candidates(arm, goal, solve.wrap(reference[5]), rows[:8], chain)
        for slot in range(9):
            rank(arm, goal, rows, slot, reference, weights, costs, out)
        nodes[:, STATE] = RANKED
    else:
        pair = equations.theta1_pair(arm, goal)
        for node in range(4):
            nodes[node, THETA1], nodes[node, STATE] = pair[node // 2], UNSOLVED
            nodes[node, BOUND] = cost_bound(pair[node // 2], reference[0], weights[0])
    while True:   # at most 2 wrists, 4 nodes and 18 candidates: each pass solves, ranks or rules out one
        node, best = least_open_node(nodes), int(np.argmin(costs))
        slot, inside = best // 2, best % 2
        if node >= 0 and nodes[node, BOUND] <= costs[slot, inside]:
            advance(arm, goal, node, reference, weights, rows, costs, nodes, out)
            continue
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
def reference_row(arm: np.ndarray, goal: np.ndarray, reference: np.ndarray, weights: np.ndarray, out: np.ndarray,
                  chain: np.ndarray, row: np.ndarray) -> bool:
    """On a calibrated arm, Newton from the reference into ``row``: True (its variants in ``out``) when that solution
    is provably the nearest, else ``row`` is kept as a candidate (NaN where Newton failed).

    A nearer solution's variants cost less than ``out``'s c, so lie within r = √(c / min w) of the reference; both
    solutions' exact ±2π copies (each joint within LIMIT_ROUNDING of its variant) then lie within |out − reference|
    + r + 2·√6·LIMIT_ROUNDING (< 5·LIMIT_ROUNDING) of each other, the span newton.isolated must rule out."""
    row[:] = reference
    if not newton.refine(arm, row, goal, chain) <= CALIBRATED_TOLERANCE:
        row[:] = math.nan
        return False
    cost = solve.variants(arm, row, reference, weights, LIMIT_ROUNDING, out)[0]
    span = math.sqrt(((out - reference) ** 2).sum()) + math.sqrt(cost / weights.min()) + 5.0 * LIMIT_ROUNDING
    return cost < math.inf and (cost == 0.0 or newton.isolated(arm, row, span, chain)) and solve.meets(arm, out, goal,
                                                                                                    chain)


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
    nodes = np.empty((4, NODE_SIZE))
    for index in range(len(poses)):
        frames.goal_of(arm, poses[index], goal)
        status[index] = nearest(arm, goal, references[index], weights, out[index], chain, rows, costs, nodes)
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
