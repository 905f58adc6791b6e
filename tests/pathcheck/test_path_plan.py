"""The path check's input (ur3dq/pathcheck/path_plan.py): PathSegment.joint_targets builds many segments at once,
equal to those built one at a time, and refuses the same faults with the same messages."""
import math

import numpy as np
import pytest

from ur3dq.pathcheck import PathSegment

FIELDS = ("name", "move", "target_joints", "target_pose", "speed", "acceleration", "blend", "tcp_offset")


def columns(count, seed=3):
    rng = np.random.default_rng(seed)
    tcp = (0.0, 0.0, 0.1, 0.0, 0.0, 0.0)
    return ([f"p{i}" for i in range(count)], [("joint", "linear", "process")[i % 3] for i in range(count)],
            rng.uniform(-6, 6, (count, 6)), rng.uniform(0.1, 1, count).tolist(), rng.uniform(0.5, 2, count).tolist(),
            [0.0 if i % 2 else 0.01 for i in range(count)], [None if i % 4 else tcp for i in range(count)])


def one_at_a_time(names, moves, targets, speeds, accelerations, blends, offsets):
    return [PathSegment(n, m, target_joints=t, speed=v, acceleration=a, blend=b, tcp_offset=o)
            for n, m, t, v, a, b, o in zip(names, moves, targets, speeds, accelerations, blends, offsets)]


def test_many_segments_at_once_equal_those_built_one_at_a_time():
    fields = columns(40)
    many, single = PathSegment.joint_targets(*fields), one_at_a_time(*fields)
    assert len(many) == len(single) == 40
    for a, b in zip(many, single):
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
