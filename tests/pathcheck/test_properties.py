"""Property tests: random programs inside a region that is feasible by construction are accepted, and every
accepted move's samples are what the controller runs (on the line, FK-consistent, within the resolution)."""
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import Margins, PathPlan, PathSegment, cell_from_dict, check_path

UR5 = robot_model("ur5")
# Tool straight down in front of the robot: TCP ≈ 0.49 m out, 0.26 m up. Within ±0.1 m of it, at that orientation,
# the wrist stays at θ5 ≈ −90° (far from singular), the elbow bent (|sin θ3| > 0.5), the wrist centre > 0.3 m from
# the base axis, and the links far from each other and from a floor 5 cm below the base.
HOME = np.array([0.0, -1.9, 1.9, -1.5708, -1.5708, 0.0])
CELL = cell_from_dict({"floor": {"z": -0.05}, "margin": 0.01})

offset = st.tuples(*[st.floats(-0.1, 0.1)] * 3)
joint_nudge = st.tuples(*[st.floats(-0.15, 0.15)] * 6)
waypoint = st.one_of(st.tuples(st.just("linear"), offset), st.tuples(st.just("process"), offset),
                     st.tuples(st.just("joint"), joint_nudge))


def program(waypoints):
    home_pose = UR5.fk(HOME)
    segments = []
    for i, (move, values) in enumerate(waypoints):
        if move == "joint":
            segments.append(PathSegment(f"w{i}", "joint", target_joints=HOME + np.array(values)))
        else:
            pose = DualQuaternion.from_translation(values) * home_pose
            segments.append(PathSegment(f"w{i}", move, target_pose=pose.to_array(), speed=0.1, acceleration=1.2))
    return PathPlan(HOME, segments)


@settings(max_examples=40, deadline=None)
@given(st.lists(waypoint, min_size=1, max_size=6))
def test_random_feasible_programs_are_accepted_and_sampled_as_the_controller_moves(waypoints):
    plan = program(waypoints)
    margins = Margins()
    result = check_path(UR5, plan, CELL, margins)
    assert result.ok, result.summary()
    assert [step.name for step in result.steps] == [segment.name for segment in plan.segments]
    previous_end = plan.start_joints
    for segment, step in zip(plan.segments, result.steps):
        assert np.allclose(step.joints[0], previous_end, atol=1e-9)       # each move starts where the last ended
        previous_end = step.end_joints
        chords = np.linalg.norm(np.diff(step.tcp, axis=0), axis=1)
        assert np.all(chords <= margins.tcp_resolution + 1e-9)
        assert np.all(np.abs(np.diff(step.joints, axis=0)) <= margins.joint_resolution + 1e-9)
        fk = UR5.fk_batch(step.joints)
        assert np.allclose(dqarray.translation_unchecked(fk), step.tcp, atol=1e-9)
        if segment.cartesian:
            start, end = step.tcp[0], step.tcp[-1]
            assert np.allclose(end, DualQuaternion.from_array(segment.target_pose).translation, atol=1e-9)
            length = np.linalg.norm(end - start)
            if length > 1e-9:
                direction = (end - start) / length
                off = (step.tcp - start) - np.outer((step.tcp - start) @ direction, direction)
                assert np.max(np.linalg.norm(off, axis=1)) < 1e-9
            metres, radians = dqarray.pose_distance(fk[-1], segment.target_pose)
            assert metres < 1e-9 and radians < 1e-9
        else:
            assert np.allclose(step.joints[-1], segment.target_joints, atol=1e-12)


@settings(max_examples=20, deadline=None)
@given(offset, st.floats(0.05, 0.3))
def test_a_box_on_the_line_is_always_found(target, size):
    # A cube centred on the middle of a random line inside the region: the tool passes through it.
    home_pose = UR5.fk(HOME)
    end = DualQuaternion.from_translation(target) * home_pose
    middle = 0.5 * (home_pose.translation + end.translation)
    cell = cell_from_dict({"boxes": [{"name": "cube", "min": list(middle - size / 2), "max": list(middle + size / 2)}],
                           "margin": 0.0})
    plan = PathPlan(HOME, [PathSegment("line", "linear", target_pose=end.to_array(), speed=0.1)])
    result = check_path(UR5, plan, cell)
    assert any(p.check == "cell" and '"cube"' in p.message for p in result.problems), result.summary()
    assert not math.isnan(result.steps[0].margins["cell"]) and result.steps[0].margins["cell"] < 0


@settings(max_examples=15, deadline=None)
@given(st.lists(st.tuples(waypoint, st.sampled_from([0.0, 0.01, 0.2])), min_size=1, max_size=6))
def test_the_check_without_samples_finds_the_same_margins_and_problems(blended_waypoints):
    """keep_samples=False (the command line's check before a run) finds the same problems, with blends (some too
    large) between the moves; a move it samples as the dense check does has the same margins, worst samples and
    sample count, and any other is a joint move the bounds certified (tests/pathcheck/test_bounds.py)."""
    plan = program([w for w, _ in blended_waypoints])
    segments = [PathSegment(s.name, s.move, s.target_joints, s.target_pose, s.speed, s.acceleration, blend)
                for s, (_, blend) in zip(plan.segments, blended_waypoints)]
    blended = PathPlan(plan.start_joints, segments)
    cell = cell_from_dict({"floor": {"z": 0.2}, "margin": 0.01})      # a floor some moves pass through
    kept, lean = check_path(UR5, blended, cell), check_path(UR5, blended, cell, keep_samples=False)
    assert lean.problems == kept.problems
    assert [s.name for s in lean.steps] == [s.name for s in kept.steps]
    for lean_step, kept_step in zip(lean.steps, kept.steps):
        if lean_step.samples == kept_step.samples:
            assert (lean_step.margins, lean_step.worst) == (kept_step.margins, kept_step.worst)
        else:
            assert lean_step.move == "joint" and min(lean_step.margins.values()) >= 0
    assert all(s.joints is None and s.tcp is None and s.fraction is None for s in lean.steps)
    assert all(s.samples == len(s.tcp) for s in kept.steps)
