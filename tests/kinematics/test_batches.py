"""Batches of poses: ik_all_batch against ik_all pose by pose (near singularities too), the FK filter as a genuine
forward-kinematics check, and fk_batch against fk."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq import dqarray
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics import MODEL_NAMES, robot_model, ur_ik
from ur3dq.kinematics.arm import arm_vector
from ur3dq.kinematics.ur_ik import frames, solve

ANGLE = st.floats(-math.pi, math.pi, allow_nan=False)
JOINTS = st.tuples(*(ANGLE,) * 6).map(np.array)
NEAR_ZERO = st.sampled_from([0.0, 1e-15, -1e-13, 1e-11, -1e-9, 1e-7, -1e-5, 1e-3, 2e-3])
TCP = [0.01, -0.02, 0.15, 0.1, -0.2, 0.3]


def same_sets(batch_rows, singles) -> None:
    """The finite rows of one pose's ik_all_batch slots are ik_all's solutions, float for float, in slot order."""
    found = batch_rows[np.isfinite(batch_rows[:, 0])]
    np.testing.assert_array_equal(found, np.array(singles).reshape(-1, 6))


@settings(max_examples=60, deadline=None)
@given(q=JOINTS, theta5=NEAR_ZERO, theta3=NEAR_ZERO, wrist_at_pi=st.booleans(), elbow_folded=st.booleans(),
       name=st.sampled_from(MODEL_NAMES))
def test_batch_holds_the_solution_sets_of_ik_all_near_singularities(q, theta5, theta3, wrist_at_pi, elbow_folded,
                                                                    name):
    # A batch is a loop of ik_all's own kernel over its poses: the same sets, not only similar ones.
    model = robot_model(name)
    q = q.copy()
    q[2] = theta3 + (math.pi if elbow_folded else 0.0)
    q[4] = theta5 + (math.pi if wrist_at_pi else 0.0)
    poses = model.fk_batch(np.stack([q, q * 0.5]))
    for rows, pose in zip(ur_ik.ik_all_batch(model, poses), poses, strict=False):
        try:
            singles = ur_ik.ik_all(model, pose)
        except UnreachablePoseError:
            singles = []
        same_sets(rows, singles)


@pytest.mark.parametrize("tcp", [None, TCP])
def test_ik_all_batch_is_ik_all_pose_by_pose_with_unreachable_rows(tcp):
    model = robot_model("ur10e") if tcp is None else robot_model("ur10e").with_tcp(tcp)
    joints = np.random.default_rng(3).uniform(-math.pi, math.pi, (300, 6))
    poses = model.fk_batch(joints)
    poses[5] = dqarray.from_ur_pose([3.0, 0.0, 0.0, 0.0, 0.0, 0.0])      # too far
    poses[6] = dqarray.from_ur_pose([0.0, 0.0, 0.3, 0.0, 0.0, 0.0])      # wrist centre on the base axis: too close
    batch = ur_ik.ik_all_batch(model, poses)
    assert np.isnan(batch[5:7]).all()
    for index in (0, 1, 2, 100, 299):
        same_sets(batch[index], ur_ik.ik_all(model, poses[index]))


def test_the_shoulder_singularity_in_a_batch():
    # Wrist centre exactly d4 from the base axis: a2 c2 + a3 c23 + d5 s234 = 0 (q2 = −π/2 zeroes the a2 term).
    model = robot_model("ur3")
    a3, d5 = model.dh.a[2], model.dh.d[4]
    q2, q3 = -math.pi / 2, 0.3
    q234 = math.asin(-a3 * math.cos(q2 + q3) / d5)
    q = np.array([0.4, q2, q3, q234 - q2 - q3, 0.9, -0.6])
    pose = model.fk_batch(q[None])
    batch = ur_ik.ik_all_batch(model, pose)[0]
    same_sets(batch, ur_ik.ik_all(model, pose[0]))
    assert min(np.max(np.abs(ur_ik.wrap_angle(row - q))) for row in batch if np.isfinite(row[0])) < 1e-6


def filter_verdicts(model, rows, poses) -> np.ndarray:
    """(N, 8) the FK filter's verdicts on each pose's 8 branch rows."""
    arm, goal, chain = arm_vector(model), np.empty(frames.GOAL_SIZE), np.empty((7, 12))
    verdicts = np.zeros(rows.shape[:2], dtype=bool)
    for index, pose in enumerate(poses):
        frames.goal_of(arm, pose, goal)
        for slot, row in enumerate(rows[index]):
            verdicts[index, slot] = np.isfinite(row).all() and solve.meets(arm, row, goal, chain)
    return verdicts


@pytest.mark.parametrize("calibrated", [False, True])
def test_fk_filter_evaluates_the_joints_it_is_given(calibrated):
    # A genuine forward-kinematics check: nudging one joint of a solution by 1e-6 rad must fail it, by 1e-13 not.
    model = robot_model("ur5e", dh_deltas={"a": [1e-4] * 6} if calibrated else None).with_tcp(TCP)
    poses = model.fk_batch(np.random.default_rng(4).uniform(-math.pi, math.pi, (32, 6)))
    rows = ur_ik.ik_all_batch(model, poses)
    valid = filter_verdicts(model, rows, poses)
    assert valid.sum() > 150 and valid.sum() == np.isfinite(rows[..., 0]).sum()
    for joint in range(6):
        for nudge, survives in ((1e-6, False), (1e-13, True)):
            moved = rows.copy()
            moved[..., joint] += nudge
            assert np.array_equal(filter_verdicts(model, moved, poses), valid) == survives, (joint, nudge)
    assert not filter_verdicts(model, rows, np.roll(poses, 1, axis=0)).any()   # another pose's solutions


@pytest.mark.parametrize("count", [1, 4095, 4099])
def test_fk_batch_equals_fk(count):
    model = robot_model("ur10e").with_tcp(TCP)
    joints = np.random.default_rng(count).uniform(-2 * math.pi, 2 * math.pi, (count, 6))
    batch = model.fk_batch(joints)
    assert batch.shape == (count, 8)
    for i in sorted({0, count // 2, count - 1}):
        np.testing.assert_allclose(batch[i], model.fk(joints[i]).to_array(), rtol=0, atol=1e-14)


def test_sincos_of_double_matches_numpy():
    angles = np.concatenate((np.linspace(-20, 20, 20002), np.arange(-8, 9) * math.pi / 2)).reshape(3, -1)
    sine, cosine = dqarray.sincos_of_half(0.5 * angles)
    np.testing.assert_allclose(sine, np.sin(angles), rtol=0, atol=4e-15)
    np.testing.assert_allclose(cosine, np.cos(angles), rtol=0, atol=4e-15)
