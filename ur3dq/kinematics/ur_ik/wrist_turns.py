"""Calibrated arms beside a singular wrist: Newton again from the nominal seeds turned along the wrist's family.

Where θ5 is small (or near π) only θ234 + θ6 (θ234 − θ6) of a pose is well conditioned: the θ6 of a nominal seed is
off the calibrated solution's by about the calibration's angular offsets over |sin θ5|, up to any angle. Newton from
such a seed then diverges, or reaches the solution another seed reaches too, and ik_all missed a real solution (issue
11: a UR3 factory table at θ5 = −0.0015, found 1.3 rad from the nominal seeds; 13 % of 2800 configurations of the 14
factory tables, three quarters beside a wrist or elbow singularity, missed their own). A (θ1, elbow) pair has usually
two calibrated solutions beside a singular wrist, as it has two regular ones (θ5 of either sign): where the seeds of
such a pair did not give two new ones, Newton runs again from the pair's seeds turned by k·2π/TURNS along the family
(θ6 + δ, θ234 ∓ δ, the shoulder and elbow solved again for the new θ234) and fills the pair's slots with what it
reaches. A pair may have more (a calibrated arm, unlike the nominal one, up to 16 in all): beyond its two slots they
stay unlisted (measured, ~2.5 % of those configurations).
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.ur_ik.calibrated import _refine_batch
from ur3dq.kinematics.ur_ik.equations import _elbow_cosine, _planar_arm, _ScalarOps, _shoulder_elbow_pair
from ur3dq.kinematics.ur_ik.fk_filter import _is_new
from ur3dq.kinematics.ur_ik.geometry import CALIBRATED_TOLERANCE, _Geometry

#: |sin θ5| of a nominal seed below which its θ6 is unreliable enough to try the turns. Measured on 2800 random and
#: near-singular configurations of the 14 factory tables (issue 11), poses missing their configuration: 372
#: without turns, 127 from 0.02, 107 from 0.05, 103 from 0.2; but from 0.2, 4 of the benchmark's 50 random poses
#: (|sin θ5| 0.12…0.2, a pair with one solution) ran the turns and found nothing (ik_all +20 %).
TURN_SINE = 0.05
#: |sin θ5| of a nominal seed below which the seeds of its pose are refined patiently (calibrated._refine_batch's
#: ``patient``: no giving up after newton_floats.HOPELESS_STEP): there a seed can wander for several steps and still
#: reach a solution no other seed reaches. Measured on the same 2800 configurations (14 factory tables), solutions
#: lost to giving up: 18 with no patience, 7 from 0.05 (seeds at |sin θ5| = 0.06 of a calibrated 0.037), none from
#: 0.15.
PATIENT_SINE = 0.15
#: Turns of the family tried per seed (δ = k·2π/TURNS, k = 1 … TURNS − 1): π/4 apart, as the pair's solutions may
#: lie anywhere along it.
TURNS = 8

#: The slots (branch indices of single._nominal_branches, by (θ1, θ5, θ3) sign) of each (θ1, elbow) pair.
_PAIRS = ((0, 2), (1, 3), (4, 6), (5, 7))


def beside_singular_wrist(seeds, sine: float = TURN_SINE) -> bool:
    """Whether some of the 8 seeds (6 floats each, NaN where absent) has |sin θ5| < ``sine``: with TURN_SINE,
    turned can only change rows then (~1 µs, against ~20 for its pairwise comparisons); with PATIENT_SINE, the
    pose's seeds are refined patiently."""
    return any(abs(math.sin(seed[4])) < sine for seed in seeds)


def _incomplete(seeds: np.ndarray, rows: np.ndarray) -> list:
    """(pair, open slots) of each (θ1, elbow) pair (of _PAIRS) of the 8 seeds (8, 6) (NaN where absent) that lies
    beside a singular wrist while its Newton rows (8, 6) (NaN where they did not converge) are not two solutions new
    to every other row: its open slots are those whose row is missing or repeats an earlier one."""
    kept, repeated = [], []
    for slot, row in enumerate(rows.tolist()):
        if row[0] == row[0] and _is_new(row, kept):
            kept.append(row)
        else:
            repeated.append(slot)
    pairs = []
    for pair in _PAIRS:
        near = [abs(math.sin(seeds[slot, 4])) < TURN_SINE for slot in pair]   # False for an absent seed
        open_slots = [slot for slot in pair if slot in repeated]
        if any(near) and open_slots:
            pairs.append((pair, open_slots))
    return pairs


def turned(g: _Geometry, seeds: np.ndarray, rows: np.ndarray, target) -> np.ndarray:
    """The Newton rows (8, 6) of the 8 nominal seeds (8, 6) of flange pair ``target`` (7 floats), NaN where they did
    not converge, with each incomplete pair's missing or repeated slots filled (in slot order) by the new solutions
    Newton reaches from its seeds' turns (in seed and turn order), as far as there are any; ``rows`` itself when
    no pair is incomplete."""
    pairs = _incomplete(seeds, rows)
    if not pairs:
        return rows
    starts, owners = [], []
    for pair, _ in pairs:
        for slot in pair:   # both: one seed's turns miss solutions the other's reach (measured: 135 against 107)
            for start in _turns(g, seeds[slot].tolist(), slot % 2, target):
                starts.append(start)
                owners.append(pair)
    if not starts:
        return rows
    refined, residual = _refine_batch(g, np.array(starts), np.array(target)[None])
    rows = rows.copy()
    for pair, open_slots in pairs:
        kept = [row for slot, row in enumerate(rows.tolist()) if row[0] == row[0] and slot not in open_slots]
        reached = [q for q, r, owner in zip(refined.tolist(), residual.tolist(), owners)
                   if owner == pair and r <= CALIBRATED_TOLERANCE]
        for slot in open_slots:   # a slot no new solution fills keeps its row (as ik's ranking saw it before)
            for q in reached:
                if _is_new(q, kept):
                    rows[slot] = q
                    kept.append(q)
                    break
    return rows


def _turns(g: _Geometry, seed: list, elbow: int, target) -> list:
    """Seeds (6 floats each) turned from ``seed`` along its wrist's family, keeping its elbow (0: θ3 ≥ 0, 1: θ3 ≤ 0);
    none for an absent seed, a regular wrist or a turn the arm cannot reach."""
    theta1, theta2, theta3, theta4, theta5, theta6 = seed
    if not abs(math.sin(theta5)) < TURN_SINE:
        return []
    px, py, pz = target[4:]
    cos1, sin1 = math.cos(theta1), math.sin(theta1)
    theta234 = theta2 + theta3 + theta4
    along = -1.0 if math.cos(theta5) > 0.0 else 1.0   # θ234 + θ6 fixed near θ5 = 0, θ234 − θ6 near π
    starts = []
    for k in range(1, TURNS):
        delta = k * 2.0 * math.pi / TURNS
        turned234 = theta234 + along * delta
        x4, z4 = _planar_arm(_ScalarOps, g, cos1, sin1, theta5, turned234, px, py, pz)
        cos3 = _elbow_cosine(_ScalarOps, g, x4, z4)
        if cos3 == cos3:
            shoulder, elbow3 = _shoulder_elbow_pair(_ScalarOps, g, x4, z4, cos3)[elbow]
            starts.append((theta1, shoulder, elbow3, turned234 - shoulder - elbow3, theta5, theta6 + delta))
    return starts
