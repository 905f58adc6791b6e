"""URCL (Universal_Robots_Client_Library) compatibility of the primary interface, checked with a Python re-creation
of URCL's own parser.

`UrclPrimaryParser` below replays, field by field, what URCL's `PrimaryParser` does with the bytes in *strict* mode
(the mode URCL's CI runs against URSim 3.14.3 and 5.9.4): include/ur_client_library/primary/primary_parser.h,
src/primary/robot_state/{robot_mode_data,masterboard_data,kinematics_info,configuration_data}.cpp and
src/primary/robot_message/*.cpp.  A typed sub-package must be consumed *exactly* (strict mode throws "was not parsed
completely"), reading past its end is URCL's "Could not parse received package" exception, and unknown sub-package
types are skipped whole.  Written from URCL's sources, not from sim_ursim's serialisers.
"""
import socket
import struct
import time

import pytest

from sim_ursim import messages
from sim_ursim.controller import Controller, RobotMode
from sim_ursim.launch import running_simulator
from sim_ursim.models import robot_model
from sim_ursim.primary import packets
from sim_ursim.vocabulary import SafetyMode
from tests.polling import wait_for


class UrclParseError(Exception):
    """What URCL raises or logs as a failed parse (its UrException / `return false`)."""


class _Bin:
    """URCL's comm::BinParser over one buffer: big-endian reads that raise past the end."""

    def __init__(self, data):
        self.data = data
        self.pos = 0

    def take(self, fmt):
        size = struct.calcsize(">" + fmt)
        if self.pos + size > len(self.data):
            raise UrclParseError("Could not parse received package")
        values = struct.unpack_from(">" + fmt, self.data, self.pos)
        self.pos += size
        return values if len(values) > 1 else values[0]

    def fits(self, fmt):
        return self.pos + struct.calcsize(">" + fmt) <= len(self.data)

    def remainder(self):
        rest = self.data[self.pos:]
        self.pos = len(self.data)
        return rest

    def empty(self):
        return self.pos >= len(self.data)


def _robot_mode_data(bp):
    """robot_mode_data.cpp: uint64 timestamp, 7 bools, robot mode, control mode (uint8), 3 doubles, remainder."""
    fields = bp.take("Q???????BBddd")
    bp.remainder()
    return {"timestamp": fields[0], "power_on": fields[3], "protective_stopped": fields[5], "robot_mode": fields[8]}


def _masterboard_data(bp):
    """masterboard_data.cpp: 75 bytes without the IMMI (Euromap67) block, 91 with it."""
    fields = bp.take("IIBBddbbddffffBBB")
    if fields[16]:
        bp.take("IIff")
    bp.take("IBBB")  # reserved_1, operational mode selector, three-position enabling device, reserved_2
    return {"digital_input_bits": fields[0], "digital_output_bits": fields[1], "safety_mode": fields[14]}


def _kinematics_info(bp):
    """kinematics_info.cpp: uint32 checksum[6], dh theta, a, d, alpha (double[6] each), uint32 calibration status."""
    bp.take("6I")
    theta, a, d, alpha = (bp.take("6d") for _ in range(4))
    bp.take("I")
    return {"dh_theta": theta, "dh_a": a, "dh_d": d, "dh_alpha": alpha}


def _configuration_data(bp):
    """configuration_data.cpp: limits, defaults, DH, 4 int32 type codes, then two optional int16 reserved."""
    bp.take("12d")
    bp.take("12d")
    bp.take("5d")
    for _ in range(4):
        bp.take("6d")
    codes = bp.take("4i")
    for _ in range(2):
        if bp.fits("h"):
            bp.take("h")
    return {"robot_type": codes[2], "robot_sub_type": codes[3]}


STATE_PARSERS = {0: _robot_mode_data, 3: _masterboard_data, 5: _kinematics_info, 6: _configuration_data}


def _version_message(bp):
    """version_message.cpp: int8 name length, name, uint8 major, minor, int32 svn, int32 build, build date."""
    length = bp.take("b")
    name = bytes(bp.take(f"{length}s"))
    major, minor, bugfix, build = bp.take("BBii")
    return {"project": name, "version": (major, minor, bugfix, build), "date": bp.remainder().decode()}


def _text_remainder(head):
    def parse(bp):
        values = bp.take(head) if head else ()
        return {"head": values, "text": bp.remainder().decode("utf-8", "replace")}

    return parse


def _key_message(bp):
    code, argument, title_length = bp.take("iiB")
    title = bytes(bp.take(f"{title_length}s")) if title_length else b""
    return {"code": code, "argument": argument, "title": title.decode(), "text": bp.remainder().decode()}


MESSAGE_PARSERS = {
    0: _text_remainder(""),
    3: _version_message,
    5: lambda bp: {"head": bp.take("iiBII")},
    6: _text_remainder("iiiII"),
    7: _key_message,
    10: _text_remainder("ii"),
}


def urcl_parse(message):
    """One primary message as URCL's strict PrimaryParser reads it: a list of (kind, fields) pairs."""
    bp = _Bin(message)
    size, kind = bp.take("iB")
    if size != len(message):
        raise UrclParseError(f"message header says {size} bytes, got {len(message)}")
    parsed = []
    if kind == packets.ROBOT_STATE:
        while not bp.empty():
            if not bp.fits("I"):
                raise UrclParseError("Failed to read sub-package length")
            sub_size = struct.unpack_from(">I", message, bp.pos)[0]
            if bp.pos + sub_size > len(message):
                raise UrclParseError(f"Invalid sub-package size of {sub_size} received!")
            sub = _Bin(message[bp.pos + 5:bp.pos + sub_size])
            sub_type = message[bp.pos + 4]
            bp.pos += sub_size
            if sub_type in STATE_PARSERS:
                fields = STATE_PARSERS[sub_type](sub)
                if not sub.empty():
                    raise UrclParseError(
                        f"Sub-package of type {sub_type} was not parsed completely "
                        f"({len(sub.data) - sub.pos} bytes left), and strict mode is enabled"
                    )
                parsed.append((("state", sub_type), fields))
            else:
                parsed.append((("state", sub_type), None))
    elif kind == packets.ROBOT_MESSAGE:
        _timestamp, _source, message_type = bp.take("QbB")
        parser = MESSAGE_PARSERS.get(message_type, lambda b: {"raw": b.remainder()})
        parsed.append((("message", message_type), parser(bp)))
    return parsed


CB3_3_14 = (3, 14, 3, 0)
CB3_3_15 = (3, 15, 8, 106339)
E_5_9 = (5, 9, 4, 0)
E_5_11 = (5, 11, 1, 108318)


def _state():
    return Controller(model="ur3").state()


@pytest.mark.parametrize("version", [CB3_3_14, CB3_3_15, E_5_9, E_5_11])
def test_every_robot_state_sub_package_passes_urcl_strict_parsing(version):
    model = robot_model("ur3e" if packets.is_e_series(version) else "ur3")
    message = packets.robot_state_message(_state(), packets.arm_description(model), version)
    parsed = dict(urcl_parse(message))
    assert set(parsed) >= {("state", 0), ("state", 3), ("state", 5), ("state", 6)}
    assert parsed[("state", 6)]["robot_sub_type"] == (3 if packets.is_e_series(version) else 2)


def test_cb3_masterboard_data_is_75_bytes_like_urcl_parses():
    body = packets.masterboard_data(_state(), CB3_3_15)
    assert len(body) == 75
    assert urcl_parse(packets.frame(packets.ROBOT_STATE, body))[0][1]["safety_mode"] == 1


def test_a_74_byte_masterboard_fails_urcl_like_the_old_simulator_did():
    """The parser re-creation is able to fail: the former CB3 layout (no trailing reserved byte) is refused."""
    short = packets.masterboard_data(_state(), CB3_3_15)[:-1]
    short = struct.pack(">i", len(short)) + short[4:]
    with pytest.raises(UrclParseError, match="Could not parse"):
        urcl_parse(packets.frame(packets.ROBOT_STATE, short))


def test_robot_messages_parse_like_urcl():
    version_bytes = packets.version_message(CB3_3_15, "20-06-2022, 00:00:00")
    assert urcl_parse(version_bytes)[0][1]["version"] == (3, 15, 8, 106339)
    key = messages.KeyMessage(code=0, argument=0, title="PROGRAM_XXX_STARTED", text="myprog")
    fields = urcl_parse(packets.encode_robot_message(key, CB3_3_15, 5))[0][1]
    assert fields["title"] == "PROGRAM_XXX_STARTED" and fields["text"] == "myprog"


def _read_messages(sock, count, timeout=5.0):
    """`count` whole primary messages from a connected socket."""
    sock.settimeout(timeout)
    buffer = b""
    found = []
    while len(found) < count:
        chunk = sock.recv(65536)
        if not chunk:
            raise ConnectionError("primary port closed")
        buffer += chunk
        while len(buffer) >= 4 and len(buffer) >= struct.unpack_from(">i", buffer)[0]:
            size = struct.unpack_from(">i", buffer)[0]
            found.append(buffer[:size])
            buffer = buffer[size:]
    return found


@pytest.mark.parametrize("model, version", [("ur3", "3.14.3"), ("ur3", "3.15.8"), ("ur5e", "5.9.4"), ("ur5e", None)])
def test_live_primary_stream_parses_with_urcl_strict_parser(model, version):
    with running_simulator(model=model, version=version) as sim:
        with socket.create_connection((sim.host, 30001), timeout=5) as sock:
            received = _read_messages(sock, 4)
    kinds = [kind for message in received for kind, _ in urcl_parse(message)]
    assert kinds[0] == ("message", packets.VERSION_MESSAGE)
    assert ("state", packets.MASTERBOARD_DATA) in kinds and ("state", packets.CONFIGURATION_DATA) in kinds


# --- primary-port commands, sent the way URCL's PrimaryClient::sendScript does ("<command>\n") ------------------

def test_primary_commands_power_brakes_unlock_and_stop_like_urcl_primary_client():
    # One connection kept open, as URCL's PrimaryClient does (a close right after the write is issue 15 item 7).
    with running_simulator(model="ur5e", unlock_delay=0.0) as sim, \
            socket.create_connection((sim.host, 30001), timeout=5) as sock:
        controller = sim.controller
        exceptions = controller.messages.subscribe()

        def _send_primary(_host, text):
            sock.sendall(text.encode() + b"\n")

        _send_primary(sim.host, "power on")
        assert wait_for(lambda: controller.state().robot_mode == RobotMode.IDLE, timeout=5)
        _send_primary(sim.host, "set robotmode run")
        assert wait_for(lambda: controller.state().robot_mode == RobotMode.RUNNING, timeout=5)
        controller.run_program("def waiting():\n  sleep(30)\nend\n", "test")
        assert wait_for(lambda: controller.state().program_running, timeout=5)
        _send_primary(sim.host, "stop program")
        assert wait_for(lambda: not controller.state().program_running, timeout=5)
        controller.protective_stop("test")
        assert controller.state().protective_stopped
        _send_primary(sim.host, "set unlock protective stop")
        assert wait_for(lambda: not controller.state().protective_stopped, timeout=5)
        _send_primary(sim.host, "power off")
        assert wait_for(lambda: controller.state().robot_mode == RobotMode.POWER_OFF, timeout=5)
        received = []
        while not exceptions.empty():
            received.append(exceptions.get_nowait())
    assert not [m for m in received if isinstance(m, messages.RuntimeExceptionMessage)]


def test_a_primary_unlock_clears_a_stop_at_once_the_dashboard_keeps_the_5_s_rule():
    """URCL's PrimaryClientTest unlocks through the primary interface right after a protective stop and waits up to
    5 s for it to clear; the dashboard (PolyScope) refuses within 5 s."""
    with running_simulator(model="ur5e") as sim, socket.create_connection((sim.host, 30001), timeout=5) as sock:
        controller = sim.controller
        controller.power_up()
        controller.protective_stop("test")
        with socket.create_connection((sim.host, 29999), timeout=5) as dashboard:
            reader = dashboard.makefile("r", encoding="utf-8")
            reader.readline()
            dashboard.sendall(b"unlock protective stop\n")
            assert reader.readline().startswith("Cannot unlock protective stop until 5s after occurrence")
        assert controller.state().protective_stopped
        stopped_at = time.monotonic()
        sock.sendall(b"set unlock protective stop\n")
        assert wait_for(lambda: not controller.state().protective_stopped, timeout=5)
        assert time.monotonic() - stopped_at < 1.0
        assert controller.state().safety_mode == SafetyMode.NORMAL


def test_primary_command_mixed_with_urscript_stays_urscript():
    from sim_ursim.primary import commands

    assert commands.parse_commands("power on\n\nset robotmode run\n") == ["power on", "set robotmode run"]
    assert commands.parse_commands("power on\nmovej([0,0,0,0,0,0])\n") is None
    assert commands.parse_commands("textmsg(\"power on\")\n") is None


def test_protective_stop_flag_goes_out_with_the_safety_mode_message():
    """URCL reads RobotModeData.is_protective_stopped_ (commandUnlockProtectiveStop waits on it): the state that
    shows the stop must not trail the safety-mode message by a 10 Hz state period."""
    with running_simulator(model="ur5e") as sim, socket.create_connection((sim.host, 30001), timeout=5) as sock:
        sim.controller.power_up()
        _read_messages(sock, 3)
        sim.controller.protective_stop("test")
        stream = []
        while not any(kind == ("message", packets.SAFETY_MODE_MESSAGE) for kind, _ in stream):
            for message in _read_messages(sock, 1):
                stream.extend(urcl_parse(message))
        safety_at = next(i for i, (kind, _) in enumerate(stream) if kind == ("message", packets.SAFETY_MODE_MESSAGE))
        modes_before = [fields for kind, fields in stream[:safety_at] if kind == ("state", packets.ROBOT_MODE_DATA)]
    assert modes_before and modes_before[-1]["protective_stopped"] is True


@pytest.mark.parametrize("motion", ["movel(p[2.0, 0, 0.3, 0, 3.14, 0])", "movep(p[2.0, 0, 0.3, 0, 3.14, 0])",
                                    "movec(p[0.5, 0.5, 0.3, 0, 3.14, 0], p[2.0, 0, 0.3, 0, 3.14, 0])"])
def test_unreachable_target_is_a_robot_error_with_a_protective_stop(motion):
    """Issue 15 §11: URCL's clients see an error-code message (ErrorCodeMessage, logged as C209A0 by URCL) and the
    protective-stop flag, not a URScript runtime exception."""
    with running_simulator(model="ur5e") as sim:
        sim.controller.power_up()
        bus = sim.controller.messages.subscribe()
        assert sim.controller.run_program(f"def unreachable():\n  {motion}\nend\n", "test")
        assert wait_for(lambda: sim.controller.state().protective_stopped, timeout=5)
        assert wait_for(lambda: not sim.controller.state().program_running, timeout=5)
        received = []
        while not bus.empty():
            received.append(bus.get_nowait())
    errors = [m for m in received if isinstance(m, messages.ErrorCodeMessage)]
    assert errors and errors[0].code == 209 and "unreachable" in errors[0].text
    assert not [m for m in received if isinstance(m, messages.RuntimeExceptionMessage)]


def test_a_movej_to_a_pose_no_joints_reach_is_a_runtime_exception_without_a_stop():
    """URCL's PrimaryClientTest.test_send_script_blocking_fail_on_runtime_exception: movej(p[10,0,0,0,0,0]) is a
    runtime exception ("non-invertible goal"), while the same movel is a robot error code (protective stop)."""
    with running_simulator(model="ur5e") as sim:
        sim.controller.power_up()
        bus = sim.controller.messages.subscribe()
        assert sim.controller.run_program("def unreachable():\n  movej(p[10, 0, 0, 0, 0, 0])\nend\n", "test")
        assert wait_for(lambda: not sim.controller.state().program_running, timeout=5)
        received = []
        while not bus.empty():
            received.append(bus.get_nowait())
        assert not sim.controller.state().protective_stopped
    assert [m for m in received if isinstance(m, messages.RuntimeExceptionMessage)]
    assert not [m for m in received if isinstance(m, messages.ErrorCodeMessage)]
