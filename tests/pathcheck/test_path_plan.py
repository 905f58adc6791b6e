"""The path check's input (ur3dq/pathcheck/path_plan.py): PathSegment.joint_targets builds many segments at once,
equal to those built one at a time, and refuses the same faults with the same messages; values no cell can hold
are refused at once, and a move too long to sample is a problem, not an exception."""
import math
import time

import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import Margins, PathPlan, PathSegment, check_path

FIELDS = ("name", "move", "target_joints", "target_pose", "speed", "acceleration", "blend", "tcp_offset")


def columns(count, seed=3):
    rng = np.random.default_rng(seed)
    tcp = (0.0, 0.0, 0.1, 0.0, 0.0, 0.0)
    return ([f"p{i}" for i in range(count)], [("joint", "linear", "process")[i % 3] for i in range(count)],
            rng.uniform(-6, 6, (count, 6)), rng.uniform(0.1, 1, count).tolist(), rng.uniform(0.5, 2, count).tolist(),
            [0.0 if i % 2 else 0.01 for i in range(count)], [None if i % 4 else tcp for i in range(count)])


def one_at_a_time(names, moves, targets, speeds, accelerations, blends, offsets):
    return [PathSegment(n, m, target_joints=t, speed=v, acceleration=a, blend=b, tcp_offset=o)
            for n, m, t, v, a, b, o in zip(names, moves, targets, speeds, accelerations, blends, offsets, strict=True)]


def test_many_segments_at_once_equal_those_built_one_at_a_time():
    fields = columns(40)
    many, single = PathSegment.joint_targets(*fields), one_at_a_time(*fields)
    assert len(many) == len(single) == 40
    for a, b in zip(many, single, strict=True):
        for field in FIELDS:
            x, y = getattr(a, field), getattr(b, field)
            if isinstance(y, np.ndarray):
                assert np.array_equal(x, y) and not x.flags.writeable
            else:
                assert x == y and type(x) is type(y), field
    assert PathSegment.joint_targets([], [], np.zeros((0, 6)), [], [], [], []) == []


@pytest.mark.parametrize("column, value", [(0, ""), (1, "circular"), (2, [0, 0, math.nan, 0, 0, 0]), (3, 0.0),
                                           (4, math.inf), (5, -0.01), (6, (0, 0, 0.1))])
def test_a_fault_is_refused_with_the_one_at_a_time_message(column, value):
    fields = [list(part) for part in columns(6)]
    fields[column][4] = value
    with pytest.raises(ValueError) as single:
        one_at_a_time(*fields)
    with pytest.raises(ValueError, match="'p4'" if column else None) as many:
        PathSegment.joint_targets(*fields)
    assert str(many.value) == str(single.value)


# --------------------------------------------------------------------------------- values no cell can hold
UR3 = robot_model("ur3")
POSE = UR3.fk([0.1, -1.0, 1.0, 0.2, 0.3, 0.4]).to_array()


@pytest.mark.parametrize("fields, message", [
    (dict(target_joints=[1e17] * 6), r"joints must lie within ±100 rad"),
    (dict(target_joints=[0.0, 0.0, 0.0, 0.0, 0.0, 1e6]), r"joints must lie within ±100 rad.*1e\+06"),
    (dict(move="linear", target_pose=2.0 * POSE), r"pose: not a unit dual quaternion \(\|real\| differs"),
    (dict(move="linear", target_pose=POSE + [0, 0, 0, 0, 0.1, 0, 0, 0]),
     r"pose: not a unit dual quaternion \(real·dual"),
    (dict(target_joints=[0.0] * 6, tcp_offset=[1e300, 0, 0, 0, 0, 0]), r"tcp_offset 1e\+300 m is beyond ±100 m"),
    (dict(target_joints=[0.0] * 6, tcp_offset=[0, 0, 0.1, 1e20, 0, 0]), r"tcp_offset 1e\+20 rad is beyond ±100 rad"),
], ids=["1e17-rad", "1e6-rad", "scaled-pose", "non-rigid-pose", "1e300-m-tcp", "1e20-rad-tcp"])
def test_values_no_cell_holds_are_refused_naming_the_segment(fields, message):
    started = time.process_time()
    with pytest.raises(ValueError, match=rf"^segment 'far': {message}"):
        PathSegment("far", **fields)
    assert time.process_time() - started < 0.5


def test_a_pose_within_rounding_of_unit_is_normalised_as_the_ik_takes_it():
    segment = PathSegment("near", "linear", target_pose=POSE * (1.0 + 1e-7))
    np.testing.assert_allclose(segment.target_pose, POSE, rtol=0, atol=1e-15)


def test_many_segments_at_once_refuse_a_far_joint_value_as_one_at_a_time():
    fields = [list(part) for part in columns(6)]
    fields[2][4] = [0.0, 0.0, 0.0, 0.0, 0.0, 101.0]
    with pytest.raises(ValueError, match="^segment 'p4': joints must lie within") as many:
        PathSegment.joint_targets(*fields)
    with pytest.raises(ValueError) as single:
        one_at_a_time(*fields)
    assert str(many.value) == str(single.value)
    with pytest.raises(ValueError, match="^segment 'start': joints must lie within"):
        PathPlan([0.0, 0.0, 0.0, 0.0, 0.0, -200.0], [PathSegment("a", target_joints=[0.0] * 6)])


@pytest.mark.parametrize("keep_samples", [True, False])
def test_a_move_too_long_to_sample_is_reported_fast_never_raised(keep_samples):
    """A UR3's wrist 3 turns without limit: 100 rad there at a 1e-5 rad resolution asks 1e7 samples (unless the
    clearance bounds certify the move without samples), a 90 rad base target lies outside its limit, and the move
    back from there is as long: each is one problem at once."""
    plan = PathPlan([0.0, -1.5, 1.0, -1.0, -1.5, 0.0], [
        PathSegment("spin", target_joints=[0.0, -1.5, 1.0, -1.0, -1.5, 100.0]),
        PathSegment("base", target_joints=[90.0, -1.5, 1.0, -1.0, -1.5, 0.0]),
        PathSegment("back", target_joints=[0.1, -1.5, 1.0, -1.0, -1.5, 0.0]),
    ])
    started = time.process_time()
    result = check_path(UR3, plan, margins=Margins(joint_resolution=1e-5), keep_samples=keep_samples)
    assert time.process_time() - started < 10.0
    checks = {(problem.step, problem.check) for problem in result.problems}
    assert ("base", "joint_limit") in checks and ("back", "sampling") in checks
    assert ("spin", "sampling") in checks or not keep_samples
    base = next(problem for problem in result.problems if problem.step == "base")
    assert "joint 1 (base) at 90 rad lies outside its limits" in base.message
