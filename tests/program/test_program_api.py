"""The Python API of cell programs: one call to check a program offline, and the errors and inputs the README's
tour shows (a DualQuaternion where a pose goes)."""
import json

import numpy as np
import pytest

import ur3dq
from ur3dq import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import Box, Cell, PathPlan, PathSegment, check_path
from ur3dq.pose import Pose
from ur3dq.program.steps import DEFAULT_MOTION, DigitalOut, Motion, RelativeWaypoint, Wait, Waypoint

MODEL = robot_model("ur3")
Q_PICK = np.array([0.3, -1.2, 1.4, -1.8, -1.5708, 0.2])
Q_PLACE = Q_PICK + np.array([0.6, 0.1, -0.1, 0.0, 0.0, 0.3])


def waypoint(name, joints, motion=DEFAULT_MOTION):
    return Waypoint(name, Pose.from_dual_quaternion(name, MODEL.fk(joints), "ur3", joints=tuple(joints)), motion)


PROGRAM = [RelativeWaypoint("approach", "pick", (0, 0, -0.05, 0, 0, 0)), waypoint("pick", Q_PICK, Motion("linear")),
           DigitalOut("grip", "tool", 0, True), Wait("settle", 0.2),
           RelativeWaypoint("retract", "pick", (0, 0, -0.05, 0, 0, 0), motion=Motion("linear")),
           waypoint("place", Q_PLACE)]


def test_check_program_is_one_call_and_finds_a_box_in_the_way(tmp_path):
    clear = ur3dq.check_program(PROGRAM, "ur3")
    assert clear.ok, clear.summary()
    assert [step.name for step in clear.steps] == ["approach", "pick", "retract", "place"]
    tcp = MODEL.fk(Q_PICK).translation   # a fixture around the pick point: the linear descent ends inside it
    fixture = Box("fixture", tcp - 0.02, tcp + 0.02)
    blocked = ur3dq.check_program(PROGRAM, MODEL, Cell(boxes=(fixture,)))
    assert not blocked.ok and "fixture" in blocked.summary()
    cell_file = tmp_path / "cell.json"
    cell_file.write_text(json.dumps({"boxes": [{"name": "fixture", "min": fixture.lo.tolist(),
                                                "max": fixture.hi.tolist()}]}))
    assert ur3dq.check_program(PROGRAM, "ur3", cell_file).summary() == blocked.summary()


def test_check_program_from_where_the_arm_is_checks_the_first_move_too():
    start = Q_PICK + np.array([0.0, 0.4, -0.6, 0.0, 0.0, 0.0])
    tcp = MODEL.fk(start).translation   # a box around where the arm starts: only the move from there meets it
    cell = Cell(boxes=(Box("bin", tcp - 0.03, tcp + 0.03),))
    assert ur3dq.check_program(PROGRAM, MODEL, cell).ok
    from_start = ur3dq.check_program(PROGRAM, MODEL, cell, start_joints=start)
    assert not from_start.ok and from_start.problems[0].step == "approach"
    with pytest.raises(ValueError, match="no waypoint"):
        ur3dq.check_program([Wait("only", 1.0)], MODEL)


def test_a_path_segment_takes_a_dual_quaternion_as_its_docstring_shows():
    sigma = MODEL.fk(Q_PICK)
    from_dq = PathSegment("pick", "linear", target_pose=sigma, speed=0.1)
    from_array = PathSegment("pick", "linear", target_pose=sigma.to_array(), speed=0.1)
    np.testing.assert_array_equal(from_dq.target_pose, from_array.target_pose)
    start = Q_PICK + np.array([0, 0, 0.05, 0, 0, 0])
    assert check_path(MODEL, PathPlan(start, [from_dq])).ok


def test_a_waypoint_given_a_dual_quaternion_says_it_got_the_wrong_type():
    with pytest.raises(ValueError, match=r"needs a recorded pose \(ur3dq.pose.Pose\), got DualQuaternion: wrap it "
                                         r"as Pose.from_dual_quaternion\('pick'"):
        Waypoint("pick", DualQuaternion.identity())
