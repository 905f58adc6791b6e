"""Pure parsing of the primary/secondary client interface (ports 30001/30002): bytes in, values out, no sockets.

Framing (docs/protocols.md §3.1): `int32 size` (whole message) + `uint8 type` + body, big-endian. A robot-state
message (16) is a run of sub-packages `int32 size + uint8 type + data`; a robot message (20) starts with
`uint64 timestamp, int8 source, uint8 robot_message_type`. Layouts follow UR's primary-secondary guide as
transcribed in docs/protocols.md §3.3-3.4.
"""
import struct
from dataclasses import dataclass
from typing import TypeAlias, TypedDict

import numpy as np

ROBOT_STATE = 16
ROBOT_MESSAGE = 20

# robot-state sub-package types
ROBOT_MODE_DATA = 0
MASTERBOARD_DATA = 3
CARTESIAN_INFO = 4
KINEMATICS_INFO = 5
CONFIGURATION_DATA = 6

# robot-message types
TEXT_MESSAGE = 0
VERSION_MESSAGE = 3
SAFETY_MODE_MESSAGE = 5
ERROR_CODE_MESSAGE = 6
KEY_MESSAGE = 7
RUNTIME_EXCEPTION_MESSAGE = 10

MAX_MESSAGE_SIZE = 1 << 20  # a larger size field means the stream is out of step, not a real message

ROBOT_TYPE_NAMES = {1: "ur5", 2: "ur10", 3: "ur3", 4: "ur16"}


class PrimaryParseError(ValueError):
    """Bytes that do not follow the primary-interface layout."""


@dataclass(frozen=True)
class RobotModeData:
    """Robot Mode Data (sub-package 0): power, stops, program flags, robot mode and speed fractions."""

    timestamp: int
    real_robot_connected: bool
    real_robot_enabled: bool
    power_on: bool
    emergency_stopped: bool
    protective_stopped: bool
    program_running: bool
    program_paused: bool
    robot_mode: int
    control_mode: int
    target_speed_fraction: float
    speed_scaling: float


@dataclass(frozen=True)
class CartesianInfo:
    """Cartesian Info (sub-package 4): TCP pose in base and (3.2+) TCP offset in flange, UR pose vectors."""

    tcp_pose: np.ndarray
    tcp_offset: np.ndarray | None


@dataclass(frozen=True)
class KinematicsInfo:
    """Kinematics Info (sub-package 5): the controller's calibrated standard DH (metres, radians)."""

    checksum: tuple[int, ...]
    theta: np.ndarray
    a: np.ndarray
    d: np.ndarray
    alpha: np.ndarray
    calibration_status: int | None


@dataclass(frozen=True)
class ConfigurationData:
    """Configuration Data (sub-package 6): joint limits (rad), max speeds/accelerations, defaults, DH, robot type."""

    joint_min: np.ndarray
    joint_max: np.ndarray
    max_joint_speed: np.ndarray
    max_joint_acceleration: np.ndarray
    v_joint_default: float
    a_joint_default: float
    v_tool_default: float
    a_tool_default: float
    eq_radius: float
    dh_a: np.ndarray
    dh_d: np.ndarray
    dh_alpha: np.ndarray
    dh_theta: np.ndarray
    masterboard_version: int
    controller_box_type: int
    robot_type: int
    robot_sub_type: int


@dataclass(frozen=True)
class VersionMessage:
    """Version message (robot message 3): controller software version."""

    project_name: str
    major: int
    minor: int
    bugfix: int
    build: int
    build_date: str


@dataclass(frozen=True)
class KeyMessage:
    """Key message (robot message 7), e.g. title PROGRAM_XXX_STARTED / PROGRAM_XXX_STOPPED, text = program name."""

    code: int
    argument: int
    title: str
    text: str


@dataclass(frozen=True)
class RuntimeExceptionMessage:
    """Runtime exception (robot message 10): a URScript compile or runtime error at line:column."""

    line: int
    column: int
    text: str


@dataclass(frozen=True)
class ErrorCodeMessage:
    """Error code message (robot message 6), report level 0 DEBUG … 5 CRITICAL_FAULT."""

    code: int
    argument: int
    report_level: int
    text: str


@dataclass(frozen=True)
class TextMessage:
    """Text message (robot message 0), e.g. from URScript textmsg."""

    text: str


@dataclass(frozen=True)
class SafetyModeMessage:
    """Safety mode message (robot message 5): the safety mode changed to `safety_mode`."""

    code: int
    argument: int
    safety_mode: int


@dataclass(frozen=True)
class BoardIO:
    """The I/O of Masterboard Data (sub-package 3): digital input and output bits (0-7 standard, 8-15
    configurable, 16-17 tool) and the two standard analog inputs and outputs."""

    digital_in: int
    digital_out: int
    analog_in: tuple[float, float]
    analog_out: tuple[float, float]


@dataclass(frozen=True)
class RobotState:
    """The parts of one robot-state message ur3dq uses; None where the message did not carry them."""

    robot_mode: RobotModeData | None = None
    safety_mode: int | None = None
    cartesian: CartesianInfo | None = None
    kinematics: KinematicsInfo | None = None
    configuration: ConfigurationData | None = None
    board_io: BoardIO | None = None


#: The robot messages ur3dq parses (parse_robot_message); a PrimaryClient hands them to its watchers.
RobotMessage: TypeAlias = (VersionMessage | KeyMessage | RuntimeExceptionMessage | ErrorCodeMessage | TextMessage
                           | SafetyModeMessage)


class _RobotStateFields(TypedDict, total=False):
    """The keyword arguments of RobotState that parse_robot_state has found in a message."""

    robot_mode: RobotModeData
    safety_mode: int
    cartesian: CartesianInfo
    kinematics: KinematicsInfo
    configuration: ConfigurationData
    board_io: BoardIO

def split_messages(buffer: bytes) -> tuple[list[tuple[int, bytes]], bytes]:
    """(list of (message_type, body bytes), unconsumed tail) for the complete messages at the start of `buffer`."""
    messages: list[tuple[int, bytes]] = []
    offset = 0
    while len(buffer) - offset >= 5:
        size, message_type = struct.unpack_from(">iB", buffer, offset)
        if size < 5 or size > MAX_MESSAGE_SIZE:
            raise PrimaryParseError(f"message size {size} at offset {offset} is impossible; stream out of step")
        if len(buffer) - offset < size:
            break
        messages.append((message_type, bytes(buffer[offset + 5 : offset + size])))
        offset += size
    return messages, bytes(buffer[offset:])


def split_subpackages(body: bytes) -> list[tuple[int, bytes]]:
    """List of (sub-package type, data bytes) of a robot-state message body."""
    packages: list[tuple[int, bytes]] = []
    offset = 0
    while offset < len(body):
        if len(body) - offset < 5:
            raise PrimaryParseError(f"truncated sub-package header at offset {offset}")
        size, package_type = struct.unpack_from(">iB", body, offset)
        if size < 5 or offset + size > len(body):
            raise PrimaryParseError(f"sub-package type {package_type} claims {size} bytes at offset {offset}")
        packages.append((package_type, body[offset + 5 : offset + size]))
        offset += size
    return packages


def parse_robot_state(body: bytes) -> RobotState:
    """RobotState from a robot-state message body (type 16); unknown sub-packages are skipped."""
    fields: _RobotStateFields = {}
    for package_type, data in split_subpackages(body):
        if package_type == ROBOT_MODE_DATA:
            fields["robot_mode"] = parse_robot_mode_data(data)
        elif package_type == MASTERBOARD_DATA:
            fields["safety_mode"] = parse_masterboard_safety_mode(data)
            fields["board_io"] = parse_masterboard_io(data)
        elif package_type == CARTESIAN_INFO:
            fields["cartesian"] = parse_cartesian_info(data)
        elif package_type == KINEMATICS_INFO:
            fields["kinematics"] = parse_kinematics_info(data)
        elif package_type == CONFIGURATION_DATA:
            fields["configuration"] = parse_configuration_data(data)
    return RobotState(**fields)


def parse_robot_mode_data(data: bytes) -> RobotModeData:
    """RobotModeData from sub-package 0 data (3.0+ layouts: 33, 41 or 42 bytes after the header; the tail is unused)."""
    if len(data) < 33:
        raise PrimaryParseError(f"Robot Mode Data has {len(data)} bytes; at least 33 expected (software 3.0+)")
    return RobotModeData(*struct.unpack_from(">Q???????BBdd", data))


def parse_masterboard_safety_mode(data: bytes) -> int:
    """The safety mode (uint8) of Masterboard Data (sub-package 3, software 3.0+ layout)."""
    layout = ">iiBBddbbddffffB"
    if len(data) < struct.calcsize(layout):
        raise PrimaryParseError(f"Masterboard Data has {len(data)} bytes; too short for the 3.0+ layout")
    return int(struct.unpack_from(layout, data)[-1])


def parse_masterboard_io(data: bytes) -> BoardIO:
    """BoardIO of Masterboard Data (sub-package 3, software 3.0+ layout: digital input and output bits, analog
    input ranges and values, analog output domains and values)."""
    layout = ">iiBBddbbdd"
    if len(data) < struct.calcsize(layout):
        raise PrimaryParseError(f"Masterboard Data has {len(data)} bytes; too short for its I/O")
    digital_in, digital_out, _, _, in0, in1, _, _, out0, out1 = struct.unpack_from(layout, data)
    return BoardIO(digital_in, digital_out, (in0, in1), (out0, out1))


def parse_cartesian_info(data: bytes) -> CartesianInfo:
    """CartesianInfo from sub-package 4 data: 6 doubles TCP pose, then (3.2+) 6 doubles TCP offset."""
    if len(data) < 48:
        raise PrimaryParseError(f"Cartesian Info has {len(data)} bytes; 48 or 96 expected")
    pose = np.array(struct.unpack_from(">6d", data))
    offset = np.array(struct.unpack_from(">6d", data, 48)) if len(data) >= 96 else None
    return CartesianInfo(pose, offset)


def parse_kinematics_info(data: bytes) -> KinematicsInfo:
    """KinematicsInfo from sub-package 5 data: checksums, DH theta, a, d, alpha (+ calibration status)."""
    if len(data) < 216:
        raise PrimaryParseError(f"Kinematics Info has {len(data)} bytes; 216 or 220 expected")
    checksum = struct.unpack_from(">6I", data)
    dh = np.array(struct.unpack_from(">24d", data, 24)).reshape(4, 6)
    status = struct.unpack_from(">I", data, 216)[0] if len(data) >= 220 else None
    return KinematicsInfo(checksum, dh[0], dh[1], dh[2], dh[3], status)


def parse_configuration_data(data: bytes) -> ConfigurationData:
    """ConfigurationData from sub-package 6 data (440 bytes: limits, speeds, defaults, DH, board/robot type)."""
    if len(data) < 440:
        raise PrimaryParseError(f"Configuration Data has {len(data)} bytes; 440 expected")
    limits = np.array(struct.unpack_from(">12d", data, 0)).reshape(6, 2)
    dynamics = np.array(struct.unpack_from(">12d", data, 96)).reshape(6, 2)
    defaults = struct.unpack_from(">5d", data, 192)
    dh = np.array(struct.unpack_from(">24d", data, 232)).reshape(4, 6)
    board, box, robot_type, sub_type = struct.unpack_from(">4i", data, 424)
    v_joint, a_joint, v_tool, a_tool, eq_radius = defaults
    return ConfigurationData(
        limits[:, 0], limits[:, 1], dynamics[:, 0], dynamics[:, 1], v_joint, a_joint, v_tool, a_tool, eq_radius,
        dh[0], dh[1], dh[2], dh[3], board, box, robot_type, sub_type,
    )


def parse_robot_message(body: bytes) -> RobotMessage | None:
    """The message object of a robot message body (type 20), or None for message types ur3dq does not use."""
    if len(body) < 10:
        raise PrimaryParseError(f"robot message has {len(body)} bytes; at least 10 expected")
    message_type = body[9]
    data = body[10:]
    try:
        if message_type == VERSION_MESSAGE:
            return parse_version_message(data)
        if message_type == KEY_MESSAGE:
            code, argument, title_length = struct.unpack_from(">iiB", data)
            title = data[9 : 9 + title_length]
            return KeyMessage(code, argument, _text(title), _text(data[9 + title_length :]))
        if message_type == RUNTIME_EXCEPTION_MESSAGE:
            line, column = struct.unpack_from(">II", data)
            return RuntimeExceptionMessage(line, column, _text(data[8:]))
        if message_type == ERROR_CODE_MESSAGE:
            code, argument, level = struct.unpack_from(">iii", data)
            return ErrorCodeMessage(code, argument, level, _text(data[20:]))
        if message_type == TEXT_MESSAGE:
            return TextMessage(_text(data))
        if message_type == SAFETY_MODE_MESSAGE:
            code, argument, mode = struct.unpack_from(">iiB", data)
            return SafetyModeMessage(code, argument, mode)
    except struct.error as error:
        raise PrimaryParseError(f"robot message type {message_type} is truncated: {error}") from None
    return None


def parse_version_message(data: bytes) -> VersionMessage:
    """VersionMessage from a version message's data (after the robot-message header); pre-3.12 layout too."""
    try:
        name_length = struct.unpack_from(">b", data)[0]
        name = data[1 : 1 + name_length]
        major, minor = struct.unpack_from(">BB", data, 1 + name_length)
        if (major, minor) >= (3, 12):
            bugfix, build = struct.unpack_from(">ii", data, 3 + name_length)
            date_offset = 11 + name_length
        else:  # before 3.12 one int32 (svn revision) follows; the bugfix number is not sent
            bugfix, build = 0, struct.unpack_from(">i", data, 3 + name_length)[0]
            date_offset = 7 + name_length
    except struct.error:
        raise PrimaryParseError(f"version message of {len(data)} bytes is truncated") from None
    return VersionMessage(_text(name), major, minor, bugfix, build, _text(data[date_offset:]))


def is_program_started(message: object, program_name: str) -> bool:
    """True if `message` is the key message announcing that `program_name` started."""
    return isinstance(message, KeyMessage) and message.title.endswith("_STARTED") and message.text == program_name


def is_program_stopped(message: object, program_name: str) -> bool:
    """True if `message` is the key message announcing that `program_name` stopped."""
    return isinstance(message, KeyMessage) and message.title.endswith("_STOPPED") and message.text == program_name


def model_name(robot_type: int, major_version: int) -> str:
    """The ur3dq model name ('ur3', 'ur5e', …) of a Configuration Data robotType and controller major version."""
    if robot_type not in ROBOT_TYPE_NAMES:
        raise ValueError(f"robot type {robot_type} is not a model ur3dq knows ({sorted(ROBOT_TYPE_NAMES)})")
    name = ROBOT_TYPE_NAMES[robot_type]
    if name == "ur16":
        return "ur16e"  # the UR16 exists only as an e-series arm
    return name + "e" if major_version >= 5 else name


def _text(raw: bytes) -> str:
    """Bytes of a message text as str (UTF-8, undecodable bytes replaced)."""
    return bytes(raw).decode("utf-8", errors="replace")
