"""The driver reads the controller's calibrated DH, so its FK matches the controller's TCP on a non-nominal arm."""
import numpy as np
import pytest

import ur3dq.robot
from robot_target import simulator_only
from robot_test_support import ready, simulator_with
from ur3dq.kinematics import robot_model

pytestmark = simulator_only("injecting a non-nominal calibration")

# Deltas of the size a real arm's calibration shows (millimetres, milliradians).
CALIBRATION = {
    "a": [0.0, 0.0021, -0.0017, 0.0, 0.0, 0.0],
    "d": [0.0012, 0.0, 0.0, -0.0009, 0.0006, 0.0004],
    "alpha": [0.0008, -0.0004, 0.0005, 0.0, 0.0003, 0.0],
    "theta": [0.0, 0.0015, -0.002, 0.001, 0.0, 0.0025],
}
CONFIGURATIONS = [
    [0.0, -1.5707963267948966, 1.2, -1.2, -1.5707963267948966, 0.0],
    [0.4, -1.2, 1.5, -1.9, -1.2, 0.7],
    [-0.6, -1.9, 0.8, -0.4, -1.9, -0.5],
]


@pytest.fixture(scope="module")
def calibrated_host():
    with simulator_with(calibration=CALIBRATION, initial_q=CONFIGURATIONS[0]) as simulator:
        yield simulator.host


@pytest.mark.parametrize("backend", ["rtde", "urx"])
def test_calibrated_fk_matches_the_controller_where_nominal_does_not(calibrated_host, backend, record_property):
    nominal = robot_model("ur3")
    with ur3dq.robot.connect(calibrated_host, backend=backend) as robot:
        ready(robot)
        for key, deltas in CALIBRATION.items():
            assert np.allclose(getattr(robot.model.dh, key) - getattr(nominal.dh, key), deltas, atol=1e-12)
        nominal_errors = []
        for q in CONFIGURATIONS:
            robot.movej(q)
            joints, reported = robot.joints(), robot.tcp_pose()
            calibrated_m, calibrated_rad = robot.model.fk(joints).distance(reported)
            assert calibrated_m < 1e-6 and calibrated_rad < 1e-6
            nominal_errors.append(nominal.fk(joints).distance(reported)[0])
        worst_mm = max(nominal_errors) * 1000
        record_property("nominal_vs_calibrated_mm", worst_mm)
        print(f"nominal-vs-calibrated TCP difference avoided: up to {worst_mm:.2f} mm")
        assert worst_mm > 1.0


FACTORY_TARGETS = [
    [0.3, -1.4, 1.3, -1.5, -1.3, 0.4],
    [-0.5, -1.8, 1.0, -0.7, -1.8, -0.6],
]


def test_factory_calibrated_controller_table_gives_exact_fk_and_ik():
    """A controller reporting a factory-style table (hundreds of metres of cancelling d offsets on the parallel
    joints, like UR's documented UR10e table): the driver's model matches the controller's TCP and its IK drives
    the arm to a pose exactly (on today's nominal-seeded IK this table gave 'unreachable' or wrong branches)."""
    with simulator_with(model="ur5e", extra_args=("--calibration", "factory:7"),
                        initial_q=CONFIGURATIONS[0]) as simulator:
        with ur3dq.robot.connect(simulator.host) as robot:
            ready(robot)
            assert abs(robot.model.dh.d[1]) > 10.0 and abs(robot.model.dh.d[2]) > 10.0   # factory form
            for q in FACTORY_TARGETS:
                target = robot.model.fk(q)
                robot.movej_pose(target)
                joints, reported = robot.joints(), robot.tcp_pose()
                assert np.max(np.abs(joints - q)) < 1e-6
                metres, radians = robot.model.fk(joints).distance(reported)
                assert metres < 1e-6 and radians < 1e-6
                assert target.distance(reported)[0] < 1e-5
