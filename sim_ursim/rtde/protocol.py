"""RTDE wire format (port 30004): pure bytes <-> values, no sockets.

Every package is `uint16 size` (whole package, header included) + `uint8 type` + payload, big-endian
(docs/protocols.md §5.1). Both directions are here: the server uses the request parsers and reply packers, the tests
(and any raw client) use the request packers and reply parsers, so a round trip exercises both halves.
"""
import enum
import math
import struct

HEADER = struct.Struct(">HB")
MAX_PACKAGE_SIZE = 0xFFFF
SUPPORTED_PROTOCOL_VERSIONS = (1, 2)

_UINT8 = struct.Struct(">B")
_UINT16 = struct.Struct(">H")
_DOUBLE = struct.Struct(">d")
_VERSION = struct.Struct(">IIII")


class PackageType(enum.IntEnum):
    """RTDE package type byte; a reply carries the type byte of its request."""

    REQUEST_PROTOCOL_VERSION = 86  # 'V'
    GET_URCONTROL_VERSION = 118  # 'v'
    TEXT_MESSAGE = 77  # 'M'
    DATA_PACKAGE = 85  # 'U'
    CONTROL_PACKAGE_SETUP_OUTPUTS = 79  # 'O'
    CONTROL_PACKAGE_SETUP_INPUTS = 73  # 'I'
    CONTROL_PACKAGE_START = 83  # 'S'
    CONTROL_PACKAGE_PAUSE = 80  # 'P'


class MessageLevel(enum.IntEnum):
    """Warning level of a text message (RTDE guide; PYRTDE serialize.Message)."""

    EXCEPTION = 0
    ERROR = 1
    WARNING = 2
    INFO = 3


class ProtocolError(ValueError):
    """Bytes that are not a valid RTDE package or payload."""


# Struct codes per RTDE type name (big-endian, no padding); NOT_FOUND / IN_USE have no layout.
TYPE_CODES = {
    "BOOL": "?",
    "UINT8": "B",
    "UINT32": "I",
    "UINT64": "Q",
    "INT32": "i",
    "DOUBLE": "d",
    "VECTOR3D": "ddd",
    "VECTOR6D": "dddddd",
    "VECTOR6INT32": "iiiiii",
    "VECTOR6UINT32": "IIIIII",
}
NOT_FOUND = "NOT_FOUND"
IN_USE = "IN_USE"


def pack_package(package_type, payload=b""):
    """One RTDE package: header (size counts the 3 header bytes) + payload."""
    size = HEADER.size + len(payload)
    if size > MAX_PACKAGE_SIZE:
        raise ValueError(f"payload: {len(payload)} bytes do not fit one RTDE package (max {MAX_PACKAGE_SIZE - 3})")
    return HEADER.pack(size, int(package_type)) + bytes(payload)


def split_package(buffer):
    """(type, payload, bytes consumed) of the first complete package in buffer, or None if it is incomplete."""
    if len(buffer) < HEADER.size:
        return None
    size, package_type = HEADER.unpack_from(buffer)
    if size < HEADER.size:
        raise ProtocolError(f"package size {size} is smaller than the 3-byte header")
    if len(buffer) < size:
        return None
    return package_type, bytes(buffer[HEADER.size:size]), size


# --- names lists ---------------------------------------------------------------------------------------------------

def parse_variable_names(text):
    """Recipe names from a comma-separated list; a trailing empty element (ur_rtde's trailing comma) is dropped."""
    names = text.split(",")
    if names and names[-1] == "":
        names.pop()
    return names


def join_variable_names(names):
    """Comma-separated names as UR's own clients send them (no trailing comma)."""
    return ",".join(names)


def _decode_names(payload):
    """Names of a setup payload.  No length limit beyond the package's own: UR's guide speaks of "a maximum limit of
    2048 bytes", but URCL's CI sends its exhaustive output recipe (406 names, 9,173 bytes) to URSim 3.14.3, 5.9.4 and
    the latest 5.x in one setup package and gets it streamed."""
    try:
        return parse_variable_names(payload.decode("ascii"))
    except UnicodeDecodeError as error:
        raise ProtocolError(f"variable list is not ASCII: {error}") from None


# --- V: protocol version -------------------------------------------------------------------------------------------

def pack_protocol_version_request(version):
    """V request: uint16 protocol version."""
    return pack_package(PackageType.REQUEST_PROTOCOL_VERSION, _UINT16.pack(version))


def parse_protocol_version_request(payload):
    """Requested protocol version from a V payload (uint16)."""
    if len(payload) != _UINT16.size:
        raise ProtocolError(f"protocol version request needs 2 bytes, got {len(payload)}")
    return _UINT16.unpack(payload)[0]


def pack_accepted_reply(package_type, accepted):
    """Reply of V, S and P: uint8 1 (accepted) or 0, under the request's type byte."""
    return pack_package(package_type, _UINT8.pack(1 if accepted else 0))


def parse_accepted_reply(payload):
    """True if a V/S/P reply payload says accepted."""
    if len(payload) != 1:
        raise ProtocolError(f"accepted reply needs 1 byte, got {len(payload)}")
    return payload[0] != 0


# --- v: controller version -----------------------------------------------------------------------------------------

def pack_controller_version_reply(major, minor, bugfix, build):
    """v reply: uint32 major, minor, bugfix, build."""
    return pack_package(PackageType.GET_URCONTROL_VERSION, _VERSION.pack(major, minor, bugfix, build))


def parse_controller_version_reply(payload):
    """(major, minor, bugfix, build) from a v reply payload."""
    if len(payload) != _VERSION.size:
        raise ProtocolError(f"controller version reply needs 16 bytes, got {len(payload)}")
    return _VERSION.unpack(payload)


# --- O: output recipe ----------------------------------------------------------------------------------------------

def pack_setup_outputs_request(names, frequency, protocol_version):
    """O request: v2 = double frequency + names, v1 = names only (frequency ignored)."""
    text = join_variable_names(names).encode("ascii")
    if protocol_version >= 2:
        return pack_package(PackageType.CONTROL_PACKAGE_SETUP_OUTPUTS, _DOUBLE.pack(frequency) + text)
    return pack_package(PackageType.CONTROL_PACKAGE_SETUP_OUTPUTS, text)


def parse_setup_outputs_request(payload, protocol_version):
    """(frequency in Hz or None for v1, names) from an O payload."""
    if protocol_version >= 2:
        if len(payload) < _DOUBLE.size:
            raise ProtocolError("output setup (protocol 2) needs an 8-byte frequency before the names")
        frequency = _DOUBLE.unpack_from(payload)[0]
        return frequency, _decode_names(payload[_DOUBLE.size:])
    return None, _decode_names(payload)


def pack_setup_outputs_reply(recipe_id, types, protocol_version):
    """O reply: v2 = uint8 recipe id + types, v1 = types only."""
    text = ",".join(types).encode("ascii")
    if protocol_version >= 2:
        return pack_package(PackageType.CONTROL_PACKAGE_SETUP_OUTPUTS, _UINT8.pack(recipe_id) + text)
    return pack_package(PackageType.CONTROL_PACKAGE_SETUP_OUTPUTS, text)


def parse_setup_outputs_reply(payload, protocol_version):
    """(recipe id or None for v1, types) from an O reply payload."""
    if protocol_version >= 2:
        if not payload:
            raise ProtocolError("output setup reply (protocol 2) needs a recipe id")
        return payload[0], payload[1:].decode("ascii").split(",")
    return None, payload.decode("ascii").split(",")


# --- I: input recipe -----------------------------------------------------------------------------------------------

def pack_setup_inputs_request(names):
    """I request: names (same in protocol 1 and 2)."""
    return pack_package(PackageType.CONTROL_PACKAGE_SETUP_INPUTS, join_variable_names(names).encode("ascii"))


def parse_setup_inputs_request(payload):
    """Names from an I payload."""
    return _decode_names(payload)


def pack_setup_inputs_reply(recipe_id, types):
    """I reply: uint8 recipe id (0 = invalid recipe) + types."""
    body = _UINT8.pack(recipe_id) + ",".join(types).encode("ascii")
    return pack_package(PackageType.CONTROL_PACKAGE_SETUP_INPUTS, body)


def setup_reply_size(types: list[str]) -> int:
    """Bytes of the setup reply (O with a recipe id, or I) that lists `types`."""
    return HEADER.size + _UINT8.size + sum(len(name) for name in types) + max(len(types) - 1, 0)


def setup_reply_fits(types: list[str]) -> bool:
    """True when the setup reply listing `types` fits one package. A request's names may be one byte each but every
    reply type takes up to 9 (NOT_FOUND), so a request that fits can ask for a reply that does not."""
    return setup_reply_size(types) <= MAX_PACKAGE_SIZE


def oversized_reply_reason(types: list[str]) -> str:
    """One short line on why a recipe whose setup reply does not fit one package is refused."""
    return (f"{len(types)} variables; the reply listing their types would take {setup_reply_size(types)} bytes, "
            f"more than one RTDE package holds ({MAX_PACKAGE_SIZE})")


def abbreviated(items: list[object], limit: int = 8) -> str:
    """`items` for a log line: the first `limit` of them, then how many more."""
    shown = ", ".join(str(item) for item in items[:limit])
    return f"{shown} and {len(items) - limit} more" if len(items) > limit else shown


def parse_setup_inputs_reply(payload):
    """(recipe id, types) from an I reply payload."""
    if not payload:
        raise ProtocolError("input setup reply needs a recipe id")
    return payload[0], payload[1:].decode("ascii").split(",")


# --- U: data packages ----------------------------------------------------------------------------------------------

def recipe_struct(types):
    """Precompiled big-endian struct of a recipe's values in order (no recipe id).

    ValueError for a type without layout.
    """
    codes = []
    for position, type_name in enumerate(types):
        code = TYPE_CODES.get(type_name)
        if code is None:
            raise ValueError(f"types[{position}]: {type_name!r} has no data layout")
        codes.append(code)
    return struct.Struct(">" + "".join(codes))


def data_package_header(recipe_id, payload_size):
    """Header + optional recipe id byte of a U package whose values take payload_size bytes.

    recipe_id None: a version 1 output package (no recipe id byte).
    """
    if recipe_id is None:
        return HEADER.pack(HEADER.size + payload_size, PackageType.DATA_PACKAGE)
    return HEADER.pack(HEADER.size + 1 + payload_size, PackageType.DATA_PACKAGE) + _UINT8.pack(recipe_id)


def pack_data_package(values_struct, recipe_id, flat_values):
    """U package: header, recipe id (omitted when None: protocol-1 output), flat values packed by values_struct."""
    return data_package_header(recipe_id, values_struct.size) + values_struct.pack(*flat_values)


def parse_data_package(payload, values_struct, has_recipe_id=True):
    """(recipe id or None, flat values) of a U payload laid out by values_struct."""
    body = payload[1:] if has_recipe_id else payload
    if len(body) != values_struct.size:
        raise ProtocolError(f"data package carries {len(body)} value bytes, recipe needs {values_struct.size}")
    return (payload[0] if has_recipe_id else None), values_struct.unpack(body)


def data_package_recipe_id(payload):
    """Recipe id byte of a U payload that carries one."""
    if not payload:
        raise ProtocolError("data package has no recipe id")
    return payload[0]


def group_values(types, flat_values):
    """Values per variable: vectors become tuples, scalars stay scalars (inverse of flattening)."""
    grouped = []
    position = 0
    for type_name in types:
        width = len(TYPE_CODES[type_name])
        if type_name.startswith("VECTOR"):
            grouped.append(tuple(flat_values[position:position + width]))
        else:
            grouped.append(flat_values[position])
        position += width
    return grouped


# --- S / P ---------------------------------------------------------------------------------------------------------

def pack_start_request():
    """S request (empty)."""
    return pack_package(PackageType.CONTROL_PACKAGE_START)


def pack_pause_request():
    """P request (empty)."""
    return pack_package(PackageType.CONTROL_PACKAGE_PAUSE)


def pack_controller_version_request():
    """v request (empty)."""
    return pack_package(PackageType.GET_URCONTROL_VERSION)


# --- M: text messages ----------------------------------------------------------------------------------------------

def pack_text_message(message, source, level, protocol_version):
    """M package to the client: v2 = len-prefixed message and source + level; v1 = level + message (rest)."""
    message_bytes = message.encode("utf-8")[:255]
    if protocol_version >= 2:
        source_bytes = source.encode("utf-8")[:255]
        payload = (_UINT8.pack(len(message_bytes)) + message_bytes + _UINT8.pack(len(source_bytes)) + source_bytes
                   + _UINT8.pack(int(level)))
    else:
        payload = _UINT8.pack(int(level)) + message_bytes
    return pack_package(PackageType.TEXT_MESSAGE, payload)


def parse_text_message(payload, protocol_version=2, from_controller=False):
    """(message, source, level) of an M payload; only a controller's protocol-1 message uses the short layout."""
    if protocol_version < 2 and from_controller:
        if not payload:
            raise ProtocolError("text message has no level byte")
        return payload[1:].decode("utf-8", "replace"), "", payload[0]
    try:
        message_length = payload[0]
        message = payload[1:1 + message_length]
        source_length = payload[1 + message_length]
        source = payload[2 + message_length:2 + message_length + source_length]
        level = payload[2 + message_length + source_length]
    except IndexError:
        raise ProtocolError("text message is shorter than its length bytes say") from None
    return message.decode("utf-8", "replace"), source.decode("utf-8", "replace"), level


# --- frequency -----------------------------------------------------------------------------------------------------

def is_valid_frequency(hz):
    """True for an output frequency the controller accepts: finite and > 0 (above the control rate it is capped)."""
    return isinstance(hz, (int, float)) and math.isfinite(hz) and hz > 0


def output_decimation(requested_hz, control_hz):
    """Control cycles between two output packages: floor(control rate / requested), at least 1 (RTDE guide)."""
    if not is_valid_frequency(requested_hz):
        raise ValueError(f"frequency: {requested_hz!r} Hz is not a positive finite rate")
    return max(1, int(control_hz // requested_hz))
