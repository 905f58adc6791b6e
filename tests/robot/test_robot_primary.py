"""Primary-interface parsing from bytes laid out as UR's guide describes (built here with struct)."""
import math
import struct

import pytest

from ur3dq.robot import primary

UR3_A = [0, -0.24365, -0.21325, 0, 0, 0]
UR3_D = [0.1519, 0, 0, 0.11235, 0.08535, 0.0819]
UR3_ALPHA = [math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2, 0]


def frame(message_type, body):
    return struct.pack(">iB", len(body) + 5, message_type) + body


def robot_mode_body(protective=False, running=True, mode=7, fraction=0.5, scaling=1.0, size=47):
    body = struct.pack(">Q???????BBdd", 123, True, True, True, False, protective, running, False, mode, 0,
                       fraction, scaling)
    if size >= 46:
        body += struct.pack(">d", 1.0)
    if size >= 47:
        body += b"\x00"
    return body


def kinematics_body(theta, a, d, alpha):
    return struct.pack(">6I", *[0xFFFFFFFF] * 6) + struct.pack(">24d", *theta, *a, *d, *alpha) + struct.pack(">I", 0)


def configuration_body(robot_type=3):
    body = b"".join(struct.pack(">dd", -6.28, 6.28) for _ in range(6))
    body += b"".join(struct.pack(">dd", 3.14, 40.0) for _ in range(6))
    body += struct.pack(">5d", 1.0472, 1.3963, 0.25, 1.2, 0.25)
    body += struct.pack(">24d", *UR3_A, *UR3_D, *UR3_ALPHA, *[0.0] * 6)
    return body + struct.pack(">4i", 6, 4, robot_type, 3)


def masterboard_body(safety_mode):
    return struct.pack(">iiBBddbbddffffBBb", 0, 0, 0, 0, 0.0, 0.0, 0, 0, 0.0, 0.0, 30.0, 48.0, 1.0, 0.0,
                       safety_mode, 0, 0) + struct.pack(">IBB", 0, 0, 0)


def robot_message(message_type, data, source=-2):
    return frame(primary.ROBOT_MESSAGE, struct.pack(">Qbb", 99, source, message_type) + data)


def test_split_messages_keeps_an_incomplete_tail():
    first = frame(16, b"abc")
    second = frame(20, b"defgh")
    messages, tail = primary.split_messages(first + second[:4])
    assert messages == [(16, b"abc")] and tail == second[:4]
    messages, tail = primary.split_messages(tail + second[4:])
    assert messages == [(20, b"defgh")] and tail == b""


def test_split_messages_rejects_an_impossible_size():
    with pytest.raises(primary.PrimaryParseError, match="out of step"):
        primary.split_messages(struct.pack(">iB", 2, 16))


def test_robot_state_with_every_used_subpackage():
    theta = [0.001, -0.002, 0, 0, 0, 0.003]
    a = [0.0001 + x for x in UR3_A]
    body = (frame(primary.ROBOT_MODE_DATA, robot_mode_body(protective=True))
            + frame(1, b"\x00" * 246)  # joint data: skipped
            + frame(primary.CARTESIAN_INFO, struct.pack(">12d", *range(12)))
            + frame(primary.KINEMATICS_INFO, kinematics_body(theta, a, UR3_D, UR3_ALPHA))
            + frame(primary.MASTERBOARD_DATA, masterboard_body(3))
            + frame(primary.CONFIGURATION_DATA, configuration_body()))
    messages, _ = primary.split_messages(frame(primary.ROBOT_STATE, body))
    state = primary.parse_robot_state(messages[0][1])
    assert state.robot_mode.protective_stopped and state.robot_mode.program_running
    assert state.robot_mode.robot_mode == 7 and state.robot_mode.target_speed_fraction == 0.5
    assert state.safety_mode == 3
    assert state.cartesian.tcp_pose.tolist() == [0, 1, 2, 3, 4, 5]
    assert state.cartesian.tcp_offset.tolist() == [6, 7, 8, 9, 10, 11]
    assert state.kinematics.theta.tolist() == theta and state.kinematics.a.tolist() == a
    assert state.kinematics.d.tolist() == UR3_D and state.kinematics.alpha.tolist() == UR3_ALPHA
    assert state.kinematics.calibration_status == 0
    config = state.configuration
    assert config.robot_type == 3 and config.joint_max.tolist() == [6.28] * 6
    assert config.max_joint_speed.tolist() == [3.14] * 6 and config.max_joint_acceleration.tolist() == [40.0] * 6
    assert config.dh_d.tolist() == UR3_D and config.v_joint_default == 1.0472


@pytest.mark.parametrize("size", [38, 46, 47])
def test_robot_mode_data_of_each_3x_layout(size):
    body = robot_mode_body(scaling=0.25, size=size)
    if size == 38:
        body = body[:33]
    data = primary.parse_robot_mode_data(body)
    assert data.power_on and data.robot_mode == 7 and data.speed_scaling == 0.25


def test_truncated_subpackage_is_an_error():
    with pytest.raises(primary.PrimaryParseError, match="Kinematics Info"):
        primary.parse_robot_state(frame(primary.KINEMATICS_INFO, b"\x00" * 100))


def test_version_message_3_12_and_later():
    data = struct.pack(">b", 9) + b"URControl" + struct.pack(">BBii", 3, 15, 7, 106339) + b"20-06-2022, 10:00:00"
    messages, _ = primary.split_messages(robot_message(primary.VERSION_MESSAGE, data))
    version = primary.parse_robot_message(messages[0][1])
    assert (version.project_name, version.major, version.minor, version.bugfix, version.build) == (
        "URControl", 3, 15, 7, 106339)
    assert version.build_date == "20-06-2022, 10:00:00"


def test_version_message_before_3_12_has_one_revision_number():
    data = struct.pack(">b", 9) + b"URControl" + struct.pack(">BBi", 3, 4, 55555) + b"01-01-2017"
    version = primary.parse_version_message(data)
    assert (version.major, version.minor, version.bugfix, version.build, version.build_date) == (
        3, 4, 0, 55555, "01-01-2017")


def test_key_messages_for_a_named_program():
    title = b"PROGRAM_XXX_STARTED"
    data = struct.pack(">iiB", 0, 0, len(title)) + title + b"ur3dq_move_7"
    message = primary.parse_robot_message(primary.split_messages(robot_message(primary.KEY_MESSAGE, data))[0][0][1])
    assert primary.is_program_started(message, "ur3dq_move_7")
    assert not primary.is_program_started(message, "ur3dq_move_70")
    assert not primary.is_program_stopped(message, "ur3dq_move_7")


def test_runtime_exception_error_code_text_and_safety_messages():
    def parse(kind, data):
        return primary.parse_robot_message(primary.split_messages(robot_message(kind, data))[0][0][1])

    runtime = parse(primary.RUNTIME_EXCEPTION_MESSAGE, struct.pack(">II", 3, 5) + b"compile_error_name_not_found:x:")
    assert (runtime.line, runtime.column, runtime.text) == (3, 5, "compile_error_name_not_found:x:")
    error = parse(primary.ERROR_CODE_MESSAGE, struct.pack(">iiiII", 210, 0, 4, 0, 0) + b"refused")
    assert (error.code, error.report_level, error.text) == (210, 4, "refused")
    assert parse(primary.TEXT_MESSAGE, b"hello").text == "hello"
    assert parse(primary.SAFETY_MODE_MESSAGE, struct.pack(">iiBII", 1, 0, 3, 0, 0)).safety_mode == 3
    assert parse(2, b"\x00\x00\x01T") is None  # popups are not used by the driver


def test_model_name():
    assert primary.model_name(3, 3) == "ur3" and primary.model_name(3, 5) == "ur3e"
    assert primary.model_name(1, 5) == "ur5e" and primary.model_name(4, 5) == "ur16e"
    with pytest.raises(ValueError, match="robot type 9"):
        primary.model_name(9, 5)
