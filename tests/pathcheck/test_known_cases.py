"""The path check's known cases, each built so the answer is known without the checker's own geometry."""
import math

import numpy as np
import pytest

from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import Margins, PathPlan, PathSegment, cell_from_dict, check_path

UR5 = robot_model("ur5")
# Tool pointing straight down (flange z = −base z), wrist well away from every singularity.
DOWN = np.array([0.0, -1.9, 1.9, -1.5708, -1.5708, 0.0])


def shifted(model, q, offset):
    """The TCP pose of q translated by `offset` (base frame), orientation kept."""
    return (DualQuaternion.from_translation(offset) * model.fk(q)).to_array()


def only(result, check):
    return [p for p in result.problems if p.check == check]


def test_a_feasible_linear_move_passes_with_every_margin_reported():
    plan = PathPlan(DOWN, [PathSegment("slide", "linear", target_pose=shifted(UR5, DOWN, (0.0, 0.15, 0.0)),
                                       speed=0.1)])
    result = check_path(UR5, plan, cell_from_dict({"floor": {"z": 0.0}}))
    assert result.ok, result.summary()
    step = result.steps[0]
    assert step.samples >= 151            # ≤ 1 mm of TCP between samples over 0.15 m
    assert np.max(np.linalg.norm(np.diff(step.tcp, axis=0), axis=1)) <= 0.001 + 1e-12
    assert set(step.margins) >= {"wrist", "elbow", "shoulder", "joint_limit", "joint_speed", "self_collision", "cell"}
    # The samples are on the straight line, their joints reproduce them (the IK answers were followed, not guessed).
    start, end = step.tcp[0], step.tcp[-1]
    direction = (end - start) / np.linalg.norm(end - start)
    off_line = (step.tcp - start) - np.outer((step.tcp - start) @ direction, direction)
    assert np.max(np.linalg.norm(off_line, axis=1)) < 1e-9
    fk = np.array([UR5.fk(q).translation for q in step.joints[::25]])
    assert np.allclose(fk, step.tcp[::25], atol=1e-9)


def test_movel_through_the_wrist_singularity_is_refused_naming_the_wrist_and_the_step():
    # θ5 = 0 at the middle pose; a line across the arm's plane (along z1, the base-joint direction) at a constant
    # orientation makes θ1 change through it, so θ5 = acos(z1·z6) crosses 0 in the middle of the line.
    middle = np.array([0.0, -1.2, 1.5, -1.8, 0.0, 0.5])
    z1 = np.array([math.sin(middle[0]), -math.cos(middle[0]), 0.0])
    start_pose = shifted(UR5, middle, -0.06 * z1)
    start = UR5.ik(start_pose, middle)
    plan = PathPlan(start, [PathSegment("approach", "linear", target_pose=shifted(UR5, middle, 0.06 * z1),
                                        speed=0.1)])
    result = check_path(UR5, plan)
    wrist = only(result, "wrist")
    assert not result.ok and wrist, result.summary()
    assert wrist[0].step == "approach"
    assert "wrist singular: wrist 2 passes 0." in wrist[0].message and "keep ≥ 1.1 °" in wrist[0].message
    assert 0.4 < wrist[0].fraction < 0.6
    assert "step 'approach' at" in wrist[0].line()


def test_movel_past_the_reach_is_refused_naming_the_step_and_the_point():
    q = np.array([0.0, -1.2, 1.2, -1.5708, -1.5708, 0.0])
    far = shifted(UR5, q, (-0.8, 0.0, 0.0))           # a metre out: the UR5 reaches about 0.95 m
    plan = PathPlan(q, [PathSegment("reach out", "linear", target_pose=far, speed=0.1)])
    result = check_path(UR5, plan)
    reach = only(result, "reach")
    assert reach, result.summary()
    problem = reach[0]
    assert problem.step == "reach out" and 0.0 < problem.fraction < 1.0
    # The point named is on the line, where the wrist centre is at full stretch: independent check with the DH.
    start, end = UR5.fk(q).translation, DualQuaternion.from_array(far).translation
    expected = start + problem.fraction * (end - start)
    assert np.allclose(problem.tcp, expected, atol=1e-9)
    assert "leaves the arm's reach" in problem.message


def test_movej_sweeping_through_a_keep_out_box_is_refused_although_both_ends_are_far():
    q = np.array([0.0, -1.2, 1.2, -1.5708, -1.5708, 0.0])
    centre = UR5.fk(q).translation                    # where the tool is at θ1 = 0, halfway through the sweep
    box = {"name": "fixture", "min": list(centre - 0.05), "max": list(centre + 0.05)}
    start, end = q.copy(), q.copy()
    start[0], end[0] = -math.pi / 2, math.pi / 2
    cell = cell_from_dict({"boxes": [box]})
    for endpoint in (start, end):
        assert np.linalg.norm(UR5.fk(endpoint).translation - centre) > 0.5
        assert check_path(UR5, PathPlan(endpoint, [PathSegment("stay", "joint", target_joints=endpoint)]), cell).ok
    result = check_path(UR5, PathPlan(start, [PathSegment("swing", "joint", target_joints=end)]), cell)
    problems = only(result, "cell")
    assert problems and problems[0].step == "swing", result.summary()
    assert 'keep-out box "fixture"' in problems[0].message and "mm inside" in problems[0].message
    assert 0.3 < problems[0].fraction < 0.7


def test_movej_sweeping_below_the_floor_is_refused():
    # Upper arm from just above horizontal on one side, through hanging down, to the other side (the long way):
    # the elbow passes a_2 = 0.425 m below the shoulder (d1 = 0.089 m above the floor).
    start = np.array([0.0, -0.2, -1.2, 0.0, 1.5708, 0.0])
    end = start.copy()
    end[1] = math.pi + 0.2
    cell = cell_from_dict({"floor": {"z": 0.0}})
    result = check_path(UR5, PathPlan(start, [PathSegment("dive", "joint", target_joints=end)]), cell)
    floor = [p for p in only(result, "cell") if "the floor" in p.message]
    assert floor and floor[0].step == "dive", result.summary()
    assert 0.2 < floor[0].fraction < 0.8


def test_wrist_3_folded_onto_the_upper_arm_is_a_self_collision():
    # Upper arm up, elbow folded 150° so the forearm comes back down beside it, wrist 2 turning wrist 3 towards the
    # upper arm. Independently of the checker's kernels: with the model's own DH frames (dual quaternions), the
    # wrist 3 axis (frame 5 → flange) passes closer to the upper arm's axis (frame 1 → 2, at UR's 135.85 mm
    # shoulder offset) than the sum of the two tubes' radii (55 + 40 mm).
    q = np.radians([0.0, -90.0, 150.0, -20.0, -80.0, 0.0])
    frames = [DualQuaternion.from_array(f) for f in UR5.frames(q)]
    offset = 0.13585 * np.asarray(frames[1].rotation.rotate([0.0, 0.0, 1.0]))
    upper_arm = np.linspace(frames[1].translation + offset, frames[2].translation + offset, 400)
    wrist_3 = np.linspace(frames[5].translation, frames[6].translation, 100)
    gap = np.min(np.linalg.norm(upper_arm[:, None] - wrist_3[None], axis=2))
    assert gap < 0.055 + 0.040 - 0.01
    clear = np.radians([0.0, -90.0, 90.0, -90.0, -90.0, 0.0])
    result = check_path(UR5, PathPlan(clear, [PathSegment("fold", "joint", target_joints=q)]))
    problems = only(result, "self_collision")
    assert problems and problems[0].step == "fold", result.summary()
    assert problems[0].message.startswith("self-collision: upper arm capsule")
    assert "mm inside the wrist 3 capsule" in problems[0].message


@pytest.mark.parametrize("margin, refused", [(0.010, True), (0.002, False)])
def test_a_path_5_mm_from_a_box_is_refused_with_a_10_mm_margin_and_accepted_with_2_mm(margin, refused):
    # A tool capsule 0.1 m long, radius 0.02 m, pointing straight down: its lowest point is 0.12 m below the
    # flange along the whole (constant-orientation, horizontal) line. The box's top is 5 mm below that.
    flange = UR5.fk(DOWN)
    assert np.allclose(flange.rotation.rotate([0.0, 0.0, 1.0]), [0.0, 0.0, -1.0], atol=1e-4)
    x, y, z = flange.translation
    top = z - 0.12 - 0.005
    cell = cell_from_dict({"margin": margin, "boxes": [{"name": "table", "min": [x - 0.1, y - 0.1, top - 0.1],
                                                        "max": [x + 0.1, y + 0.2, top]}],
                           "tool": {"capsule": {"from": [0, 0, 0], "to": [0, 0, 0.1], "radius": 0.02}}})
    plan = PathPlan(DOWN, [PathSegment("glide", "linear", target_pose=shifted(UR5, DOWN, (0.0, 0.1, 0.0)),
                                       speed=0.1)])
    result = check_path(UR5, plan, cell)
    assert result.steps[0].margins["cell"] == pytest.approx(0.005 - margin, abs=1e-9)
    if refused:
        problem = only(result, "cell")[0]
        assert problem.step == "glide"
        assert 'tool capsule 5.0 mm from keep-out box "table" (margin 10 mm)' in problem.message
        assert not result.ok
    else:
        assert result.ok, result.summary()


def test_a_line_needing_more_than_the_joints_maximum_speed_names_the_joint_and_a_slower_speed():
    middle = np.array([0.0, -1.2, 1.5, -1.8, 0.08, 0.5])     # passes 4.6° from the wrist singularity
    z1 = np.array([0.0, -1.0, 0.0])
    start = UR5.ik(shifted(UR5, middle, -0.06 * z1), middle)
    plan = PathPlan(start, [PathSegment("fast", "linear", target_pose=shifted(UR5, middle, 0.06 * z1), speed=1.0)])
    result = check_path(UR5, plan)
    speed = only(result, "joint_speed")
    assert speed, result.summary()
    assert "rad/s at 1 m/s" in speed[0].message and "lower the step's speed to ≤" in speed[0].hint
    slower = float(speed[0].hint.split("≤ ")[1].split(" m/s")[0])
    again = PathPlan(start, [PathSegment("fast", "linear", target_pose=plan.segments[0].target_pose,
                                         speed=slower * 0.99)])
    assert not only(check_path(UR5, again), "joint_speed")


def test_margins_are_user_settable():
    middle = np.array([0.0, -1.2, 1.5, -1.8, 0.3, 0.5])      # |sin θ5| ≥ 0.29 along the line
    z1 = np.array([0.0, -1.0, 0.0])
    start = UR5.ik(shifted(UR5, middle, -0.02 * z1), middle)
    plan = PathPlan(start, [PathSegment("line", "linear", target_pose=shifted(UR5, middle, 0.02 * z1), speed=0.05)])
    assert not only(check_path(UR5, plan), "wrist")
    assert only(check_path(UR5, plan, margins=Margins(wrist=0.5)), "wrist")
    with pytest.raises(ValueError, match="wrist"):
        Margins(wrist=-1)


def test_a_blend_zone_raises_the_clearance_margin_by_the_blend_radius():
    # The tool passes 5 mm over a box only near the corner between two lines; with a 20 mm blend there the
    # controller's rounded path may cut the corner, so the 2 mm margin becomes 22 mm inside the blend zone.
    flange = UR5.fk(DOWN)
    x, y, z = flange.translation
    top = z - 0.12 - 0.005
    corner = shifted(UR5, DOWN, (0.0, 0.08, 0.0))
    cell = {"margin": 0.002, "boxes": [{"name": "post", "min": [x - 0.02, y + 0.06, top - 0.1],
                                        "max": [x + 0.02, y + 0.1, top]}],
            "tool": {"capsule": {"from": [0, 0, 0], "to": [0, 0, 0.1], "radius": 0.02}}}
    segments = [PathSegment("in", "linear", target_pose=corner, speed=0.1),
                PathSegment("out", "linear", target_pose=shifted(UR5, DOWN, (0.08, 0.08, 0.05)), speed=0.1)]
    assert check_path(UR5, PathPlan(DOWN, segments), cell_from_dict(cell)).ok
    blended = [PathSegment("in", "linear", target_pose=corner, speed=0.1, blend=0.02), segments[1]]
    result = check_path(UR5, PathPlan(DOWN, blended), cell_from_dict(cell))
    problem = only(result, "cell")[0]
    assert problem.step == "in" and "(margin 2 mm + blend 20 mm)" in problem.message
    too_big = [PathSegment("in", "linear", target_pose=corner, speed=0.1, blend=0.05), segments[1]]
    blend = only(check_path(UR5, PathPlan(DOWN, too_big)), "blend")
    assert blend and "more than half" in blend[0].message


def test_a_line_ending_on_another_branch_than_planned_is_reported_and_later_steps_start_where_it_ended():
    target = shifted(UR5, DOWN, (0.0, 0.1, 0.0))
    reached = UR5.ik(target, DOWN)
    elsewhere = [s for s in UR5.ik_all(target) if np.max(np.abs(np.angle(np.exp(1j * (s - reached))))) > 0.5][0]
    plan = PathPlan(DOWN, [PathSegment("line", "linear", target_joints=elsewhere, target_pose=target, speed=0.1),
                           PathSegment("back", "joint", target_joints=DOWN)])
    result = check_path(UR5, plan)
    branch = only(result, "branch")
    assert branch and branch[0].step == "line" and "another IK branch" in branch[0].message
    assert np.allclose(result.steps[1].joints[0], reached, atol=1e-6)


def test_after_an_unreachable_line_without_planned_joints_the_rest_is_unchecked():
    q = np.array([0.0, -1.2, 1.2, -1.5708, -1.5708, 0.0])
    plan = PathPlan(q, [PathSegment("out", "linear", target_pose=shifted(UR5, q, (-0.8, 0, 0))),
                        PathSegment("next", "joint", target_joints=q, blend=0.01),
                        PathSegment("last", "linear", target_pose=shifted(UR5, q, (0, 0.1, 0)))])
    result = check_path(UR5, plan)
    assert not result.ok and result.unchecked == ("next", "last")
    assert [step.name for step in result.steps] == ["out"]
