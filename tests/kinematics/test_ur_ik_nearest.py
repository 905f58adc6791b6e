"""`ik` of ur3dq.kinematics.ur_ik: per-joint nearest ±2π variants, the ranking of the branches and the FK filter,
each against an independent brute force.

The brute force for `ik` is the product of every in-limit ±2π variant (joint_variants) of every FK-verified
solution of ik_all: the search must find the same least weighted cost, also at and near the singular points and
with limits that exclude some variants or whole branches.
"""
import itertools
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from ik_cost import assert_least_cost, merge_slack
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics import URModel, robot_model, ur_ik
from ur3dq.kinematics.arm import arm_vector
from ur3dq.kinematics.ur_ik import frames, solve

ANGLE = st.floats(-math.pi, math.pi, allow_nan=False)
JOINTS = st.tuples(*(ANGLE,) * 6).map(np.array)
REFERENCE = st.tuples(*(st.floats(-2 * math.pi, 2 * math.pi, allow_nan=False),) * 6).map(np.array)
WEIGHTS = st.tuples(*(st.floats(0.1, 10.0),) * 6)
NEAR_SINGULAR = st.sampled_from([0.0, 1e-15, -1e-12, 1e-9, -1e-6, 1e-4, -2e-3, 0.3])


def brute_force_least_cost(model, pose, reference, weights):
    """Least Σ wᵢ·(qᵢ − refᵢ)² over the full product of in-limit variants of every ik_all solution (inf: none)."""
    try:
        solutions = ur_ik.ik_all(model, pose, q_ref=reference)
    except UnreachablePoseError:
        return math.inf
    best = math.inf
    for solution in solutions:
        variants = ur_ik.joint_variants(model, solution)   # a rounding past a limit is listed at the limit
        assert np.all((variants >= model.joint_lower) & (variants <= model.joint_upper))
        if len(variants):
            best = min(best, float(np.min(np.sum(weights * (variants - reference) ** 2, axis=1))))
    return best


def singular_wrist(q) -> bool:
    """θ5 at 0 or π: the solutions are a one-parameter family (equations.py), of which ik_all lists the split at
    the reference's θ6 while ik moves along the family into the limits or nearer the reference."""
    return min(abs(math.sin(q[4] / 2)), abs(math.cos(q[4] / 2))) < 1e-9


@settings(max_examples=300, deadline=None)
@given(angle=st.floats(-20.0, 20.0), reference=st.floats(-20.0, 20.0), low=st.floats(-15.0, 5.0),
       width=st.floats(0.0, 20.0), unlimited=st.sampled_from(["", "low", "high", "both"]))
def test_closest_variant_is_the_nearest_in_limit_variant_by_enumeration(angle, reference, low, width, unlimited):
    high = math.inf if unlimited in ("high", "both") else low + width
    low = -math.inf if unlimited in ("low", "both") else low
    variants = [angle + 2 * math.pi * k for k in range(-8, 9)]
    assume(all(abs(v - low) > 1e-9 and abs(v - high) > 1e-9 for v in variants))   # no rounding-level edge cases
    variant = solve.closest_variant(angle, reference, low, high, ur_ik.LIMIT_ROUNDING)[0]
    inside = [v for v in variants if low <= v <= high]
    if not inside:
        assert variant == math.inf
        return
    assert low <= variant <= high
    assert math.remainder(variant - angle, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert abs(variant - reference) == pytest.approx(min(abs(v - reference) for v in inside), abs=1e-9)


@pytest.mark.parametrize("name", ["ur5e", "ur10", "ur16e"])
@settings(max_examples=40, deadline=None)
@given(q=JOINTS, reference=REFERENCE, weights=WEIGHTS, theta5=NEAR_SINGULAR, theta3=NEAR_SINGULAR,
       wrist_at_pi=st.booleans(), elbow_folded=st.booleans())
def test_ik_finds_the_brute_force_least_cost_near_singular_points(name, q, reference, weights, theta5, theta3,
                                                                  wrist_at_pi, elbow_folded):
    model = robot_model(name)
    q = q.copy()
    q[4] = theta5 + (math.pi if wrist_at_pi else 0.0)
    q[2] = theta3 + (math.pi if elbow_folded else 0.0)
    pose = model.fk(q)
    weights = np.array(weights)
    best = brute_force_least_cost(model, pose, reference, weights)
    try:
        chosen = ur_ik.ik(model, pose, reference, weights)
    except UnreachablePoseError:
        assert best == math.inf   # the folded elbow may be out of reach of this arm's wrist offset
        return
    assert np.all(chosen >= model.joint_lower) and np.all(chosen <= model.joint_upper)
    cost = float(np.sum(weights * (chosen - reference) ** 2))
    if singular_wrist(q):   # ik may move along the family past ik_all's split: the brute force bounds it above
        assert cost <= best * (1 + 1e-9) + merge_slack(best, weights)
    else:
        assert_least_cost(cost, model, pose, reference, weights)
    metres, radians = model.fk(chosen).distance(pose)
    assert metres <= ur_ik.FK_TOLERANCE_M and radians <= ur_ik.FK_TOLERANCE_RAD


@settings(max_examples=80, deadline=None)
@given(q=JOINTS, reference=st.tuples(*(st.floats(-1.5, 1.5),) * 6).map(np.array), weights=WEIGHTS)
def test_ik_with_narrow_limits_and_a_tcp_finds_the_brute_force_least_cost_or_says_outside_limits(q, reference,
                                                                                               weights):
    nominal = robot_model("ur3e")
    narrow = URModel("ur3e", nominal.dh, nominal.max_joint_speed, np.full(6, -1.5), np.full(6, 1.5),
                     tcp=DualQuaternion.from_ur_pose([0.01, -0.02, 0.12, 0.2, -0.1, 0.3]))
    pose = narrow.fk(q)
    weights = np.array(weights)
    best = brute_force_least_cost(narrow, pose, reference, weights)
    if singular_wrist(q):
        # ik finds at least as good a split of the family as ik_all's, or none inside the limits when it has none.
        try:
            chosen = ur_ik.ik(narrow, pose, reference, weights)
        except UnreachablePoseError as error:
            assert best == math.inf and "outside limits" in str(error)
            return
        assert np.all(chosen >= narrow.joint_lower) and np.all(chosen <= narrow.joint_upper)
        assert float(np.sum(weights * (chosen - reference) ** 2)) <= best * (1 + 1e-9) + merge_slack(best, weights)
    elif best == math.inf:
        with pytest.raises(UnreachablePoseError, match="outside limits"):
            ur_ik.ik(narrow, pose, reference, weights)
        return
    else:
        chosen = ur_ik.ik(narrow, pose, reference, weights)
        assert_least_cost(float(np.sum(weights * (chosen - reference) ** 2)), narrow, pose, reference, weights)
    assert narrow.fk(chosen).is_close(pose, ur_ik.FK_TOLERANCE_M, ur_ik.FK_TOLERANCE_RAD)


@pytest.mark.parametrize("q, reference, weights", [
    ((0.0, 1.0, 0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0, 0.0, 1.0), (1.0,) * 6),
    ((0.0,) * 6, (0.0, 0.0, 0.0, 0.0, 0.0, 1.5), (1.0, 2.0, 3.0, 1.0, 1.0, 1.0)),
])
def test_ik_moves_along_the_singular_wrist_family_into_narrow_limits(q, reference, weights):
    # θ5 = 0 with a TCP: the split at the reference's θ6 puts θ4 outside ±1.5, another split of the family is inside.
    nominal = robot_model("ur3e")
    narrow = URModel("ur3e", nominal.dh, nominal.max_joint_speed, np.full(6, -1.5), np.full(6, 1.5),
                     tcp=DualQuaternion.from_ur_pose([0.01, -0.02, 0.12, 0.2, -0.1, 0.3]))
    pose = narrow.fk(np.array(q))
    chosen = ur_ik.ik(narrow, pose, np.array(reference), np.array(weights))
    assert np.all(np.abs(chosen) <= 1.5)
    assert narrow.fk(chosen).is_close(pose, ur_ik.FK_TOLERANCE_M, ur_ik.FK_TOLERANCE_RAD)
    cost = float(np.sum(np.array(weights) * (chosen - np.array(reference)) ** 2))
    assert cost <= brute_force_least_cost(narrow, pose, np.array(reference), np.array(weights))


def test_ik_returns_every_joint_of_the_nearest_branch_in_its_in_limit_variant():
    # The per-joint choice of the 2π shift (separable cost) is the product search's choice: check one case where
    # four joints need a shift, against the full 2^k product of shifts.
    model = robot_model("ur5e")
    q = np.array([2.9, -2.8, 1.1, 3.0, -2.5, 2.2])
    reference = q + np.array([-2 * math.pi, 2 * math.pi, 0.0, -2 * math.pi, 2 * math.pi, 0.0]) + 0.01
    chosen = ur_ik.ik(model, model.fk(q), reference)
    products = [q + 2 * math.pi * np.array(k) for k in itertools.product((-1, 0, 1), repeat=6)]
    inside = [p for p in products if np.all(np.abs(p) <= 2 * math.pi)]
    nearest = min(inside, key=lambda p: float(np.sum((p - reference) ** 2)))
    assert np.allclose(chosen, nearest, atol=1e-9)


def meets(model, q, pose) -> bool:
    """The IK's FK filter (eq. 4.45) of joints q against a TCP pose (8 coefficients)."""
    arm, goal = arm_vector(model), np.empty(frames.GOAL_SIZE)
    frames.goal_of(arm, np.asarray(pose, dtype=float), goal)
    return solve.meets(arm, np.asarray(q, dtype=float), goal, np.empty((7, 12)))


def test_fk_filter_accepts_the_pose_either_sign_and_rejects_a_nanometre_more():
    model = robot_model("ur10e").with_tcp([0.0, 0.0, 0.2, 0.0, 0.0, 0.5])
    q = (0.4, -1.1, 1.3, -0.7, 1.0, 0.2)
    pose = model.fk(q).to_array()
    assert meets(model, q, tuple(pose))
    assert meets(model, q, tuple(-pose))   # σ and −σ are the same pose
    # A 1e-8 rad turn of the base moves the TCP by ~1e-8 m (> 1 nm); of wrist 3, the TCP on its axis turns only.
    assert not meets(model, (q[0] + 1e-8,) + q[1:], tuple(pose))
    assert not meets(model, q[:5] + (q[5] + 1e-8,), tuple(pose))
    assert meets(model, q[:5] + (q[5] + 1e-11,), tuple(pose))


@pytest.mark.parametrize("name", ["ur3", "ur10e"])
def test_ik_batch_equals_ik_for_references_far_outside_the_limits(name):
    # A reference several turns beyond ±2π still has a nearest in-limit variant: the end of the in-limit run on
    # its side (not only the variants next to the reference's own), in the batch and the single path alike.
    model = robot_model(name)
    rng = np.random.default_rng(5)
    joints = rng.uniform(-math.pi, math.pi, (60, 6))
    references = joints + rng.choice([-3.0, -2.0, 0.0, 2.0, 3.0], joints.shape) * 2 * math.pi
    references += rng.normal(0.0, 0.3, joints.shape)
    poses = model.fk_batch(joints)
    batch = ur_ik.ik_batch(model, poses, references)
    assert np.all(np.isfinite(batch))   # ±2π limits leave every joint some variant
    for pose, reference, row in zip(poses, references, batch, strict=False):
        single = ur_ik.ik(model, pose, reference)
        assert np.max(np.abs(row - single)) < 1e-9
        assert np.all(single >= model.joint_lower) and np.all(single <= model.joint_upper)
        best = brute_force_least_cost(model, DualQuaternion.from_array(pose), reference, np.ones(6))
        if name != "ur3":   # joint_variants lists the UR3's unlimited wrist 3 within ±2π only
            assert float(np.sum((single - reference) ** 2)) == pytest.approx(best, rel=1e-9)


@pytest.mark.parametrize("weights", [None, (1.0, 2.0, 0.5, 1.0, 3.0, 0.1)])
def test_ik_batch_equals_ik_across_blocks(weights):
    # Two ik_batch blocks, a TCP, and references around ±π (where the nearest variant can lie past a ±2π limit).
    model = robot_model("ur10").with_tcp([0.01, -0.02, 0.15, 0.1, -0.2, 0.3])
    rng = np.random.default_rng(12)
    count = 4096 + 29
    joints = rng.uniform(-math.pi, math.pi, (count, 6))
    references = joints + rng.normal(0.0, 0.3, joints.shape)
    references[::7] = rng.uniform(-7.0, 7.0, (len(references[::7]), 6))
    poses = model.fk_batch(joints)
    batch = ur_ik.ik_batch(model, poses, references, weights)
    for i in list(range(0, count, 37)) + list(range(4096 - 5, count)):
        np.testing.assert_array_equal(batch[i], ur_ik.ik(model, poses[i], references[i], weights))
