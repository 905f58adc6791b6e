"""Ports 30001 / 30002 / 30003 over real sockets: streams, fault injection, URScript from raw sockets, and what
ur_rtde's RTDE clients see while those scripts run.  Bytes are read with struct layouts written here."""
import ast
import logging
import re
import socket
import struct
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from polling import wait_for
from sim_ursim.launch import running_simulator, simulator_process
from sim_ursim.messages import TextMessage
from sim_ursim.primary import server as server_module
from sim_ursim.primary.script_intake import MAX_PENDING_BYTES

PRIMARY, SECONDARY, REALTIME, DASHBOARD = 30001, 30002, 30003, 29999
ROBOT_STATE, ROBOT_MESSAGE = 16, 20
TEXT, POPUP, VERSION, SAFETY_MODE, ERROR_CODE, KEY, RUNTIME_EXCEPTION = 0, 2, 3, 5, 6, 7, 10
PLAYING, STOPPED = 2, 1


@pytest.fixture
def sim():
    with running_simulator(model="ur3") as simulator:
        yield simulator


@pytest.fixture
def powered_sim(sim):
    sim.controller.power_up()
    return sim


class Client:
    """A raw TCP client that reads size-prefixed messages (int32 total size first, as on 30001–30003)."""

    def __init__(self, host, port, timeout=3.0):
        self.sock = socket.create_connection((host, port), timeout=timeout)
        self.buffer = b""

    def read_exactly(self, count):
        while len(self.buffer) < count:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("closed by the server")
            self.buffer += chunk
        data, self.buffer = self.buffer[:count], self.buffer[count:]
        return data

    def message(self):
        """The next whole message (its bytes, size field included)."""
        head = self.read_exactly(4)
        (size,) = struct.unpack(">i", head)
        return head + self.read_exactly(size - 4)

    def send(self, text):
        self.sock.sendall(text.encode())

    def robot_messages(self, predicate, timeout):
        """Robot messages (subtype, text-bearing body) until one satisfies predicate(subtype, data); all of them."""
        seen = []
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            data = self.message()
            if data[4] != ROBOT_MESSAGE:
                continue
            subtype = data[14]
            seen.append((subtype, data))
            if predicate(subtype, data):
                return seen
        raise AssertionError(f"no matching robot message within {timeout} s; saw {[s for s, _ in seen]}")

    def close(self):
        self.sock.close()


@pytest.fixture
def clients():
    opened = []

    def _open(host, port, **kwargs):
        client = Client(host, port, **kwargs)
        opened.append(client)
        return client

    yield _open
    for client in opened:
        client.close()


def robot_mode_of(state_message):
    """Robot mode byte of a robot-state message (RobotModeData is the first sub-package)."""
    assert state_message[4] == ROBOT_STATE and state_message[9] == 0
    return state_message[5 + 5 + 8 + 7]


def next_state(client):
    while True:
        data = client.message()
        if data[4] == ROBOT_STATE:
            return data


# --- streams --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("port", [PRIMARY, SECONDARY])
def test_version_message_first_then_robot_state_at_10_hz(sim, clients, port):
    client = clients(sim.host, port)
    first = client.message()
    assert (first[4], first[14]) == (ROBOT_MESSAGE, VERSION)
    name_length = first[15]
    assert first[16:16 + name_length] == b"URControl"
    assert tuple(first[16 + name_length:18 + name_length]) == (3, 15)
    started = time.monotonic()
    states = [next_state(client) for _ in range(10)]
    elapsed = time.monotonic() - started
    assert 0.6 < elapsed < 3.0  # ten packets at 10 Hz (0.9 s), generous for a loaded 2-core machine
    assert all(len(s) <= 2000 for s in states)


def test_robot_state_follows_power_up(sim, clients):
    client = clients(sim.host, SECONDARY)
    assert robot_mode_of(next_state(client)) == 3  # POWER_OFF
    sim.controller.power_up()
    deadline = time.monotonic() + 3
    while robot_mode_of(next_state(client)) != 7:  # RUNNING
        assert time.monotonic() < deadline


def test_bus_messages_reach_30001_but_not_30002(sim, clients):
    primary, secondary = clients(sim.host, PRIMARY), clients(sim.host, SECONDARY)
    next_state(primary), next_state(secondary)
    sim.controller.messages.publish(TextMessage("hello from the bus"))
    found = primary.robot_messages(lambda subtype, data: subtype == TEXT, timeout=2)
    assert found[-1][1].endswith(b"hello from the bus")
    deadline = time.monotonic() + 0.5
    while time.monotonic() < deadline:
        data = secondary.message()
        assert data[4] == ROBOT_STATE


def test_a_protective_stop_is_announced_on_30001_and_flagged_in_the_state(powered_sim, clients):
    primary = clients(powered_sim.host, PRIMARY)
    next_state(primary)
    powered_sim.controller.protective_stop("test")
    seen = primary.robot_messages(lambda s, d: s == ERROR_CODE, timeout=3)
    safety = [data for subtype, data in seen if subtype == SAFETY_MODE]
    assert safety and struct.unpack_from(">iiB", safety[0], 15)[2] == 3  # PROTECTIVE_STOP
    code, _, report_level = struct.unpack_from(">iii", seen[-1][1], 15)
    assert (code, report_level) == (209, 2) and b"Protective stop" in seen[-1][1]
    robot_mode_data = next_state(primary)[5:]
    assert struct.unpack_from(">?", robot_mode_data, 5 + 8 + 4)[0] is True  # isProtectiveStopped


def test_a_primary_client_that_stops_reading_is_disconnected(sim):
    silent = socket.socket()
    silent.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    silent.connect((sim.host, PRIMARY))
    try:
        silent.settimeout(3.0)
        assert silent.recv(4)  # the version message has come, and the writer subscribes to the bus before it
        for _ in range(300):  # 2.4 MB of robot messages: far more than the socket buffers hold
            sim.controller.messages.publish(TextMessage("x" * 8000))
        server = sim.servers["primary"]
        assert wait_for(lambda: not server.connections(), timeout=server_module.SEND_TIMEOUT + 10.0)
        with pytest.raises((ConnectionError, OSError)):
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline:  # drain what was buffered; the server has hung up behind it
                if not silent.recv(65536):
                    raise ConnectionError("closed by the server")
    finally:
        silent.close()


def test_frozen_streams_send_nothing_then_resume(sim, clients):
    client = clients(sim.host, SECONDARY)
    next_state(client)
    sim.controller.faults.freeze_streams(0.8)
    client.buffer = b""
    client.sock.settimeout(0.3)
    with pytest.raises(socket.timeout):
        while True:  # what was already in flight may still arrive, then silence
            client.message()
    client.sock.settimeout(3.0)
    client.buffer = b""
    assert next_state(client)[4] == ROBOT_STATE


def test_latency_delays_the_first_message(sim, clients):
    sim.controller.faults.add_latency(0.4)
    started = time.monotonic()
    client = clients(sim.host, PRIMARY)
    client.message()
    assert time.monotonic() - started >= 0.35


def test_drop_connections_closes_every_client_and_new_ones_are_served(sim, clients):
    primary, realtime = clients(sim.host, PRIMARY), clients(sim.host, REALTIME)
    next_state(primary), realtime.message()
    sim.controller.faults.drop_connections()
    for client in (primary, realtime):
        with pytest.raises((ConnectionError, OSError)):
            for _ in range(2000):
                client.message()
    assert next_state(clients(sim.host, PRIMARY))[4] == ROBOT_STATE


# --- realtime -------------------------------------------------------------------------------------------------

def test_realtime_streams_the_3_15_package_at_about_125_hz(sim, clients):
    client = clients(sim.host, REALTIME)
    first = client.message()
    assert len(first) == 1116
    times = [struct.unpack_from(">d", first, 4)[0]]
    started = time.monotonic()
    while time.monotonic() - started < 1.0:
        times.append(struct.unpack_from(">d", client.message(), 4)[0])
    assert len(times) > 40  # 125 expected; a busy machine makes the controller merge cycles
    assert_cycle_steps(np.diff(times), period=0.008)


def test_realtime_e_series_package_is_1220_bytes_at_500_hz(clients):
    with running_simulator(model="ur3e") as simulator:
        client = clients(simulator.host, REALTIME)
        first = client.message()
        assert len(first) == 1220
        times = [struct.unpack_from(">d", client.message(), 4)[0] for _ in range(50)]
        assert_cycle_steps(np.diff(times), period=0.002)


def test_a_frozen_realtime_stream_leaves_a_gap_in_controller_time(sim, clients):
    client = clients(sim.host, REALTIME)
    times = [struct.unpack_from(">d", client.message(), 4)[0]]
    frozen_at = sim.controller.state().timestamp
    sim.controller.faults.freeze_streams(0.5)
    while times[-1] < frozen_at + 0.6:  # every package is sent, so the ones before the freeze may still be queued
        times.append(struct.unpack_from(">d", client.message(), 4)[0])
    assert np.max(np.diff(times)) >= 0.4


def assert_cycle_steps(steps, period):
    """One package per control cycle: controller time advances by whole periods, and by exactly one at least once."""
    cycles = steps / period
    assert np.allclose(cycles, np.round(cycles), atol=1e-6) and np.all(cycles >= 1 - 1e-6)
    assert np.min(steps) == pytest.approx(period, abs=1e-9)


def test_a_client_that_never_reads_is_discontinued_but_can_still_send_scripts(sim, clients):
    silent = socket.socket()
    silent.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    silent.connect((sim.host, REALTIME))
    try:
        reader = clients(sim.host, REALTIME)
        server = sim.servers["realtime"]
        deadline = time.monotonic() + 30
        received = 0
        while server.discontinued_count() == 0:
            reader.message()
            received += 1
            assert time.monotonic() < deadline, "the silent client was never discontinued"
        # The reader kept its stream the whole time, and keeps it now.
        started = time.monotonic()
        for _ in range(25):
            reader.message()
        assert time.monotonic() - started < 2.0
        silent.sendall(b"write_output_integer_register(5, 42)\n")
        assert wait_for(lambda: sim.controller.state().output_int_registers[5] == 42, timeout=3)
    finally:
        silent.close()


# --- URScript from raw sockets --------------------------------------------------------------------------------

def test_key_messages_mark_program_start_and_stop(sim, clients):
    primary = clients(sim.host, PRIMARY)
    next_state(primary)
    clients(sim.host, SECONDARY).send("def keyed():\n  sleep(0.2)\nend\n")
    seen = primary.robot_messages(lambda s, d: s == KEY and b"STOPPED" in d, timeout=5)
    keys = [data for subtype, data in seen if subtype == KEY]
    assert b"PROGRAM_XXX_STARTED" in keys[0] and keys[0].endswith(b"keyed")
    assert b"PROGRAM_XXX_STOPPED" in keys[-1]


def test_multi_line_program_with_a_thread(sim, clients):
    primary = clients(sim.host, PRIMARY)
    next_state(primary)
    program = textwrap.dedent(
        """\
        def counting_program():
          global counter = 0
          thread counter_thread():
            while counter < 5:
              counter = counter + 1
              write_output_integer_register(3, counter)
              sleep(0.02)
            end
          end
          handle = run counter_thread()
          join handle
          textmsg("counted ", counter)
        end
        """
    )
    primary.send(program)
    seen = primary.robot_messages(lambda s, d: s == TEXT, timeout=5)
    assert seen[-1][1].endswith(b"counted 5")
    assert sim.controller.state().output_int_registers[3] == 5


def program_window(realtime_client, timeout):
    """Controller times (s) at which the realtime program-state field turned PLAYING and back to STOPPED, and the
    joints of the last package."""
    started = ended = None
    deadline = time.monotonic() + timeout
    while ended is None:
        assert time.monotonic() < deadline, "program did not finish"
        data = realtime_client.message()
        values = struct.unpack(f">{(len(data) - 4) // 8}d", data[4:])
        program_state, timestamp = values[131], values[0]
        if started is None and program_state == PLAYING:
            started = timestamp
        elif started is not None and program_state == STOPPED:
            ended = timestamp
    return ended - started, values[31:37]


def test_a_blended_sequence_of_moves_is_faster_than_stopping_at_each(powered_sim, clients):
    waypoints = ["[0.6, -1.2, 1.0, -1.4, -1.5, 0.2]", "[0.9, -1.0, 0.8, -1.4, -1.5, 0.2]",
                 "[1.2, -1.2, 1.0, -1.4, -1.5, 0.2]"]
    durations = {}
    for radius in (0.0, 0.05):
        # Back to the start quickly: only the program's own moves are timed.
        powered_sim.controller.movej([0.3, -1.2, 1.0, -1.4, -1.5, 0.2], a=10.0, v=3.0).wait(timeout=10)
        moves = "".join(f"  movej({q}, a=2.0, v=1.0, r={radius if i < 2 else 0})\n" for i, q in enumerate(waypoints))
        realtime = clients(powered_sim.host, REALTIME)
        clients(powered_sim.host, SECONDARY).send(f"def sequence():\n{moves}end\n")
        durations[radius], final_q = program_window(realtime, timeout=15)
        assert list(final_q) == pytest.approx([1.2, -1.2, 1.0, -1.4, -1.5, 0.2], abs=1e-4)
    assert durations[0.05] < durations[0.0] - 0.1


def test_a_runtime_error_is_reported_on_30001_and_stops_the_program(sim, clients):
    primary = clients(sim.host, PRIMARY)
    next_state(primary)
    primary.send("def failing():\n  values = [1, 2]\n  x = values[5]\n  textmsg(\"not reached\")\nend\n")
    seen = primary.robot_messages(lambda s, d: s == RUNTIME_EXCEPTION, timeout=5)
    data = seen[-1][1]
    line, column = struct.unpack_from(">II", data, 15)
    assert line == 3 and b"runtime_error" in data[23:]
    assert data[13] == 256 - 3  # source -3
    assert wait_for(lambda: sim.controller.state().runtime_state == STOPPED, timeout=2)
    assert not any(subtype == TEXT for subtype, _ in seen)


def test_a_urscript_popup_reaches_30001_in_the_cb3_layout(sim, clients):
    primary = clients(sim.host, PRIMARY)
    next_state(primary)
    primary.send("popup(\"Check the gripper\", title=\"Attention\", warning=True)\n")
    data = primary.robot_messages(lambda s, d: s == POPUP, timeout=5)[-1][1]
    warning, error, title_length = struct.unpack_from(">??B", data, 15)
    assert (warning, error) == (True, False)
    assert data[18:18 + title_length] == b"Attention" and data[18 + title_length:] == b"Check the gripper"


def test_a_compile_error_names_the_unknown_function(sim, clients):
    primary = clients(sim.host, PRIMARY)
    next_state(primary)
    primary.send("def typo():\n  txtmsg(\"x\")\nend\n")
    seen = primary.robot_messages(lambda s, d: s == RUNTIME_EXCEPTION, timeout=5)
    assert b"txtmsg" in seen[-1][1]


def test_a_new_program_replaces_the_running_one(sim, clients):
    sender = clients(sim.host, PRIMARY)
    sender.send("def first():\n  sleep(30)\nend\n")
    assert wait_for(lambda: sim.controller.state().runtime_state == PLAYING, timeout=3)
    sender.send("def second():\n  write_output_integer_register(7, 2)\nend\n")
    assert wait_for(lambda: sim.controller.state().output_int_registers[7] == 2, timeout=3)
    assert wait_for(lambda: sim.controller.state().runtime_state == STOPPED, timeout=3)


def test_statement_lines_run_as_a_program(sim, clients):
    clients(sim.host, REALTIME).send("write_output_integer_register(1, 11)\nwrite_output_integer_register(2, 22)\n")
    assert wait_for(lambda: list(sim.controller.state().output_int_registers[1:3]) == [11, 22], timeout=3)


# --- ur_rtde watching URScript sent on raw sockets (simulator in a subprocess: ur_rtde holds the GIL) -----------

def dashboard(host, *commands):
    with socket.create_connection((host, DASHBOARD), timeout=3) as sock:
        reader = sock.makefile("r")
        reader.readline()
        replies = []
        for command in commands:
            sock.sendall(command.encode() + b"\n")
            replies.append(reader.readline().strip())
        return replies


def run_child(code, timeout=40):
    """Run `code` in a fresh interpreter (ur_rtde blocks with the GIL held); its stdout, or the failure."""
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


def test_ur_rtde_receive_watches_a_urscript_movej_from_start_to_finish():
    target = [0.4, -1.3, 1.1, -1.2, -1.4, 0.3]
    with simulator_process(model="ur3") as process:
        dashboard(process.host, "power on", "brake release")
        code = textwrap.dedent(
            f"""
            import socket, time
            import rtde_receive
            receiver = rtde_receive.RTDEReceiveInterface({process.host!r})
            deadline = time.monotonic() + 5
            while receiver.getRobotMode() != 7:
                assert time.monotonic() < deadline, "never RUNNING"
                time.sleep(0.01)
            script = socket.create_connection(({process.host!r}, 30002))
            script.sendall(b"movej({target}, a=2.0, v=1.5)\\n")
            states, bits, first_move = [], [], None
            deadline = time.monotonic() + 15
            while True:
                assert time.monotonic() < deadline, "movej never finished"
                state, status = receiver.getRuntimeState(), receiver.getRobotStatus()
                q = receiver.getActualQ()
                if not states or states[-1] != state:
                    states.append(state)
                bits.append(status)
                if state == 2 and first_move is None and any(abs(a - b) > 1e-6 for a, b in zip(q, [0.0] * 6)):
                    first_move = q
                if len(states) >= 2 and state == 1:
                    break
                time.sleep(0.004)
            print(states)
            print(sorted(set(bits)))
            print(first_move is not None)
            print(receiver.getActualQ())
            receiver.disconnect()
            script.close()
            """
        )
        states, bits, moved, final_q = run_child(code).strip().splitlines()
    assert ast.literal_eval(states)[-2:] == [2, 1]  # PLAYING, then STOPPED
    assert 3 in ast.literal_eval(bits)  # power on + program running (robot_status_bits bits 0 and 1) while it ran
    assert moved == "True"
    assert ast.literal_eval(final_q) == pytest.approx(target, abs=1e-4)


def test_register_handshake_with_a_raw_script_observed_over_rtde():
    with simulator_process(model="ur3") as process:
        code = textwrap.dedent(
            f"""
            import socket, time
            import rtde_io, rtde_receive
            receiver = rtde_receive.RTDEReceiveInterface({process.host!r})
            io = rtde_io.RTDEIOInterface({process.host!r})
            script = socket.create_connection(({process.host!r}, 30001))
            script.sendall(
                b"def handshake():\\n"
                b"  write_output_integer_register(12, 1)\\n"
                b"  while read_input_integer_register(18) != 7:\\n"
                b"    sync()\\n"
                b"  end\\n"
                b"  write_output_float_register(12, read_input_integer_register(18) * 0.5)\\n"
                b"  write_output_integer_register(12, 2)\\n"
                b"end\\n")
            def wait_register(value):
                deadline = time.monotonic() + 5
                while receiver.getOutputIntRegister(12) != value:
                    assert time.monotonic() < deadline, f"register 12 never became {{value}}"
                    time.sleep(0.004)
            wait_register(1)
            print(receiver.getRuntimeState())
            io.setInputIntRegister(18, 7)
            wait_register(2)
            print(receiver.getOutputDoubleRegister(12))
            io.disconnect(); receiver.disconnect(); script.close()
            """
        )
        playing, doubled = run_child(code).strip().splitlines()
    assert playing == "2"
    assert float(doubled) == 3.5


def test_ur_rtde_control_uploads_its_script_on_30003_and_moves_the_arm():
    """RTDEControlInterface sends its ~38 kB control script on 30003 (never reading that socket); the script must
    arrive as one program and run: moveJ returns only after the script reports the command done."""
    target = [0.3, -1.2, 1.0, -1.4, -1.5, 0.2]
    with simulator_process(model="ur3") as process:
        dashboard(process.host, "power on", "brake release")
        code = textwrap.dedent(
            f"""
            import time
            import rtde_control, rtde_receive
            receiver = rtde_receive.RTDEReceiveInterface({process.host!r})
            deadline = time.monotonic() + 5
            while receiver.getRobotMode() != 7:
                assert time.monotonic() < deadline, "never RUNNING"
                time.sleep(0.01)
            control = rtde_control.RTDEControlInterface({process.host!r})
            print(control.isProgramRunning())
            print(control.moveJ({target}, 1.5, 2.0))
            print(receiver.getActualQ())
            control.stopScript()
            control.disconnect(); receiver.disconnect()
            """
        )
        running, moved, final_q = run_child(code).strip().splitlines()
    assert (running, moved) == ("True", "True")
    assert ast.literal_eval(final_q) == pytest.approx(target, abs=1e-4)


def test_delay_line_releases_items_in_order_when_due():
    line = server_module.DelayLine()
    assert line.next_due == float("inf") and line.take_due(100.0) == []
    line.put(b"a", 1.0)
    line.put(b"b", 1.5)
    assert line.next_due == 1.0
    assert line.take_due(0.9) == []
    assert line.take_due(1.2) == [b"a"]
    assert line.take_due(2.0) == [b"b"]


# ------------------------------------------------------------------------- sent then closed; bounded intake


@pytest.mark.parametrize("port", [PRIMARY, SECONDARY, REALTIME])
def test_a_program_sent_then_closed_at_once_always_runs(sim, port):
    """Data received before the client closed is processed, whatever the writer thread saw (issue 14 item 2): the
    client closes without reading the server's greeting/state, so the close is a reset on 30001/30002."""
    for n in range(1, 61):
        with socket.create_connection((sim.host, port), timeout=3.0) as sock:
            sock.sendall(f"write_output_integer_register(7, {n})\n".encode())
        assert wait_for(lambda n=n: sim.controller.state().output_int_registers[7] == n, timeout=3.0), (
            f"program {n} sent to {port} then closed did not run")


def _flood_until_dropped(host, port, opening, line, limit_bytes):
    """Send `opening`, then `line` repeatedly; the number of bytes sent when the server dropped the connection
    (None if it never did within limit_bytes)."""
    sent = 0
    with socket.create_connection((host, port), timeout=3.0) as sock:
        sock.sendall(opening)
        chunk = line * (65536 // len(line))
        try:
            while sent < limit_bytes:
                sock.sendall(chunk)
                sent += len(chunk)
        except (BrokenPipeError, ConnectionResetError):
            return sent
        sock.settimeout(5.0)
        try:  # everything sent: the drop shows as the end of the stream (or a reset) while reading
            while sock.recv(65536):
                pass
        except ConnectionResetError:
            pass
        except TimeoutError:
            return None
        return sent


@pytest.mark.parametrize("port, opening, line", [
    (SECONDARY, b"textmsg((\n", b"1,\n"),  # an unclosed bracket followed by many lines
    (REALTIME, b"def never_ends():\n", b"  textmsg(1)\n"),  # an unclosed block
    (PRIMARY, b"", b"x" * 1024),  # one endless line
])
def test_a_client_flooding_an_incomplete_program_is_dropped_and_others_are_served(sim, port, opening, line,
                                                                                  caplog):
    """What a 30001-30003 connection may hold is bounded (issue 10 item 8): the offender is dropped, and a
    well-behaved client's program still runs. What the server held is read from its own drop message: the
    client's count of bytes sent also holds what sat in the two kernel buffers, which autotuning grows to
    megabytes when the reader is slow (a loaded machine)."""
    limit = MAX_PENDING_BYTES

    def held_when_dropped():  # the byte counts of the server's drop messages so far
        return [int(match.group(1)) for record in caplog.records
                for match in [re.search(r"dropped: (\d+) bytes", record.getMessage())] if match]

    with caplog.at_level(logging.WARNING, logger="sim_ursim.primary.server"):
        sent = _flood_until_dropped(sim.host, port, opening, line, 4 * limit)
        assert sent is not None, f"not dropped after {4 * limit} bytes"
        assert wait_for(held_when_dropped, timeout=3.0), [record.getMessage() for record in caplog.records]
    assert held_when_dropped()[0] < 2 * limit, held_when_dropped()
    with socket.create_connection((sim.host, SECONDARY), timeout=3.0) as good:
        good.sendall(b"write_output_integer_register(8, 42)\n")
    assert wait_for(lambda: sim.controller.state().output_int_registers[8] == 42, timeout=3.0)


def test_a_program_sent_during_a_protective_stop_is_not_run_and_the_refusal_is_reported(clients):
    """A controller starts no program while a protective stop is latched: a script a client sends on 30002 is not
    run (ur_rtde's RTDEReceiveInterface sees the runtime state stay STOPPED and the arm still), and an error-code
    message on 30001 names the protective stop and its fix. Once the stop is unlocked the same script runs."""
    from sim_ursim.control_channel import send_request

    with simulator_process(model="ur3") as process:
        dashboard(process.host, "power on", "brake release")
        assert wait_for(lambda: send_request(process.host, "status")["state"]["robot_mode"] == "RUNNING", timeout=10)
        assert send_request(process.host, "protective-stop", reason="test")["ok"]
        primary = clients(process.host, PRIMARY)
        code = textwrap.dedent(
            f"""
            import socket, time
            import rtde_receive
            receiver = rtde_receive.RTDEReceiveInterface({process.host!r})
            before = receiver.getActualQ()
            def send(script):
                with socket.create_connection(({process.host!r}, 30002)) as connection:
                    connection.sendall(script)
            script = b"def moved():\\n  movej([0.5, -1.3, 1.1, -1.2, -1.4, 0.3], a=2.0, v=1.5)\\nend\\n"
            send(script)
            states = set()
            deadline = time.monotonic() + 0.5
            while time.monotonic() < deadline:
                states.add(receiver.getRuntimeState())
                time.sleep(0.004)
            print(sorted(states))
            print(max(abs(a - b) for a, b in zip(before, receiver.getActualQ())))
            send(b"set unlock protective stop\\n")
            deadline = time.monotonic() + 5
            while receiver.isProtectiveStopped():
                assert time.monotonic() < deadline, "the protective stop was never unlocked"
                time.sleep(0.004)
            send(script)
            deadline = time.monotonic() + 5
            while receiver.getRuntimeState() != 2:
                assert time.monotonic() < deadline, "the script never ran after the unlock"
                time.sleep(0.004)
            print("ran")
            receiver.disconnect()
            """
        )
        states, moved, ran = run_child(code).strip().splitlines()
        refusals = primary.robot_messages(lambda subtype, data: subtype == ERROR_CODE and b"not started" in data, 3)
    assert ast.literal_eval(states) == [1] and float(moved) < 1e-9 and ran == "ran"   # STOPPED throughout
    text = refusals[-1][1].decode("latin-1")
    assert "protective stop" in text and "unlock the protective stop" in text
