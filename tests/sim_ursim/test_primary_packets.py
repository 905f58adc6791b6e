"""Primary/secondary interface bytes, parsed by an independent parser: urx 0.11's own ParserUtils, and struct
layouts written here from the URCL / docs/protocols.md §3 tables (not from sim_ursim's code)."""
import dataclasses
import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from urx.ursecmon import ParserUtils

from sim_ursim import messages
from sim_ursim.controller import Controller
from sim_ursim.models import robot_model
from sim_ursim.primary import packets

CB3_3_15 = (3, 15, 8, 106339)
CB3_3_4 = (3, 4, 5, 100000)
CB3_3_1 = (3, 1, 0, 0)
E_5_11 = (5, 11, 1, 108318)
ALL_VERSIONS = [CB3_3_1, CB3_3_4, (3, 5, 0, 0), (3, 10, 0, 0), CB3_3_15, (5, 0, 0, 0), (5, 4, 0, 0), E_5_11]


BASE_STATE = Controller(model="ur3").state()


def snapshot(**overrides):
    """A real ControllerState (architecture.md Contract 3) with distinctive values in the fields serialised."""
    fields = dict(
        cycle=1234,
        timestamp=12.5,
        target_q=np.array([0.1, -1.2, 1.3, -1.4, -1.5, 0.6]),
        target_qd=np.array([0.01, 0.02, 0.03, 0.04, 0.05, 0.06]),
        actual_q=np.array([0.11, -1.21, 1.31, -1.41, -1.51, 0.61]),
        actual_qd=np.array([0.5, -0.25, 0.125, 0.0, 0.0, -0.5]),
        actual_current=np.array([0.5, 1.0, -0.5, 0.25, 0.125, 0.0625]),
        actual_tcp_pose=np.array([0.3, -0.1, 0.25, 2.2, -2.2, 0.05]),
        actual_tcp_force=np.array([1.0, 2.0, 3.0, 0.1, 0.2, 0.3]),
        target_tcp_pose=np.array([0.31, -0.11, 0.26, 2.21, -2.21, 0.06]),
        tcp_offset=np.array([0.0, 0.0, 0.15, 0.0, 0.0, 0.0]),
        elbow_position=np.array([-0.2, 0.05, 0.15]),
        elbow_velocity=np.array([0.01, 0.02, 0.03]),
        robot_mode=7,
        control_mode=0,
        safety_mode=1,
        safety_status=1,
        runtime_state=2,
        joint_mode=(253,) * 6,
        joint_temperatures=np.array([30.0, 31.0, 32.0, 33.0, 34.0, 35.0]),
        actual_joint_voltage=np.array([47.5] * 6),
        actual_robot_voltage=48.0,
        actual_robot_current=1.5,
        speed_scaling=1.0,
        target_speed_fraction=0.75,
        digital_input_bits=0b1001,
        digital_output_bits=0b10000000110,
        payload=0.5,
        payload_cog=np.array([0.0, 0.0, 0.05]),
        program_running=True,
        program_paused=False,
        power_on=True,
        protective_stopped=False,
        emergency_stopped=False,
        freedrive=False,
    )
    fields.update(overrides)
    return dataclasses.replace(BASE_STATE, **fields)


ARM = packets.arm_description(robot_model("ur3", calibration={"a": [0.0, 0.001, -0.002, 0.0, 0.0, 0.0]}))


def state_message(version, state=None):
    return packets.robot_state_message(state or snapshot(), ARM, version)


def sub_packages(message):
    """(type, bytes incl. header) of every sub-package, walking the size fields as URCL's parser does."""
    size, kind = struct.unpack_from(">iB", message)
    assert size == len(message) and kind == 16
    found, offset = [], 5
    while offset < len(message):
        sub_size, sub_type = struct.unpack_from(">iB", message, offset)
        found.append((sub_type, message[offset:offset + sub_size]))
        offset += sub_size
    assert offset == len(message)
    return found


# --- urx 0.11 parses what it can --------------------------------------------------------------------------------

def test_urx_parses_the_3_4_layout_as_version_3_2_with_every_field():
    parser = ParserUtils()
    data = parser.parse(state_message(CB3_3_4))
    assert parser.version == (3, 2)
    mode = data["RobotModeData"]
    assert (mode["robotMode"], mode["isPowerOnRobot"], mode["isProgramRunning"]) == (7, True, True)
    assert (mode["isEmergencyStopped"], mode["isSecurityStopped"], mode["isRealRobotEnabled"]) == (False, False, True)
    assert mode["speedFraction"] == 0.75 and mode["speedScaling"] == 1.0
    joints = data["JointData"]
    state = snapshot()
    for i in range(6):
        assert joints[f"q_actual{i}"] == state.actual_q[i]
        assert joints[f"q_target{i}"] == state.target_q[i]
        assert joints[f"qd_actual{i}"] == state.actual_qd[i]
        assert joints[f"jointMode{i}"] == 253
        assert joints[f"T_motor{i}"] == pytest.approx(state.joint_temperatures[i])
    cartesian = data["CartesianInfo"]
    assert [cartesian[k] for k in ("X", "Y", "Z", "Rx", "Ry", "Rz")] == list(state.actual_tcp_pose)
    assert cartesian["tcpOffsetZ"] == 0.15
    assert data["MasterBoardData"]["digitalInputBits"] == 0b1001
    assert data["MasterBoardData"]["digitalOutputBits"] == 0b10000000110
    assert data["ForceModeData"]["z"] == 3.0
    assert data["AdditionalInfo"]["teachButtonPressed"] is False


def test_urx_0_11_cannot_identify_the_real_3_15_layout_but_still_reads_joints_and_pose():
    parser = ParserUtils()
    data = parser.parse(state_message(CB3_3_15))
    assert parser.version == (0, 0)  # 47-byte RobotModeData is unknown to urx 0.11
    assert data["RobotModeData"]["robotMode"] == 7
    assert data["JointData"]["q_actual2"] == snapshot().actual_q[2]
    assert data["CartesianInfo"]["Rz"] == snapshot().actual_tcp_pose[5]
    assert "tcpOffsetZ" not in data["CartesianInfo"]


def test_urx_reads_the_3_1_layout_as_version_3_0():
    parser = ParserUtils()
    data = parser.parse(state_message(CB3_3_1))
    assert parser.version == (3, 0)
    assert data["RobotModeData"]["speedFraction"] == 0.75


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-6.3, 6.3), min_size=6, max_size=6), st.booleans(), st.booleans())
def test_urx_round_trips_any_joint_vector_and_flags(q, running, protective):
    parser = ParserUtils()
    state = snapshot(actual_q=np.array(q), program_running=running, protective_stopped=protective)
    data = parser.parse(state_message(CB3_3_4, state))
    assert [data["JointData"][f"q_actual{i}"] for i in range(6)] == q
    assert data["RobotModeData"]["isProgramRunning"] is running
    assert data["RobotModeData"]["isSecurityStopped"] is protective


# --- layouts, sizes and values checked against the documented tables ---------------------------------------------

EXPECTED_SIZES = {
    CB3_3_1: {0: 38, 1: 251, 4: 53, 5: 225, 3: 72, 2: 37, 6: 445, 7: 61, 8: 8},
    CB3_3_4: {0: 46, 1: 251, 4: 101, 5: 225, 3: 74, 2: 37, 6: 445, 7: 61, 8: 8},
    CB3_3_15: {0: 47, 1: 251, 4: 101, 5: 225, 3: 75, 2: 37, 6: 445, 7: 61, 8: 8},
    E_5_11: {0: 47, 1: 251, 4: 101, 5: 225, 3: 75, 2: 37, 6: 445, 7: 61, 8: 9},
}


@pytest.mark.parametrize("version", list(EXPECTED_SIZES))
def test_sub_package_sizes_follow_the_versioned_layouts(version):
    found = sub_packages(state_message(version))
    assert [kind for kind, _ in found] == [0, 1, 4, 5, 3, 2, 6, 7, 8]
    assert {kind: len(body) for kind, body in found} == EXPECTED_SIZES[version]


@pytest.mark.parametrize("version", ALL_VERSIONS)
def test_every_state_message_fits_urx_2000_byte_limit(version):
    assert len(state_message(version)) <= 2000


def test_robot_mode_data_matches_urcl_layout():
    state = snapshot(program_paused=True, control_mode=1, emergency_stopped=True, timestamp=3.25)
    body = dict(sub_packages(state_message(CB3_3_15, state)))[0]
    fields = struct.unpack(">iBQ???????BBdddB", body)
    assert fields[2] == 3_250_000  # microseconds
    assert fields[3:10] == (True, True, True, True, False, True, True)
    assert fields[10:12] == (7, 1)  # robot mode RUNNING, control mode TEACH
    assert fields[12:15] == (0.75, 1.0, 1.0)


def test_kinematics_and_configuration_publish_the_calibrated_dh():
    model = robot_model("ur3", calibration={"a": [0.0, 0.001, -0.002, 0.0, 0.0, 0.0]})
    found = dict(sub_packages(state_message(CB3_3_15)))
    kin = struct.unpack(">iB6I24dI", found[5])
    theta, a, d, alpha = kin[8:14], kin[14:20], kin[20:26], kin[26:32]
    assert a[1] == pytest.approx(-0.24365 + 0.001) and a[2] == pytest.approx(-0.21325 - 0.002)
    assert list(d) == list(model.d) and list(alpha) == list(model.alpha) and list(theta) == [0.0] * 6
    config = struct.unpack(">iB12d12d5d24d4i", found[6])
    limits, speeds = config[2:14], config[14:26]
    assert limits[0] == pytest.approx(-2 * math.pi) and limits[1] == pytest.approx(2 * math.pi)
    # base 180°/s, wrist 1 360°/s
    assert speeds[0] == pytest.approx(math.pi) and speeds[6] == pytest.approx(2 * math.pi)
    assert config[26:31] == (1.0472, 1.3963, 0.25, 1.2, 0.25)
    dh_a = config[31:37]
    assert list(dh_a) == list(model.a)
    assert config[55:59] == (6, 4, 3, 2)  # masterboard version, controller box, robotType UR3, subtype CB3


def test_masterboard_carries_io_bits_and_safety_mode():
    state = snapshot(safety_mode=3, digital_input_bits=0x30001, digital_output_bits=0x102)
    body = dict(sub_packages(state_message(E_5_11, state)))[3]
    fields = struct.unpack(">iBiiBBddbbddffffBBbIBBB", body)
    assert fields[2:4] == (0x30001, 0x102)
    assert fields[16] == 3


def test_arm_description_of_an_e_series_model():
    e_arm = packets.arm_description(robot_model("ur5e"))
    assert (e_arm.robot_type, e_arm.robot_sub_type) == (1, 3)


# --- version message ---------------------------------------------------------------------------------------------

def test_version_message_3_12_and_later_matches_urcl_layout():
    data = packets.version_message(E_5_11, "08-12-2021, 10:00:00")
    size, kind, _, source, robot_message_type, name_length = struct.unpack_from(">iBQbBb", data)
    assert (size, kind, source, robot_message_type) == (len(data), 20, -2, 3)
    offset = struct.calcsize(">iBQbBb")
    assert data[offset:offset + name_length] == b"URControl"
    major, minor, bugfix, build = struct.unpack_from(">BBii", data, offset + name_length)
    assert (major, minor, bugfix, build) == (5, 11, 1, 108318)
    assert data[offset + name_length + 10:] == b"08-12-2021, 10:00:00"


def test_version_message_before_3_12_is_parsed_by_urx_0_11():
    data = ParserUtils().parse(packets.version_message((3, 4, 5, 100000), "01-02-2017, 10:00:00"))
    version = data["VersionMessage"]
    assert (version["projectName"], version["majorVersion"], version["minorVersion"]) == (b"URControl", 3, 4)
    assert version["svnRevision"] == 100000 and version["buildDate"] == b"01-02-2017, 10:00:00"


def test_primary_build_date_converts_the_dashboard_date():
    assert packets.primary_build_date("Jun 20 2022") == "20-06-2022, 00:00:00"
    with pytest.raises(ValueError, match="dashboard_date"):
        packets.primary_build_date("2022-06-20")


# --- robot messages ----------------------------------------------------------------------------------------------

def test_text_message_is_parsed_by_urx():
    data = ParserUtils().parse(packets.encode_robot_message(messages.TextMessage("hello"), CB3_3_15, 99))
    assert data["messageText"]["messageText"] == b"hello"
    assert data["messageText"]["timestamp"] == 99


def test_key_message_is_parsed_by_urx():
    key = messages.KeyMessage(code=0, argument=0, title="PROGRAM_XXX_STARTED", text="myProg")
    data = ParserUtils().parse(packets.encode_robot_message(key, CB3_3_15, 1))["keyMessage"]
    assert (data["messageTitle"], data["messageText"]) == (b"PROGRAM_XXX_STARTED", b"myProg")


def test_cb3_popup_is_parsed_by_urx():
    popup = messages.PopupMessage(title="Attention", text="check the gripper", warning=True)
    data = ParserUtils().parse(packets.encode_robot_message(popup, CB3_3_15, 1))["popupMessage"]
    assert (data["warning"], data["error"]) == (True, False)
    assert (data["messageTitle"], data["messageText"]) == (b"Attention", b"check the gripper")


def test_e_series_popup_carries_request_id_and_type():
    popup = messages.PopupMessage(title="T", text="x", error=True, request_id=7)
    data = packets.encode_robot_message(popup, E_5_11, 1)
    request_id, requested_type, warning, error, blocking, title_length = struct.unpack_from(">II???B", data, 15)
    assert (request_id, requested_type, warning, error, blocking, title_length) == (7, 0, False, True, False, 1)
    assert data[-2:] == b"Tx"


def test_runtime_exception_layout():
    error = messages.RuntimeExceptionMessage(line=3, column=5, text="compile_error_name_not_found:txtmsg:")
    data = packets.encode_robot_message(error, CB3_3_15, 1)
    assert struct.unpack_from(">bBII", data, 13) == (-3, 10, 3, 5)
    assert data[23:] == b"compile_error_name_not_found:txtmsg:"


def test_error_code_and_safety_mode_layouts():
    error = messages.ErrorCodeMessage(code=210, argument=0, report_level=2, data_type=0, data=0, text="C210")
    data = packets.encode_robot_message(error, E_5_11, 1)
    assert struct.unpack_from(">BiiiII", data, 14) == (6, 210, 0, 2, 0, 0) and data[-4:] == b"C210"
    safety = messages.SafetyModeMessage(code=3, argument=0, safety_mode_type=3)
    data = packets.encode_robot_message(safety, E_5_11, 1)
    assert struct.unpack(">iBQbBiiBII", data)[4:] == (5, 3, 0, 3, 0, 0)


def test_unknown_message_kind_is_refused_by_name():
    with pytest.raises(ValueError, match="message: cannot encode a str"):
        packets.encode_robot_message("hello", CB3_3_15, 1)
