"""The state model's decoders and the dashboard reply interpretation."""
import numpy as np
import pytest

from ur3dq.errors import RobotError
from ur3dq.robot import state
from ur3dq.robot.dashboard import model_from_reply, serial_from_reply, unlock_refusal


def status(joints, speeds=(0,) * 6):
    return state.RobotStatus(np.array(joints, float), np.array(speeds, float), np.zeros(6), 7, 1, False, False,
                             False, 1.0, 1.0, 0.0)


def test_mode_names():
    assert state.robot_mode_name(7) == "RUNNING" and state.safety_mode_name(3) == "PROTECTIVE_STOP"
    assert state.robot_mode_name(42) == "UNKNOWN(42)"
    assert status([0] * 6).robot_mode_name == "RUNNING" and status([0] * 6).safety_mode_name == "NORMAL"


def test_program_running_from_runtime_state_or_status_bit():
    assert state.program_running_from(2, 0) and state.program_running_from(1, 0b10)
    assert not state.program_running_from(1, 0b01)


def test_stop_flags_from_bits_or_mode():
    assert state.protective_stopped_from(1 << 2, 1) and state.protective_stopped_from(0, 3)
    assert not state.protective_stopped_from(1, 1)
    assert state.emergency_stopped_from(1 << 7, 1) and state.emergency_stopped_from(0, 7)
    assert not state.emergency_stopped_from(1 << 2, 3)


def test_at_rest_at():
    target = [0.1] * 6
    assert state.at_rest_at(status(target), target)
    assert not state.at_rest_at(status([0.1] * 5 + [0.11]), target)
    assert not state.at_rest_at(status(target, speeds=[0, 0, 0.1, 0, 0, 0]), target)


@pytest.mark.parametrize("reply, major, name", [("UR3", 3, "ur3"), ("UR3", 5, "ur3e"), ("UR16", 5, "ur16e"),
                                                ("UR5e", 5, "ur5e"), (" UR10\r", 3, "ur10")])
def test_model_from_dashboard_reply(reply, major, name):
    assert model_from_reply(reply, major) == name


def test_model_from_an_unexpected_reply():
    with pytest.raises(RobotError, match="not a UR model"):
        model_from_reply("could not understand: 'get robot model'", 3)


def test_unlock_refusal():
    assert unlock_refusal("Protective stop releasing") is None
    assert "5s" in unlock_refusal("Cannot unlock protective stop until 5s after occurrence.")


@pytest.mark.parametrize("reply, serial", [
    ("20235500001", "20235500001"),
    ("20235500001\r", "20235500001"),
    ("could not understand: 'get serial number'", None),
    ("", None),
])
def test_serial_from_reply(reply, serial):
    assert serial_from_reply(reply) == serial
