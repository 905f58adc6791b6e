"""Fixtures of the driver tests: both backends, a simulated arm, a connected Robot at HOME.

The simulator runs in its own process (`simulator_process`): ur_rtde's RTDEReceiveInterface constructor blocks
without releasing the GIL, so it deadlocks against a simulator served by threads of the same interpreter.
Faults are injected through the simulator's control channel; the arm is powered through the driver (dashboard).
"""
import json
import os
import tempfile

import numpy as np
import pytest

import ur3dq.robot

BACKENDS = ["rtde", "urx"]
# A comfortable UR3 configuration away from singularities and joint limits.
HOME = np.array([0.0, -1.5707963267948966, 1.2, -1.2, -1.5707963267948966, 0.0])


def external_robot_host():
    """The official URSim / robot named by UR3DQ_TEST_HOST (tests/conftest.py's rule), or None."""
    return os.environ.get("UR3DQ_TEST_HOST") or None


def inject(host, command, **arguments):
    """Send one fault-control request to the simulator at `host`; AssertionError if it is refused."""
    from sim_ursim.control_channel import send_request

    reply = send_request(host, command, **arguments)
    assert reply["ok"], reply
    return reply["message"]


def simulator_with(calibration=None, **options):
    """A context manager running `python -m sim_ursim` (UR3) with an optional DH calibration (deltas dict)."""
    from sim_ursim.testing import simulator_process

    if calibration is None:
        return simulator_process(model="ur3", **options)
    handle, path = tempfile.mkstemp(prefix="ur3dq-calibration-", suffix=".json")
    with os.fdopen(handle, "w") as calibration_file:
        json.dump(calibration, calibration_file)
    return _removing(path, simulator_process(model="ur3", extra_args=("--calibration", path), **options))


class _removing:
    """Wraps a context manager and removes `path` when it exits."""

    def __init__(self, path, inner):
        self.path, self.inner = path, inner

    def __enter__(self):
        return self.inner.__enter__()

    def __exit__(self, *exc_info):
        try:
            return self.inner.__exit__(*exc_info)
        finally:
            os.remove(self.path)


def ready(robot):
    """Power the arm and release its brakes through the driver if needed, then move it to HOME."""
    if robot.state().robot_mode != 7:
        robot.power_on()
        robot.brake_release()
    robot.movej(HOME)
    return robot


@pytest.fixture(params=BACKENDS)
def backend(request):
    """Each driver backend in turn: the same behavioural tests run on both."""
    return request.param


@pytest.fixture
def sim_host():
    """The host of a fresh simulator process (sim_ursim only)."""
    with simulator_with() as simulator:
        yield simulator.host


@pytest.fixture
def arm_host():
    """UR3DQ_TEST_HOST if set, else a fresh simulator process's host."""
    host = external_robot_host()
    if host is not None:
        yield host
        return
    with simulator_with() as simulator:
        yield simulator.host


@pytest.fixture
def robot(arm_host, backend):
    """A Robot on the arm, powered, at HOME; closed after the test."""
    with ur3dq.robot.connect(arm_host, backend=backend) as connected:
        yield ready(connected)


@pytest.fixture
def sim_robot(sim_host, backend):
    """(simulator host, Robot at HOME) for fault-injection tests (sim_ursim only)."""
    with ur3dq.robot.connect(sim_host, backend=backend) as connected:
        yield sim_host, ready(connected)


@pytest.fixture
def home():
    """The HOME joint configuration the `robot` and `sim_robot` fixtures start from (copy)."""
    return HOME.copy()
