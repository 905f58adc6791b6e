"""Calibrated arms beside a singular wrist (issue 11): ik_all and ik find the configuration a pose came from when
the nominal seeds' θ6 is off by up to π (ur_ik.wrist_turns)."""
import math

import numpy as np
import pytest

from calibrated_arms import factory_model
from ur3dq.kinematics.ur_ik import ik_all_batch, wrist_turns
from ur3dq.kinematics.ur_ik.calibrated import _refine_batch
from ur3dq.kinematics.ur_ik.fk_filter import _fk_check, _is_new, _targets
from ur3dq.kinematics.ur_ik.geometry import CALIBRATED_TOLERANCE, _geometry
from ur3dq.kinematics.ur_ik.single import _nominal_branches

TCP = [0.01, -0.02, 0.15, 0.1, 0.2, -0.3]
#: A UR3 factory table's configuration at θ5 = −0.0015 whose nominal seeds of its (θ1, elbow) pair both diverged:
#: ik_all returned 6 solutions, none within 1.3 rad of it, and ik from 0.08 rad away answered 1.3 rad away.
MISSED = [-1.1612051042373295, 1.379655701486345, -2.9196383056944066, -2.9158776758500142, -0.0014765392074586267,
          2.3150071628319635]
MISSED_REFERENCE = [-1.181891637719581, 1.298038699419245, -2.8380830971919506, -2.9084284109361933,
                    -0.07414182876320465, 2.369044842943544]


def distance(a, b) -> float:
    """Largest joint difference of a and b (6,) modulo 2π."""
    return float(np.max(np.abs(np.remainder(np.asarray(a) - b + math.pi, 2 * math.pi) - math.pi)))


def test_ik_all_and_ik_find_the_configuration_both_nominal_seeds_missed():
    model = factory_model("ur3", 1).with_tcp(TCP)
    pose = model.fk(MISSED)
    # Newton beside the singular wrist stops within 1e-12 of the pose: ~1e-9 rad of joints at σ ≈ 1e-3.
    assert min(distance(solution, MISSED) for solution in model.ik_all(pose)) < 1e-8
    assert distance(model.ik(pose, MISSED_REFERENCE), MISSED) < 1e-8
    poses = model.fk_batch(np.array([MISSED]))
    assert distance(model.ik_batch(poses, np.array([MISSED_REFERENCE]))[0], MISSED) < 1e-8
    rows = ik_all_batch(model, poses)[0]
    assert min(distance(row, MISSED) for row in rows if np.isfinite(row).all()) < 1e-8


@pytest.mark.parametrize("name, seed", [("ur3", 0), ("ur5e", 1), ("ur10", 2)])
def test_turned_seeds_fill_open_pairs_with_new_solutions_only(name, seed):
    """What the turns add are solutions (they pass the FK filter), each new to every other row; ik_all returns the
    rows the turns leave, duplicates merged."""
    model = factory_model(name, seed)
    g = _geometry(model)
    rng = np.random.default_rng(seed)
    q = rng.uniform(-math.pi, math.pi, (60, 6))
    q[:, 4] = rng.choice([-1.0, 1.0], 60) * 10 ** rng.uniform(-6, -1, 60) + rng.choice([0.0, math.pi], 60)
    filled = 0
    for pose in model.fk_batch(q):
        tcp_coefficients, target = _targets(g, pose)
        meets = _fk_check(model, g, tcp_coefficients)
        seeds = np.array(_nominal_branches(g, target, 0.0))
        exists = ~np.isnan(seeds[:, :2]).any(axis=1)   # as single._solution_candidates tells an absent branch
        rows = np.full((8, 6), np.nan)
        refined, residual = _refine_batch(g, seeds[exists], np.array(target)[None])
        rows[exists] = np.where((residual <= CALIBRATED_TOLERANCE)[:, None], refined, np.nan)
        turned = wrist_turns.turned(g, seeds, rows, target)
        for k in range(8):
            if np.array_equal(turned[k], rows[k], equal_nan=True):   # a slot without a new solution keeps its row
                continue
            filled += 1
            assert meets(tuple(turned[k]))
            assert all(distance(turned[k], turned[j]) >= 1e-6 for j in range(8) if j != k and
                       np.isfinite(turned[j]).all())
        found = []
        for row in turned.tolist():
            if row[0] == row[0] and _is_new(row, found):
                found.append(row)
        solutions = model.ik_all(pose)
        assert len(solutions) == len(found)
        for row in found:
            assert min(distance(row, solution) for solution in solutions) < 1e-12
    assert filled > 0   # the turns ran: these configurations hold pairs whose seeds missed



#: Configurations of factory tables (name, seed, joints) beside a singular wrist whose own seeds wander for more
#: than newton_floats.HOPELESS_STEP steps before they converge: ik_all lost each of them when the seeds of poses
#: with |sin θ5| down to 0.05 only were patient (their seeds' nominal θ5 lies at 0.06 or beyond).
WANDERING = [
    ("ur10", 1, [-2.6545893776333913, 2.965088302181308, 2.8319959077912245, -0.952980456428536,
                 0.01162954968941295, -2.219696976356699]),
    ("ur3e", 1, [-1.8441883077367531, 1.6645534075697554, 0.273603078557477, 2.6203465803622663,
                 0.03568688378252453, 2.3173657323280414]),
    ("ur5e", 1, [1.1011201066150917, -2.9827667901993404, -2.755392952170523, -2.29526860249773,
                 -0.04074190690989708, 1.77744362328475]),
]


@pytest.mark.parametrize("name, seed, q", WANDERING)
def test_seeds_beside_a_singular_wrist_are_refined_patiently(name, seed, q):
    model = factory_model(name, seed)
    pose = model.fk(q)
    assert min(distance(solution, q) for solution in model.ik_all(pose)) < 1e-8
    rows = ik_all_batch(model, model.fk_batch(np.array([q])))[0]
    assert min(distance(row, q) for row in rows if np.isfinite(row).all()) < 1e-8


#: A UR5 factory table's configuration beside a singular wrist (θ5 = 0.0165) that the batches solved apart from the
#: single-pose calls: refined in ik_all_batch's joint-major kernels one of its seeds reached no solution (4 against
#: ik_all's 5), and ik_batch answered 1.57 rad from ik, from the reference below.
APART = [-2.7040871864467735, 2.0014521389254387, -0.6728366607648217, -2.647198284311477, 0.016480392529305,
         -2.0413456443079765]
APART_REFERENCE = [-2.673356849387699, 1.9910685161926798, -0.6329613939635976, -2.6297422531597223,
                   0.030823050609150113, -2.0186379871484923]


@pytest.mark.parametrize("name, seed", [("ur5", 1), ("ur3e", 0)])
def test_batches_give_the_single_pose_answers_beside_a_singular_wrist(name, seed):
    """ik_all_batch and ik_batch take a pose beside a singular wrist from ik_all's and ik's own code: the same
    solutions and the same answer, float for float (on the batch's kernels they differed on 5 and 1 of 3,360 hard
    poses of the 14 factory tables); elsewhere the same solutions within the rounding of Newton's stop."""
    model = factory_model(name, seed)
    rng = np.random.default_rng(seed + 40)
    q = rng.uniform(-math.pi, math.pi, (48, 6))
    q[::2, 4] = rng.normal(0.0, 0.02, 24) + rng.choice([0.0, math.pi], 24)
    q[0] = APART
    references = q + rng.normal(0.0, 0.05, q.shape)
    references[0] = APART_REFERENCE
    poses = model.fk_batch(q)   # one pose for both paths: fk and fk_batch differ by rounding
    batch, nearest = ik_all_batch(model, poses), model.ik_batch(poses, references)
    beside = 0
    for pose, reference, rows, answer in zip(poses, references, batch, nearest):
        singles, rows = model.ik_all(pose), [row for row in rows if np.isfinite(row).all()]
        seeds = _nominal_branches(_geometry(model), _targets(_geometry(model), pose)[1], 0.0)
        if wrist_turns.beside_singular_wrist(seeds):
            beside += 1
            np.testing.assert_array_equal(np.array(rows), np.array(singles))
            np.testing.assert_array_equal(answer, model.ik(pose, reference))
        else:
            assert len(rows) == len(singles) and all(min(distance(row, s) for row in rows) < 1e-8 for s in singles)
            np.testing.assert_allclose(answer, model.ik(pose, reference), rtol=0, atol=1e-8)
    assert beside >= 20
