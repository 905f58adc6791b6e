"""The IK of one pose, compiled: every solution (``solutions``) and the one nearest a reference (``nearest``); and
the loops over poses that every public call runs (a single pose is a batch of one).

Calibrated arms: the closed form of the catalogue lengths gives up to 8 seeds (a branch beyond the domain slack is
absent), Newton on the full DH chain refines each (newton.refine); beside a singular wrist a seed's θ6 can be off by
up to π, so where a (θ1, elbow) pair's seeds do not reach two new solutions, Newton runs again from their turns along
the wrist's family (θ6 + δ, θ234 ∓ δ) and fills the pair's slots. ``nearest`` first refines q_ref itself and keeps
that solution when no other can be nearer (newton.isolated); otherwise it ranks every candidate.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics import fk
from ur3dq.kinematics.arm import CALIBRATED, CALIBRATED_TOLERANCE, DUPLICATE_TOLERANCE, LENGTHS, LOWER, UPPER
from ur3dq.kinematics.jit import kernel
from ur3dq.kinematics.ur_ik import equations, frames, newton
from ur3dq.kinematics.ur_ik.equations import TWO_PI

#: |sin θ5| of a seed below which its θ6 is unreliable enough to try the turns of its wrist's family (measured on
#: 2800 configurations of the 14 factory tables: poses missing their configuration 372 without turns, 107 from 0.05).
TURN_SINE = 0.3
#: Turns tried per seed, δ = k·2π/TURNS: a pair's solutions may lie anywhere along the family.
TURNS = 8
#: What ``nearest`` reports: a solution; solutions, none inside the limits; no solution.
FOUND, OUTSIDE_LIMITS, UNREACHABLE = 0, 1, 2


@kernel
def wrap(angle: float) -> float:
    """An angle in (−π, π] (IEEE remainder: exact; NaN stays NaN)."""
    wrapped = equations.remainder(angle, TWO_PI)
    return wrapped + TWO_PI if wrapped <= -math.pi else wrapped


@kernel
def nearest_turn(angle: float, reference: float) -> float:
    """angle + 2πk nearest ``reference`` (rad), limits aside (IEEE remainder: exact; NaN stays NaN)."""
    return reference + equations.remainder(angle - reference, TWO_PI)


@kernel
def closest_variant(angle: float, reference: float, lower: float, upper: float, rounding: float) -> tuple[float, bool]:
    """(angle + 2πk inside [lower, upper] nearest ``reference`` (rad), whether that is a limit the variant nearest
    of all was clamped onto): a variant within ``rounding`` past a limit is the limit (a joint at ±2π whose solved
    angle rounded past it); inf when none fits (or angle is NaN). Per joint on its own: the cost Σ wᵢ·Δqᵢ² is
    separable and the limits are per joint."""
    if angle != angle:
        return math.inf, False
    centre = nearest_turn(angle, reference)
    if lower <= centre <= upper:
        return centre, False
    if lower - rounding <= centre <= upper + rounding:
        return min(max(centre, lower), upper), True
    # Every in-limit variant lies on one side of the centre: the nearest is the end of the in-limit run there.
    if centre < lower:
        end = angle + TWO_PI * math.ceil((lower - angle) / TWO_PI)
        end = end + TWO_PI if end < lower else end   # rounding of the division
    else:
        end = angle + TWO_PI * math.floor((upper - angle) / TWO_PI)
        end = end - TWO_PI if end > upper else end
    return (end if lower <= end <= upper else math.inf), False


@kernel
def variants(arm: np.ndarray, row: np.ndarray, reference: np.ndarray, weights: np.ndarray, rounding: float,
             out: np.ndarray) -> tuple[float, bool]:
    """The in-limit ±2π variants of ``row`` nearest ``reference`` into ``out`` (within ``rounding`` past a limit: the
    limit); returns their cost Σ wᵢ·Δqᵢ² (inf when some joint has none), and whether some joint was clamped."""
    cost, clamped = 0.0, False
    for j in range(6):
        out[j], onto = closest_variant(row[j], reference[j], arm[LOWER + j], arm[UPPER + j], rounding)
        cost += weights[j] * (out[j] - reference[j]) ** 2
        clamped = clamped or onto
    return cost, clamped


@kernel
def is_new(row: np.ndarray, kept: np.ndarray, count: int) -> bool:
    """Whether ``row`` differs by DUPLICATE_TOLERANCE or more in some joint (mod 2π) from each of kept[:count] (rows
    of NaN aside)."""
    for other in range(count):
        same = kept[other, 0] == kept[other, 0]
        for j in range(6):
            if abs(equations.remainder(row[j] - kept[other, j], TWO_PI)) >= DUPLICATE_TOLERANCE:
                same = False
                break
        if same:
            return False
    return True


@kernel
def meets(arm: np.ndarray, q: np.ndarray, goal: np.ndarray, chain: np.ndarray) -> bool:
    """The FK filter (eq. 4.45) of joints q (6) against the goal: the closed form, or the DH chain when calibrated."""
    if arm[CALIBRATED] == 0.0:
        return frames.flange_meets(arm, fk.nominal_flange(arm, q[0], q[1], q[2], q[3], q[4], q[5]), goal)
    fk.chain_frames(arm, q, chain)
    return frames.chain_meets(arm, chain[6], goal)


@kernel
def turn_starts(arm: np.ndarray, goal: np.ndarray, seed: np.ndarray, elbow: int, starts: np.ndarray) -> int:
    """Starts (≤ TURNS − 1 rows into ``starts``) turned from ``seed`` along its wrist's family, its elbow sign kept
    (elbow 0: θ3 ≥ 0); returns how many (none for a regular wrist, an absent seed, or turns out of reach)."""
    theta1, theta5, theta6 = seed[0], seed[4], seed[5]
    if not abs(math.sin(theta5)) < TURN_SINE:
        return 0
    theta234 = seed[1] + seed[2] + seed[3]
    along = -1.0 if math.cos(theta5) > 0.0 else 1.0   # θ234 + θ6 fixed near θ5 = 0, θ234 − θ6 near π
    count = 0
    for k in range(1, TURNS):
        delta = k * TWO_PI / TURNS
        turned234 = theta234 + along * delta
        x4, z4 = equations.planar_arm(arm, math.cos(theta1), math.sin(theta1), theta5, turned234, goal)
        cos3 = equations.elbow_cosine(arm, x4, z4)
        if cos3 == cos3:
            theta2, theta3 = equations.shoulder_elbow(arm, x4, z4, cos3, 1.0 - 2.0 * elbow)
            starts[count, 0], starts[count, 1], starts[count, 2] = theta1, theta2, theta3
            starts[count, 3], starts[count, 4], starts[count, 5] = turned234 - theta2 - theta3, theta5, theta6 + delta
            count += 1
    return count


@kernel
def fill_pair(arm: np.ndarray, goal: np.ndarray, seeds: np.ndarray, rows: np.ndarray, pair: tuple[int, int],
              chain: np.ndarray) -> None:
    """Where the (θ1, elbow) pair's slots beside a singular wrist hold no two solutions new to every other row, fill
    its missing or repeated slots (in slot order) with the new solutions Newton reaches from its seeds' turns."""
    if not (abs(math.sin(seeds[pair[0], 4])) < TURN_SINE or abs(math.sin(seeds[pair[1], 4])) < TURN_SINE):
        return
    kept, count, open_slots = np.empty((8, 6)), 0, [-1, -1]
    for slot in range(8):
        if rows[slot, 0] == rows[slot, 0] and is_new(rows[slot], kept, count):
            kept[count] = rows[slot]
            count += 1
        elif slot in pair:
            open_slots[0 if slot == pair[0] else 1] = slot
    if open_slots[0] < 0 and open_slots[1] < 0:
        return
    count = 0   # kept: the rows of the other slots
    for slot in range(8):
        if rows[slot, 0] == rows[slot, 0] and slot != open_slots[0] and slot != open_slots[1]:
            kept[count] = rows[slot]
            count += 1
    starts = np.empty((2 * (TURNS - 1), 6))
    total = turn_starts(arm, goal, seeds[pair[0]], pair[0] % 2, starts)
    total += turn_starts(arm, goal, seeds[pair[1]], pair[1] % 2, starts[total:])
    reached = 0
    for index in range(total):
        if newton.refine(arm, starts[index], goal, chain) <= CALIBRATED_TOLERANCE:
            starts[reached] = starts[index]
            reached += 1
    for slot in open_slots:
        for index in range(reached):
            if slot >= 0 and is_new(starts[index], kept, count):
                rows[slot] = starts[index]
                kept[count] = starts[index]
                count += 1
                break


@kernel
def mirror_elbow(arm: np.ndarray, goal: np.ndarray, rows: np.ndarray, slot: int, chain: np.ndarray) -> None:
    """Where one of the elbow pair ``slot``, ``slot + 1`` converged and the other did not reach a new solution (both
    seeds clamped beyond the closed form's reach, near the stretched elbow), Newton from the converged row's mirror
    image: the planar arm's other elbow to the same wrist point (θ3 → −θ3, θ2 → θ2 + 2·atan2(a3·s3, a2 + a3·c3),
    θ2 + θ3 + θ4 kept), filling the other slot if that reaches a new solution."""
    first, second = rows[slot], rows[slot + 1]
    if first[0] == first[0] and not (second[0] == second[0] and is_new(second, rows[slot:slot + 1], 1)):
        source, target = slot, slot + 1
    elif second[0] == second[0] and not first[0] == first[0]:
        source, target = slot + 1, slot
    else:
        return
    a2, a3 = arm[LENGTHS + 1], arm[LENGTHS + 2]
    mirrored = rows[source].copy()
    theta2, theta3 = mirrored[1], mirrored[2]
    mirrored[1] = theta2 + 2.0 * math.atan2(a3 * math.sin(theta3), a2 + a3 * math.cos(theta3))
    mirrored[2] = -theta3
    mirrored[3] += theta2 + theta3 - mirrored[1] - mirrored[2]
    if newton.refine(arm, mirrored, goal, chain) <= CALIBRATED_TOLERANCE and is_new(mirrored, rows, 8):
        rows[target] = mirrored


@kernel
def candidates(arm: np.ndarray, goal: np.ndarray, theta6_ref: float, rows: np.ndarray, chain: np.ndarray) -> None:
    """The 8 branch slots of the goal into ``rows`` (8, 6), NaN where absent: the closed form's branches, on a
    calibrated arm refined by Newton (NaN where it did not converge) and completed beside a singular wrist."""
    equations.branches(arm, goal, theta6_ref, rows)
    if arm[CALIBRATED] == 0.0:
        return
    seeds = rows.copy()
    for slot in range(8):
        if rows[slot, 0] == rows[slot, 0] and rows[slot, 1] == rows[slot, 1]:
            if not newton.refine(arm, rows[slot], goal, chain) <= CALIBRATED_TOLERANCE:
                rows[slot] = math.nan
        else:
            rows[slot] = math.nan
    for elbow_pair in range(4):
        mirror_elbow(arm, goal, rows, 2 * elbow_pair, chain)
    for pair in ((0, 2), (1, 3), (4, 6), (5, 7)):
        fill_pair(arm, goal, seeds, rows, pair, chain)


@kernel
def solutions(arm: np.ndarray, goal: np.ndarray, theta6_ref: float, rows: np.ndarray, chain: np.ndarray) -> None:
    """Every FK-verified solution of the goal in its branch slot of ``rows`` (8, 6), each joint in (−π, π]; NaN
    where a branch is absent, repeats an earlier solution (DUPLICATE_TOLERANCE) or misses the pose."""
    candidates(arm, goal, theta6_ref, rows, chain)
    kept, count = np.empty((8, 6)), 0
    for slot in range(8):
        row = rows[slot]
        if row[0] == row[0] and row[1] == row[1] and is_new(row, kept, count) and meets(arm, row, goal, chain):
            kept[count] = row
            count += 1
            for j in range(6):
                row[j] = wrap(row[j])
        else:
            row[:] = math.nan
