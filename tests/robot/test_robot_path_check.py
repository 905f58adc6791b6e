"""Issue 13: a Robot can require the whole-path check before every motion — movej, movej_path, a cell program —
and then refuses (nothing sent, the arm stays) a path that sweeps through the cell's box although both ends are
clear of it, while a clear path still moves."""
import numpy as np
import pytest

import ur3dq.program
import ur3dq.robot
from robot_test_support import HOME, ready
from ur3dq.errors import SafetyCheckError
from ur3dq.pathcheck import cell_from_dict
from ur3dq.pose import Pose
from ur3dq.program.steps import Motion, Waypoint

# The base turns 1.2 rad from HOME; a box where the TCP passes at half way, far (> 0.1 m) from both ends.
SWEPT = HOME + np.array([1.2, 0, 0, 0, 0, 0])
CLEAR = HOME + np.array([0.0, 0.1, -0.1, 0.0, 0.0, 0.2])


def cell_across_the_sweep(model):
    middle = model.fk(HOME + np.array([0.6, 0, 0, 0, 0, 0])).translation
    return cell_from_dict({"boxes": [{"name": "fixture", "min": list(middle - 0.03), "max": list(middle + 0.03)}],
                           "margin": 0.01})


@pytest.fixture
def checked_robot(arm_host, backend, module_robot):
    """A second connection to the module's arm (at HOME) that requires the path check in the cell."""
    ready(module_robot)
    with ur3dq.robot.connect(arm_host, backend=backend, heartbeat=False) as robot:
        robot.require_path_check(cell_across_the_sweep(robot.model))
        yield robot


def test_a_movej_through_a_box_is_refused_and_nothing_moves(checked_robot):
    model = checked_robot.model
    for ends in (SWEPT, HOME):   # both ends are clear of the box: only the sweep between them is not
        distance = np.abs(model.fk(ends).translation - model.fk(HOME + [0.6, 0, 0, 0, 0, 0]).translation)
        assert distance.max() > 0.1
    with pytest.raises(SafetyCheckError, match=r'path check: step .targets\[0\]. at .*keep-out box "fixture"'):
        checked_robot.movej(SWEPT)
    with pytest.raises(SafetyCheckError, match='keep-out box "fixture"'):
        checked_robot.movej_path([CLEAR, SWEPT], blend=0.01)
    assert np.allclose(checked_robot.joints(), HOME, atol=1e-6)
    checked_robot.movej(CLEAR)   # a clear path still moves
    assert np.allclose(checked_robot.joints(), CLEAR, atol=1e-4)


def test_a_cell_program_through_the_box_is_refused_and_a_script_without_a_path_too(checked_robot):
    model = checked_robot.model
    pose = Pose.from_dual_quaternion("swept", model.fk(SWEPT), "ur3", joints=tuple(SWEPT))
    with pytest.raises(SafetyCheckError, match=r"""path check: step 'swept' at .*keep-out box "fixture\""""):
        ur3dq.program.run(checked_robot, [Waypoint("swept", pose, Motion("joint", 0.5))])
    with pytest.raises(SafetyCheckError, match="requires a path check before every motion"):
        checked_robot.run_script("bare", "def bare():\n  movej([0,0,0,0,0,0])\nend\n", HOME, 1.0)
    assert np.allclose(checked_robot.joints(), HOME, atol=1e-6)


def test_without_the_requirement_the_same_sweep_runs(robot):
    assert robot.movej(SWEPT) > 0    # the box is only the checked robot's cell: this proves the path is reachable
    assert np.allclose(robot.joints(), SWEPT, atol=1e-4)
