"""The batch kernels (issue 2's speed work): the closed-form IK block kernel against the general equations it
shortcuts, the FK filter as a genuine forward-kinematics check, and the batch FK's blocking and layout.

The reference for the IK kernel is the general path that calibrated models still take (equations._branches over numpy
arrays, its own FK filter through model.fk_batch, the pairwise duplicate check): branch k of every pose must hold
the same solution (within DUPLICATE_TOLERANCE, mod 2π) or be absent in both.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq import dqarray
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics import MODEL_NAMES, robot_model, ur_fk, ur_ik
from ur3dq.kinematics.ur_ik import batch as ik_batch
from ur3dq.kinematics.ur_ik import batch_kernels as ik_batch_kernels
from ur3dq.kinematics.ur_ik import geometry as ik_geometry

ANGLE = st.floats(-math.pi, math.pi, allow_nan=False)
JOINTS = st.tuples(*(ANGLE,) * 6).map(np.array)
NEAR_ZERO = st.sampled_from([0.0, 1e-15, -1e-13, 1e-11, -1e-9, 1e-7, -1e-5, 1e-3, 2e-3])
TCP = [0.01, -0.02, 0.15, 0.1, -0.2, 0.3]


def general_solutions(model, poses):
    """(N, 8, 6) what ik_all_batch returned before the kernel: general equations, FK filter, duplicate check."""
    g = ik_geometry._geometry(model)
    columns = ik_batch._batch_candidates(g, ik_batch._batch_flange_targets(g, poses), 0.0)
    keep = ik_batch._drop_duplicates(columns, ik_batch._fk_filter(model, columns, poses))
    return np.where(keep, columns, np.nan).transpose(2, 1, 0)


def assert_same_branches(actual, expected):
    present = np.isfinite(actual[..., 0])
    np.testing.assert_array_equal(present, np.isfinite(expected[..., 0]))
    difference = ur_ik.wrap_angle(actual[present] - expected[present])
    assert np.max(np.abs(difference), initial=0.0) < ur_ik.DUPLICATE_TOLERANCE


@pytest.mark.parametrize("name", MODEL_NAMES)
@pytest.mark.parametrize("tcp", [None, TCP])
def test_kernel_equals_the_general_equations_on_random_poses(name, tcp):
    model = robot_model(name) if tcp is None else robot_model(name).with_tcp(tcp)
    joints = np.random.default_rng(3).uniform(-math.pi, math.pi, (ur_ik.IK_BLOCK + 37, 6))   # two blocks
    poses = model.fk_batch(joints)
    poses[5] = dqarray.from_ur_pose([3.0, 0.0, 0.0, 0.0, 0.0, 0.0])      # too far
    poses[6] = dqarray.from_ur_pose([0.0, 0.0, 0.3, 0.0, 0.0, 0.0])      # wrist centre on the base axis: too close
    assert_same_branches(ur_ik.ik_all_batch(model, poses), general_solutions(model, poses))


@settings(max_examples=60, deadline=None)
@given(q=JOINTS, theta5=NEAR_ZERO, theta3=NEAR_ZERO, wrist_at_pi=st.booleans(), elbow_folded=st.booleans(),
       name=st.sampled_from(MODEL_NAMES))
def test_batch_holds_the_solution_sets_of_ik_all_near_singularities(q, theta5, theta3, wrist_at_pi, elbow_folded,
                                                                    name):
    # Near a wrist and elbow singularity at once the elbow pair's separation is rounding noise amplified to ~1e-3
    # rad, so the batch redoes those poses with ik_all's own scalar path: the same sets, not only similar ones.
    model = robot_model(name)
    q = q.copy()
    q[2] = theta3 + (math.pi if elbow_folded else 0.0)
    q[4] = theta5 + (math.pi if wrist_at_pi else 0.0)
    poses = model.fk_batch(np.stack([q, q * 0.5]))
    for rows, pose in zip(ur_ik.ik_all_batch(model, poses), poses):
        found = rows[np.isfinite(rows[:, 0])]
        try:
            singles = ur_ik.ik_all(model, pose)
        except UnreachablePoseError:
            singles = []
        assert len(found) == len(singles)
        for single in singles:
            assert np.min(np.max(np.abs(ur_ik.wrap_angle(found - single)), axis=1)) < 1e-12


def test_kernel_equals_the_general_equations_at_the_shoulder_singularity():
    # Wrist centre exactly d4 from the base axis: a2 c2 + a3 c23 + d5 s234 = 0 (q2 = −π/2 zeroes the a2 term).
    model = robot_model("ur3")
    a3, d5 = model.dh.a[2], model.dh.d[4]
    q2, q3 = -math.pi / 2, 0.3
    q234 = math.asin(-a3 * math.cos(q2 + q3) / d5)
    q = np.array([0.4, q2, q3, q234 - q2 - q3, 0.9, -0.6])
    pose = model.fk_batch(q[None])
    batch = ur_ik.ik_all_batch(model, pose)[0]
    found = batch[np.isfinite(batch[:, 0])]
    # The rounding of x5² + y5² − d4² (~1e-17) opens the merged θ1 pair to ~1e-8 rad: both paths keep both.
    assert len(found) == len(ur_ik.ik_all(model, pose[0]))
    assert_same_branches(batch[None], general_solutions(model, pose))


def test_fk_filter_evaluates_the_joints_it_is_given():
    # A genuine forward-kinematics check: nudging one joint of a solution by 1e-6 rad must fail it, by 1e-13 not.
    model = robot_model("ur5e").with_tcp(TCP)
    g = ik_geometry._geometry(model)
    poses = model.fk_batch(np.random.default_rng(4).uniform(-math.pi, math.pi, (64, 6)))
    columns, exists, _, _ = ik_batch_kernels._regular_branches(g, np.stack(ik_batch._batch_flange_targets(g, poses)))
    valid = ik_batch_kernels._regular_fk_filter(g, columns, ik_batch._pair_rows(poses.T)) & exists
    assert valid.sum() > 300
    for joint in range(6):
        for nudge, survives in ((1e-6, False), (1e-13, True)):
            moved = columns.copy()
            moved[joint] += nudge
            again = ik_batch_kernels._regular_fk_filter(g, moved, ik_batch._pair_rows(poses.T)) & exists
            assert np.array_equal(again, valid) == survives, (joint, nudge)


def test_fk_filter_rejects_a_solution_of_another_pose():
    model = robot_model("ur10")
    g = ik_geometry._geometry(model)
    poses = model.fk_batch(np.random.default_rng(5).uniform(-math.pi, math.pi, (32, 6)))
    columns, exists, _, _ = ik_batch_kernels._regular_branches(g, np.stack(ik_batch._batch_flange_targets(g, poses)))
    other_poses = ik_batch._pair_rows(np.roll(poses, 1, axis=0).T)
    assert not np.any(ik_batch_kernels._regular_fk_filter(g, columns, other_poses) & exists)


@pytest.mark.parametrize("count", [1, ur_fk.BLOCK - 1, ur_fk.BLOCK + 3])
def test_fk_batch_over_block_boundaries_equals_fk(count):
    model = robot_model("ur10e").with_tcp(TCP)
    joints = np.random.default_rng(count).uniform(-2 * math.pi, 2 * math.pi, (count, 6))
    batch = model.fk_batch(joints)
    assert batch.shape == (count, 8)
    for i in sorted({0, count // 2, count - 1}):
        expected = model.fk(joints[i]).to_array()
        np.testing.assert_allclose(batch[i], expected, rtol=0, atol=1e-14)


@settings(max_examples=200, deadline=None)
@given(angle=st.floats(-1e3, 1e3, allow_nan=False) | st.sampled_from([math.pi, -math.pi, 3 * math.pi, 0.0]))
def test_wrap_in_place_equals_wrap_angle(angle):
    values = np.array([angle, -angle, math.nan])
    expected = ur_ik.wrap_angle(values)
    wrapped = ik_batch_kernels._wrap_in_place(values)
    assert wrapped is values
    np.testing.assert_array_equal(wrapped[:2], expected[:2])
    assert math.isnan(wrapped[2])


def test_sincos_of_double_matches_numpy():
    angles = np.concatenate((np.linspace(-20, 20, 20002), np.arange(-8, 9) * math.pi / 2)).reshape(3, -1)
    sine, cosine = dqarray.sincos_of_half(0.5 * angles)
    np.testing.assert_allclose(sine, np.sin(angles), rtol=0, atol=4e-15)
    np.testing.assert_allclose(cosine, np.cos(angles), rtol=0, atol=4e-15)
