"""Helpers of the driver tests (a module name of its own, so test files can import it next to conftest.py)."""
import json
import os
import tempfile

import numpy as np

BACKENDS = ["rtde", "urx"]
# A comfortable UR3 configuration away from singularities and joint limits.
HOME = np.array([0.0, -1.5707963267948966, 1.2, -1.2, -1.5707963267948966, 0.0])


def inject(host, command, **arguments):
    """Send one fault-control request to the simulator at `host`; AssertionError if it is refused."""
    from sim_ursim.control_channel import send_request

    reply = send_request(host, command, **arguments)
    assert reply["ok"], reply
    return reply["message"]


def simulator_state(host):
    """The simulator's own view (not the driver's), from its control channel: {"program_running": bool, "q": [6
    floats], "robot_mode": name, "safety_mode": name}."""
    from sim_ursim.control_channel import send_request

    reply = send_request(host, "status")
    assert reply["ok"], reply
    return reply["state"]


def simulator_with(calibration=None, model="ur3", **options):
    """A context manager running `python -m sim_ursim` (UR3 by default) with an optional DH calibration (deltas)."""
    from sim_ursim.launch import simulator_process

    if calibration is None:
        return simulator_process(model=model, **options)
    handle, path = tempfile.mkstemp(prefix="ur3dq-calibration-", suffix=".json")
    with os.fdopen(handle, "w") as calibration_file:
        json.dump(calibration, calibration_file)
    return _removing(path, simulator_process(model=model, extra_args=("--calibration", path), **options))


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


def set_speed_slider(host, fraction):
    """Move the speed slider as the operator does on the pendant (the simulator's control channel). Not through RTDE
    inputs: the driver under test holds them for its heartbeat (ur3dq.robot.heartbeat); ur_rtde's RTDEIOInterface
    writing the slider is tested on its own in tests/sim_ursim/test_rtde_ur_rtde.py."""
    inject(host, "speed-slider", fraction=fraction)

