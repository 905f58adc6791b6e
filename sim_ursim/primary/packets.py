"""Pure serialisers for the primary/secondary client interface (ports 30001 and 30002).

Every function turns values (a controller snapshot, an arm description, a robot message) into the exact bytes a
controller of the emulated software version sends; nothing here touches a socket.  Layouts follow
docs/protocols.md §3 (URCL src/primary/**, ur_modern_driver's versioned CB3 layouts, a real 5.24 byte dump).
All integers and floats are big-endian.  `version` is always (major, minor, bugfix, build) of the emulated
controller software; the layout decisions keyed on it are listed in docs/urx-compatibility.md.
"""
import datetime
import struct
from dataclasses import dataclass

from sim_ursim.messages import (
    ErrorCodeMessage,
    KeyMessage,
    PopupMessage,
    RuntimeExceptionMessage,
    SafetyModeMessage,
    TextMessage,
)

# Message types (int32 size, uint8 type) — docs/protocols.md §3.1.
ROBOT_STATE = 16
ROBOT_MESSAGE = 20

# Robot-state sub-package types.
ROBOT_MODE_DATA = 0
JOINT_DATA = 1
TOOL_DATA = 2
MASTERBOARD_DATA = 3
CARTESIAN_INFO = 4
KINEMATICS_INFO = 5
CONFIGURATION_DATA = 6
FORCE_MODE_DATA = 7
ADDITIONAL_INFO = 8

# Robot-message types (the byte after timestamp and source).
TEXT_MESSAGE = 0
POPUP_MESSAGE = 2
VERSION_MESSAGE = 3
SAFETY_MODE_MESSAGE = 5
ERROR_CODE_MESSAGE = 6
KEY_MESSAGE = 7
RUNTIME_EXCEPTION_MESSAGE = 10

VERSION_MESSAGE_SOURCE = -2
PROJECT_NAME = b"URControl"

# Tool modes (docs/protocols.md §1).
TOOL_MODE_RUNNING = 253
TOOL_MODE_POWER_OFF = 239

# Values the controller snapshot does not model; a healthy arm reports about these.
NOMINAL_TOOL_TEMPERATURE = 30.0
NOMINAL_MASTERBOARD_TEMPERATURE = 35.0

_HEADER = struct.Struct(">iB")
_ROBOT_MESSAGE_HEADER = struct.Struct(">QbB")
_JOINT = struct.Struct(">dddffffB")
_SIX_DOUBLES = struct.Struct(">6d")


@dataclass(frozen=True)
class ArmDescription:
    """What Configuration Data and Kinematics Info publish about the arm: limits (rad, rad/s, rad/s²), standard DH
    (a, d, alpha, theta — 6 each, metres/radians) and the controller's type codes (robotType 3 = UR3)."""

    joint_min: tuple
    joint_max: tuple
    max_speed: tuple
    max_acceleration: tuple
    dh_a: tuple
    dh_d: tuple
    dh_alpha: tuple
    dh_theta: tuple
    robot_type: int
    robot_sub_type: int
    masterboard_version: int
    controller_box_type: int
    default_joint_speed: float = 1.0472
    default_joint_acceleration: float = 1.3963
    default_tool_speed: float = 0.25
    default_tool_acceleration: float = 1.2
    equivalent_radius: float = 0.25


# robotSubType (underautomation RobotSubTypes): 2 CB3-series, 3 e-series; masterboard version and controller box
# type of an e-series arm as in the URSim 5.24 dump (6, 4); the CB3 values are not documented publicly.
ROBOT_SUB_TYPE_CB3 = 2
ROBOT_SUB_TYPE_E_SERIES = 3
E_SERIES_MASTERBOARD_VERSION = 6
E_SERIES_CONTROLLER_BOX_TYPE = 4


def arm_description(model):
    """ArmDescription of a sim_ursim.models.RobotModel (its possibly calibrated DH, limits and type codes)."""
    return ArmDescription(
        joint_min=tuple(float(v) for v in model.joint_lower),
        joint_max=tuple(float(v) for v in model.joint_upper),
        max_speed=tuple(float(v) for v in model.max_joint_speed),
        max_acceleration=tuple(float(v) for v in model.max_joint_acceleration),
        dh_a=tuple(float(v) for v in model.a),
        dh_d=tuple(float(v) for v in model.d),
        dh_alpha=tuple(float(v) for v in model.alpha),
        dh_theta=tuple(float(v) for v in model.theta),
        robot_type=int(model.robot_type),
        robot_sub_type=ROBOT_SUB_TYPE_E_SERIES if model.e_series else ROBOT_SUB_TYPE_CB3,
        masterboard_version=E_SERIES_MASTERBOARD_VERSION,
        controller_box_type=E_SERIES_CONTROLLER_BOX_TYPE,
    )


def primary_build_date(dashboard_date):
    """Version-message build date "dd-mm-yyyy, 00:00:00" from the dashboard's "Mon dd yyyy"; ValueError otherwise."""
    try:
        parsed = datetime.datetime.strptime(dashboard_date, "%b %d %Y")
    except (TypeError, ValueError):
        raise ValueError(f"dashboard_date must look like 'Jun 20 2022', got {dashboard_date!r}") from None
    return parsed.strftime("%d-%m-%Y, %H:%M:%S")


def is_e_series(version):
    """True for e-series software (major 5 and later); CB3 is major 3."""
    return version[0] >= 5


def _since(version, major, minor):
    """True when `version` is major.minor or later (every e-series release counts as later than every CB3 one)."""
    return (int(version[0]), int(version[1])) >= (major, minor)


def frame(message_type, body):
    """One primary-interface message: int32 total size (header included), uint8 type, body."""
    return _HEADER.pack(len(body) + _HEADER.size, message_type) + body


def sub_package(package_type, body):
    """One robot-state sub-package: int32 size (its 5-byte header included), uint8 type, body — framed like a
    message."""
    return frame(package_type, body)


def robot_mode_data_size(version):
    """Total RobotModeData size: 38 for 3.0–3.1, 46 for 3.2–3.4, 47 for 3.5+ and every e-series."""
    if _since(version, 3, 5):
        return 47
    if _since(version, 3, 2):
        return 46
    return 38


def robot_mode_data(state, version):
    """RobotModeData (0); timestamp in microseconds of controller time, flags and modes from the snapshot."""
    size = robot_mode_data_size(version)
    body = struct.pack(
        ">Q???????BBdd",
        int(round(state.timestamp * 1e6)),
        True,  # isRealRobotConnected: the simulator plays a connected arm
        True,  # isRealRobotEnabled (URSim reports True as well, and urx requires it)
        bool(state.power_on),
        bool(state.emergency_stopped),
        bool(state.protective_stopped),
        bool(state.program_running),
        bool(state.program_paused),
        int(state.robot_mode) & 0xFF,
        int(state.control_mode) & 0xFF,
        float(state.target_speed_fraction),
        float(state.speed_scaling),
    )
    if size >= 46:
        body += struct.pack(">d", 1.0)  # targetSpeedFractionLimit: no safety-reduced slider cap modelled
    if size >= 47:
        body += b"\x00"  # reserved
    return sub_package(ROBOT_MODE_DATA, body)


def joint_data(state):
    """JointData (1): per joint q actual, q target, qd actual (double), current, voltage, motor and micro
    temperature (float), joint mode (uint8) — 251 bytes in every version."""
    parts = []
    for i in range(6):
        temperature = float(state.joint_temperatures[i])
        parts.append(
            _JOINT.pack(
                float(state.actual_q[i]),
                float(state.target_q[i]),
                float(state.actual_qd[i]),
                float(state.actual_current[i]),
                float(state.actual_joint_voltage[i]),
                temperature,
                temperature,
                int(state.joint_mode[i]) & 0xFF,
            )
        )
    return sub_package(JOINT_DATA, b"".join(parts))


def tool_data(state):
    """ToolData (2), 37 bytes: analog ranges/inputs, 48 V supply, output voltage, current, temperature, tool mode."""
    tool_mode = TOOL_MODE_RUNNING if state.power_on else TOOL_MODE_POWER_OFF
    body = struct.pack(
        ">bbddfBffB",
        0,
        0,
        float(state.tool_analog_input0),
        float(state.tool_analog_input1),
        float(state.actual_robot_voltage),
        0,  # toolOutputVoltage (V): tool power supply off
        0.0,
        NOMINAL_TOOL_TEMPERATURE,
        tool_mode,
    )
    return sub_package(TOOL_DATA, body)


def masterboard_data_size(version):
    """MasterboardData size without Euromap67: 72 for 3.0–3.1, 74 for 3.2–3.13, 75 for 3.14+ and every e-series.

    75 = ... reserved uint32, operationalModeSelectorInput, threePositionEnablingDeviceInput, reserved uint8: the
    layout URCL parses (src/primary/robot_state/masterboard_data.cpp) with strict sub-package parsing in its CI
    against URSim 3.14.3 and 5.9.4; 74 (no trailing byte) is ur_modern_driver's MasterBoardData_V3_2.  The CB3 release
    that added the trailing byte is not public: 3.14 is the earliest with evidence.
    """
    if is_e_series(version) or _since(version, 3, 14):
        return 75
    if _since(version, 3, 2):
        return 74
    return 72


def masterboard_data(state, version):
    """MasterboardData (3): digital I/O bit fields (bits 0-7 standard, 8-15 configurable, 16-17 tool), analog I/O,
    board electrical values, safety mode; no Euromap67 module installed."""
    body = struct.pack(
        ">iiBBddbbddffffBBb",
        int(state.digital_input_bits) & 0x7FFFFFFF,
        int(state.digital_output_bits) & 0x7FFFFFFF,
        0,
        0,
        float(state.standard_analog_input0),
        float(state.standard_analog_input1),
        0,
        0,
        float(state.standard_analog_output0),
        float(state.standard_analog_output1),
        NOMINAL_MASTERBOARD_TEMPERATURE,
        float(state.actual_robot_voltage),
        float(state.actual_robot_current),
        0.0,
        int(state.safety_mode) & 0xFF,
        0,  # inReducedMode
        0,  # euromap67InterfaceInstalled
    )
    body += struct.pack(">I", 0)  # reserved (UR internal)
    if masterboard_data_size(version) >= 74:
        body += struct.pack(">BB", 0, 0)  # operationalModeSelectorInput, threePositionEnablingDeviceInput
    if masterboard_data_size(version) >= 75:
        body += b"\x00"
    return sub_package(MASTERBOARD_DATA, body)


def cartesian_info(state, version):
    """CartesianInfo (4): TCP pose [x,y,z,rx,ry,rz] in the base frame.

    From 3.2 on, also the TCP offset in the flange frame.
    """
    body = _SIX_DOUBLES.pack(*map(float, state.actual_tcp_pose))
    if _since(version, 3, 2):
        body += _SIX_DOUBLES.pack(*map(float, state.tcp_offset))
    return sub_package(CARTESIAN_INFO, body)


def kinematics_info(arm, version):
    """KinematicsInfo (5), 225 bytes: uint32 checksum×6, DH theta, a, d, alpha (double×6 each), uint32 calibration
    status; the DH published is the simulator's (possibly calibrated) model, as URCL's calibration check expects."""
    body = struct.pack(">6I", *([0xFFFFFFFF] * 6))
    for values in (arm.dh_theta, arm.dh_a, arm.dh_d, arm.dh_alpha):
        body += _SIX_DOUBLES.pack(*map(float, values))
    body += struct.pack(">I", 0)  # calibration_status: 0 as on URSim
    return sub_package(KINEMATICS_INFO, body)


def configuration_data(arm, version):
    """ConfigurationData (6), 445 bytes: joint limits, max speed/acceleration, PolyScope defaults, DH a, d, alpha,
    theta, masterboard version, controller box type, robotType, robotSubType."""
    body = b"".join(struct.pack(">dd", float(lo), float(hi)) for lo, hi in zip(arm.joint_min, arm.joint_max))
    body += b"".join(
        struct.pack(">dd", float(v), float(a)) for v, a in zip(arm.max_speed, arm.max_acceleration)
    )
    body += struct.pack(
        ">5d",
        arm.default_joint_speed,
        arm.default_joint_acceleration,
        arm.default_tool_speed,
        arm.default_tool_acceleration,
        arm.equivalent_radius,
    )
    for values in (arm.dh_a, arm.dh_d, arm.dh_alpha, arm.dh_theta):
        body += _SIX_DOUBLES.pack(*map(float, values))
    body += struct.pack(
        ">4i", arm.masterboard_version, arm.controller_box_type, arm.robot_type, arm.robot_sub_type
    )
    return sub_package(CONFIGURATION_DATA, body)


def force_mode_data(state):
    """ForceModeData (7), 61 bytes: the TCP wrench (N, Nm) and robot dexterity (0: not computed by the simulator)."""
    body = _SIX_DOUBLES.pack(*map(float, state.actual_tcp_force)) + struct.pack(">d", 0.0)
    return sub_package(FORCE_MODE_DATA, body)


def additional_info(state, version):
    """AdditionalInfo (8): CB3 three bools (teach button pressed/enabled, IO freedrive) = 8 bytes; e-series
    tpButtonState, freedriveButtonEnabled, IOEnabledFreedrive, reserved = 9 bytes."""
    if is_e_series(version):
        body = struct.pack(">B??B", 1 if state.freedrive else 0, True, False, 0)
    else:
        body = struct.pack(">???", bool(state.freedrive), True, False)
    return sub_package(ADDITIONAL_INFO, body)


def robot_state_message(state, arm, version):
    """The 10 Hz robot-state message (16) in the sub-package order of a real controller (5.24 dump, minus the
    UR-internal calibration and safety packages)."""
    body = b"".join(
        (
            robot_mode_data(state, version),
            joint_data(state),
            cartesian_info(state, version),
            kinematics_info(arm, version),
            masterboard_data(state, version),
            tool_data(state),
            configuration_data(arm, version),
            force_mode_data(state),
            additional_info(state, version),
        )
    )
    return frame(ROBOT_STATE, body)


def robot_message(robot_message_type, body, timestamp_ms, source):
    """A robot message (20): uint64 timestamp (ms), int8 source, uint8 robot-message type, then the type's body."""
    return frame(ROBOT_MESSAGE, _ROBOT_MESSAGE_HEADER.pack(int(timestamp_ms), source, robot_message_type) + body)


def version_message(version, build_date, timestamp_ms=0):
    """VersionMessage (3), sent first on connect: project name "URControl", major, minor, then bugfix and build
    (int32 each, 3.12+ and e-series) or the older single int32 svnRevision (before 3.12), then the build date."""
    major, minor, bugfix, build = (int(v) for v in version)
    body = struct.pack(">b", len(PROJECT_NAME)) + PROJECT_NAME + struct.pack(">BB", major, minor)
    if _since(version, 3, 12):
        body += struct.pack(">ii", bugfix, build)
    else:
        body += struct.pack(">i", build)
    body += build_date.encode("ascii")
    return robot_message(VERSION_MESSAGE, body, timestamp_ms, VERSION_MESSAGE_SOURCE)


def _text(text):
    """Message text as the controller sends it: UTF-8, no terminator (the text runs to the end of the message)."""
    return text.encode("utf-8")


def _titled(title):
    """A uint8-length-prefixed title (key and popup messages)."""
    encoded = title.encode("utf-8")[:255]
    return struct.pack(">B", len(encoded)) + encoded


def encode_robot_message(message, version, timestamp_ms):
    """Bytes of one bus message (sim_ursim.messages) as a 30001 robot message; ValueError for an unknown kind."""
    if isinstance(message, TextMessage):
        return robot_message(TEXT_MESSAGE, _text(message.text), timestamp_ms, message.source)
    if isinstance(message, KeyMessage):
        body = struct.pack(">ii", message.code, message.argument) + _titled(message.title) + _text(message.text)
        return robot_message(KEY_MESSAGE, body, timestamp_ms, message.source)
    if isinstance(message, ErrorCodeMessage):
        body = struct.pack(
            ">iiiII", message.code, message.argument, message.report_level, message.data_type, message.data
        ) + _text(message.text)
        return robot_message(ERROR_CODE_MESSAGE, body, timestamp_ms, message.source)
    if isinstance(message, RuntimeExceptionMessage):
        body = struct.pack(">II", message.line, message.column) + _text(message.text)
        return robot_message(RUNTIME_EXCEPTION_MESSAGE, body, timestamp_ms, message.source)
    if isinstance(message, SafetyModeMessage):
        body = struct.pack(
            ">iiBII",
            message.code,
            message.argument,
            message.safety_mode_type,
            message.report_data_type,
            message.report_data,
        )
        return robot_message(SAFETY_MODE_MESSAGE, body, timestamp_ms, message.source)
    if isinstance(message, PopupMessage):
        return robot_message(POPUP_MESSAGE, popup_body(message, version), timestamp_ms, message.source)
    raise ValueError(f"message: cannot encode a {type(message).__name__} as a primary robot message")


def popup_body(message, version):
    """Popup body: e-series uint32 requestId, uint32 requestedType, bool warning, error, blocking, title, text;
    CB3 bool warning, error, title, text (the layout urx parses)."""
    if is_e_series(version):
        head = struct.pack(">II???", message.request_id, 0, message.warning, message.error, False)
    else:
        head = struct.pack(">??", message.warning, message.error)
    return head + _titled(message.title) + _text(message.text)
