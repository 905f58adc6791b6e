"""Replay planning (pure): which joints each pose gets, travel and time, and the refusals that name the pose."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import JointLimitError, SafetyCheckError, UnreachablePoseError
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.replay import (
    SOURCE_IK_PREVIOUS,
    SOURCE_IK_RECORDED,
    SOURCE_IK_ZERO,
    SOURCE_RECORDED,
    choose_joints,
    loop_closing_travel,
    plan_replay,
    tcp_pose_for,
)
from ur3dq.robot import motion

UR3 = robot_model("ur3")
A = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
B = np.array([0.8, -1.0, 1.3, -1.9, -1.57, 0.5])
TOOL = [0.0, 0.0, 0.15, 0.0, 0.0, 0.3]


def recorded(name, q, tcp=(0.0,) * 6, keep_joints=True, model="ur3"):
    """A pose as record-pose stores it: TCP pose of `q` with TCP offset `tcp`."""
    return Pose.from_dual_quaternion(name, UR3.with_tcp(tcp).fk(q), model, joints=q if keep_joints else None,
                                     tcp_offset=tcp)


def test_ik_follows_the_recorded_joints_even_on_another_branch():
    # B with the wrist flipped is another IK branch of a different pose; record it and the planner must return it
    flipped = B + np.array([0, 0, 0, 0, 0, 2 * math.pi])
    q, source, count = choose_joints(UR3, recorded("b", flipped), previous=A, replay_recorded_joints=False)
    np.testing.assert_allclose(q, flipped, atol=1e-9)
    assert source == SOURCE_IK_RECORDED and count >= 1


def test_without_recorded_joints_ik_takes_the_closest_to_the_previous():
    pose = recorded("b", B, keep_joints=False)
    q, source, _ = choose_joints(UR3, pose, previous=B + 0.01, replay_recorded_joints=False)
    np.testing.assert_allclose(q, B, atol=1e-9)
    assert source == SOURCE_IK_PREVIOUS
    _, source, _ = choose_joints(UR3, pose, previous=None, replay_recorded_joints=False)
    assert source == SOURCE_IK_ZERO


def test_each_pose_is_solved_with_its_own_tcp_offset():
    q, _, _ = choose_joints(UR3, recorded("tool", A, tcp=TOOL, keep_joints=False), A + 0.01, False)
    np.testing.assert_allclose(q, A, atol=1e-9)


def test_recorded_joints_mode_replays_them_and_refuses_what_it_cannot():
    q, source, count = choose_joints(UR3, recorded("a", A), None, replay_recorded_joints=True)
    np.testing.assert_array_equal(q, A)
    assert source == SOURCE_RECORDED and count == 0
    with pytest.raises(ValueError, match="pose 'x' has no recorded joints"):
        choose_joints(UR3, recorded("x", A, keep_joints=False), None, True)
    with pytest.raises(ValueError, match="pose 'y' was recorded on a ur5"):
        choose_joints(UR3, recorded("y", A, model="ur5"), None, True)
    outside = A + np.array([7.0, 0, 0, 0, 0, 0])
    with pytest.raises(JointLimitError, match="pose 'z'"):
        choose_joints(UR3, Pose.from_dual_quaternion("z", UR3.fk(outside), "ur3", joints=outside), None, True)


def test_unreachable_pose_names_itself():
    far = Pose.from_dual_quaternion("far", DualQuaternion.from_translation([2.0, 0, 0]), "ur3")
    with pytest.raises(UnreachablePoseError, match="pose 'far' is unreachable on the ur3: .*too far"):
        plan_replay(UR3, [recorded("a", A), far], A)


def test_plan_reports_travel_time_and_fk_residual():
    steps = plan_replay(UR3, [recorded("a", A), recorded("b", B)], start_joints=A, a=1.4, v=1.05)
    assert [s.pose.name for s in steps] == ["a", "b"]
    assert steps[0].travel == pytest.approx(0.0, abs=1e-9) and steps[0].duration == pytest.approx(0.0, abs=1e-4)
    assert steps[1].travel == pytest.approx(0.8)
    assert steps[1].duration == pytest.approx(motion.movej_duration(A, B, 1.4, 1.05))
    assert all(s.fk_error_m < 1e-9 and s.fk_error_rad < 1e-9 for s in steps)
    unknown_start = plan_replay(UR3, [recorded("a", A)], None)
    assert unknown_start[0].travel is None and unknown_start[0].duration is None
    assert loop_closing_travel(steps) == pytest.approx(0.8)


def test_plan_refuses_a_move_beyond_max_travel():
    with pytest.raises(SafetyCheckError, match="pose 'b': a joint would travel 0.800 rad"):
        plan_replay(UR3, [recorded("a", A), recorded("b", B)], A, max_joint_travel=0.5)


def test_a_move_beyond_max_travel_is_named_before_a_later_unreachable_pose():
    """The plan's faults come in pose order, as pose by pose: the travel of an earlier move before a later pose
    that cannot be solved, and that pose when the moves before it are within --max-travel."""
    far = Pose.from_dual_quaternion("far", DualQuaternion.from_translation([2.0, 0, 0]), "ur3")
    with pytest.raises(SafetyCheckError, match="pose 'b': a joint would travel 0.800 rad"):
        plan_replay(UR3, [recorded("a", A), recorded("b", B), far], A, max_joint_travel=0.5)
    with pytest.raises(UnreachablePoseError, match="pose 'far'"):
        plan_replay(UR3, [recorded("a", A), recorded("b", B), far], A, max_joint_travel=1.0)


def test_each_duration_is_the_movej_trapezoid_of_its_move():
    """The durations, computed for all moves at once, are motion.movej_duration's, to the last bit, on both sides
    of the cruise threshold (a short move never reaches v)."""
    rng = np.random.default_rng(8)
    joints = A + rng.normal(0, 0.8, (30, 6)) * rng.uniform(0, 1, (30, 1)) ** 2
    poses = [recorded(f"p{i}", q) for i, q in enumerate(joints)]
    steps = plan_replay(UR3, poses, A, a=0.7, v=0.9)
    previous = A
    for step in steps:
        assert step.duration == motion.movej_duration(previous, step.joints, 0.7, 0.9)
        previous = step.joints
    assert min(s.travel for s in steps) < 0.9 ** 2 / 0.7 < max(s.travel for s in steps)


def test_tcp_pose_for_moves_the_recorded_pose_onto_the_current_tcp():
    pose = recorded("tool", A, tcp=TOOL)
    assert tcp_pose_for(pose, DualQuaternion.from_ur_pose(TOOL)).is_close(pose.dq)
    assert tcp_pose_for(pose, DualQuaternion.identity()).is_close(UR3.fk(A))


joint_angle = st.floats(-math.pi, math.pi, allow_nan=False)
# wrist 2 away from 0 and ±π (the wrist singularity, where IK has a continuum of solutions)
wrist_2 = st.one_of(st.floats(0.2, math.pi - 0.2), st.floats(-math.pi + 0.2, -0.2))
# elbow away from 0 and ±π (stretched or folded arm: shoulder/elbow branches merge)
elbow = st.one_of(st.floats(0.2, math.pi - 0.2), st.floats(-math.pi + 0.2, -0.2))


@settings(max_examples=60, deadline=None)
@given(q=st.tuples(joint_angle, joint_angle, elbow, joint_angle, wrist_2, joint_angle))
def test_replay_of_a_recorded_pose_returns_its_recorded_joints(q):
    q = np.array(q)
    (step,) = plan_replay(UR3, [recorded("p", q)], start_joints=np.zeros(6))
    np.testing.assert_allclose(step.joints, q, atol=1e-7)
    assert step.source == SOURCE_IK_RECORDED and step.fk_error_m < 1e-9


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur10"])
def test_the_batch_of_recorded_poses_plans_what_choose_joints_picks_pose_by_pose(name, monkeypatch):
    """plan_replay solves the poses with recorded joints in one batch: the same joints, sources and solution
    counts as choose_joints per pose — with hints that are the pose's joints or 0.3 rad off, other TCPs, and
    singular poses (joints at multiples of π, up to the ±2π limits: stretched elbow, wrist 2 at 0)."""
    import ur3dq.replay as replay

    model = robot_model(name)
    rng = np.random.default_rng(4)
    lower, upper = np.maximum(model.joint_lower, -7), np.minimum(model.joint_upper, 7)
    joints = rng.uniform(lower, upper, (400, 6))
    joints[::7] = np.clip(np.round(joints[::7] / np.pi) * np.pi, lower, upper)
    joints[::11, 4] = 0.0
    poses = []
    for index, q in enumerate(joints):
        hint = np.clip(q + rng.normal(0, 0.3, 6) * (index % 3 == 0), lower, upper)
        tcp = (0.0,) * 6 if index % 4 else (0.01, -0.02, 0.1, 0.1, 0.0, 0.2)
        poses.append(Pose.from_dual_quaternion(f"p{index}", model.with_tcp(tcp).fk(q), name, joints=tuple(hint),
                                               tcp_offset=tcp))
    batch = plan_replay(model, poses)
    monkeypatch.setattr(replay, "_solve_recorded", lambda *arguments: {})
    one_by_one = plan_replay(model, poses)
    assert sum(step.source == SOURCE_IK_RECORDED for step in batch) == len(poses)
    for fast, slow in zip(batch, one_by_one):
        np.testing.assert_allclose(fast.joints, slow.joints, rtol=0, atol=1e-9)
        assert (fast.source, fast.solutions) == (slow.source, slow.solutions)
        assert fast.fk_error_m == pytest.approx(slow.fk_error_m, abs=1e-12)


def test_at_a_singular_pose_ik_nearest_the_recorded_joints_returns_them():
    """A stretched elbow at its 2π limit and wrist 2 at 0: the recorded joints are a solution, and the one chosen
    (ik_all's list held another member of the family, 6.3 rad away, which choose_joints used to take)."""
    q = np.array([0.3, -1.0, 2 * math.pi, -1.2, 0.0, 0.5])
    chosen, source, _ = choose_joints(UR3, recorded("stretched", q), None, replay_recorded_joints=False)
    assert source == SOURCE_IK_RECORDED
    np.testing.assert_allclose(chosen, q, atol=1e-7)
