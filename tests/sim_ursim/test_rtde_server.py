"""The RTDE server over real sockets, spoken to in raw protocol 1 and 2 like UR's RTDE Python client does."""
import logging
import os
import signal
import socket
import struct
import time

import pytest

from polling import wait_for
from sim_ursim.controller import Controller
from sim_ursim.launch import simulator_process
from sim_ursim.rtde import protocol
from sim_ursim.rtde.protocol import PackageType
from sim_ursim.rtde.server import RTDEServer


class RawClient:
    """A minimal RTDE client on a plain socket: sends packages, reads them back one at a time."""

    def __init__(self, address, receive_buffer=None):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        if receive_buffer is not None:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
        self.sock.settimeout(5.0)
        self.sock.connect(address)
        self.buffer = bytearray()

    def close(self):
        self.sock.close()

    def send(self, package):
        self.sock.sendall(package)

    def receive(self, timeout=5.0):
        """Next package (type, payload); socket.timeout if none arrives in time, EOFError if the server closed."""
        self.sock.settimeout(timeout)
        while True:
            package = protocol.split_package(self.buffer)
            if package is not None:
                package_type, payload, consumed = package
                del self.buffer[:consumed]
                return package_type, payload
            chunk = self.sock.recv(65536)
            if not chunk:
                raise EOFError("server closed the connection")
            self.buffer += chunk

    def request(self, package, skip_data=True):
        """Send a request and return the payload of its reply (data packages in between are skipped)."""
        self.send(package)
        request_type = package[2]
        while True:
            package_type, payload = self.receive()
            if package_type == PackageType.DATA_PACKAGE and skip_data:
                continue
            assert package_type == request_type, f"expected reply type {request_type}, got {package_type}"
            return payload

    def negotiate(self, version=2):
        return protocol.parse_accepted_reply(self.request(protocol.pack_protocol_version_request(version)))

    def setup_outputs(self, names, frequency, version=2):
        return protocol.parse_setup_outputs_reply(
            self.request(protocol.pack_setup_outputs_request(names, frequency, version)), version)

    def setup_inputs(self, names):
        return protocol.parse_setup_inputs_reply(self.request(protocol.pack_setup_inputs_request(names)))

    def start(self):
        return protocol.parse_accepted_reply(self.request(protocol.pack_start_request()))

    def data(self, types, has_recipe_id=True, timeout=5.0):
        """Values of the next data package (skipping anything else)."""
        layout = protocol.recipe_struct(types)
        while True:
            package_type, payload = self.receive(timeout)
            if package_type == PackageType.DATA_PACKAGE:
                recipe_id, flat = protocol.parse_data_package(payload, layout, has_recipe_id)
                return recipe_id, protocol.group_values(types, flat)


def _serve(model):
    controller = Controller(model=model)
    controller.start()
    # Small buffers so that a client which stops reading is dropped within a second or two.
    server = RTDEServer(controller, "127.0.0.1", 0, backlog_limit=64 * 1024, send_buffer=32 * 1024).start()
    return controller, server


@pytest.fixture
def cb3():
    controller, server = _serve("ur3")
    yield controller, server
    server.stop()
    controller.shutdown()


@pytest.fixture
def eseries():
    controller, server = _serve("ur3e")
    yield controller, server
    server.stop()
    controller.shutdown()


@pytest.fixture
def clients(cb3):
    opened = []

    def connect(**options):
        client = RawClient(("127.0.0.1", cb3[1].port), **options)
        opened.append(client)
        return client

    yield connect
    for client in opened:
        client.close()


def test_protocol_2_is_accepted_and_3_refused(clients):
    client = clients()
    assert client.negotiate(3) is False
    assert client.negotiate(2) is True


def test_a_malformed_package_closes_the_connection(cb3, clients):
    client = clients()
    client.send(protocol.pack_package(PackageType.REQUEST_PROTOCOL_VERSION, b"\x00"))  # V needs 2 bytes
    with pytest.raises((EOFError, ConnectionResetError)):
        client.receive(timeout=2.0)
    assert wait_for(lambda: cb3[1].sessions() == [])


def test_controller_version_is_the_emulated_one(cb3, clients):
    payload = clients().request(protocol.pack_controller_version_request())
    assert protocol.parse_controller_version_reply(payload) == tuple(cb3[0].version)


def test_protocol_1_streams_without_recipe_id_every_control_cycle(clients):
    client = clients()
    assert client.negotiate(1) is True
    recipe_id, types = client.setup_outputs(["timestamp", "actual_q"], None, version=1)
    assert (recipe_id, types) == (None, ["DOUBLE", "VECTOR6D"])
    assert client.start() is True
    stamps = [client.data(types, has_recipe_id=False)[1][0] for _ in range(20)]
    assert [b - a for a, b in zip(stamps[:-1], stamps[1:], strict=True)] == pytest.approx([0.008] * 19, abs=1e-9)


def test_protocol_2_data_carries_the_recipe_id_and_real_values(cb3, clients):
    controller, _ = cb3
    client = clients()
    client.negotiate(2)
    recipe_id, types = client.setup_outputs(["timestamp", "actual_q", "robot_mode", "joint_mode"], 125)
    assert recipe_id == 1 and types == ["DOUBLE", "VECTOR6D", "INT32", "VECTOR6INT32"]
    assert client.start()
    data_id, (stamp, q, mode, joint_modes) = client.data(types)
    state = controller.state()
    assert data_id == 1
    assert 0 < stamp <= state.timestamp
    assert q == pytest.approx(state.actual_q.tolist())
    assert mode == state.robot_mode and list(joint_modes) == list(state.joint_mode)


def test_a_stalled_simulator_sends_every_cycle_afterwards_one_period_apart():
    """When the host stops the simulator (here SIGSTOP for 0.3 s, as a loaded machine does for shorter spells), it
    catches up: every control cycle is computed and streamed, late and in order, each timestamp one period after
    the last. (Before, the loop covered the stall in one long cycle and the stream sent only the newest state.)"""
    with simulator_process(model="ur3e") as simulator:
        client = RawClient((simulator.host, 30004))
        try:
            client.negotiate(2)
            _, types = client.setup_outputs(["timestamp"], 500)
            client.start()
            stamps = [client.data(types)[1][0] for _ in range(50)]
            for _ in range(2):
                os.kill(simulator.process.pid, signal.SIGSTOP)
                time.sleep(0.3)
                os.kill(simulator.process.pid, signal.SIGCONT)
                stamps += [client.data(types)[1][0] for _ in range(300)]
        finally:
            client.close()
    steps = [round((b - a) / 0.002, 6) for a, b in zip(stamps[:-1], stamps[1:], strict=True)]
    assert steps == [1.0] * len(steps)


def test_input_packages_apply_at_the_start_of_the_next_control_cycle():
    """A controller reads its RTDE inputs once per cycle: packages change nothing until the next cycle starts, and
    all those received meanwhile apply then, in order (a program reading a flag and a set-point sees both)."""
    controller = Controller(model="ur3")  # its loop is not started: the test steps the cycles
    server = RTDEServer(controller, "127.0.0.1", 0).start()
    client = RawClient(("127.0.0.1", server.port))
    try:
        client.negotiate(2)
        setpoint_id, setpoint_types = client.setup_inputs(["input_double_register_0"])
        flag_id, flag_types = client.setup_inputs(["input_int_register_0"])
        client.send(protocol.pack_data_package(protocol.recipe_struct(setpoint_types), setpoint_id, [0.25]))
        client.send(protocol.pack_data_package(protocol.recipe_struct(flag_types), flag_id, [1]))
        assert wait_for(lambda: server.sessions()[0].input_values.get("input_int_register_0") == 1)
        time.sleep(0.05)
        assert controller.state().input_int_registers[0] == 0
        assert controller.state().input_double_registers[0] == 0.0
        state = controller.step()
        assert (state.input_double_registers[0], state.input_int_registers[0]) == (0.25, 1)
    finally:
        client.close()
        server.stop()


def test_a_recipe_whose_reply_would_not_fit_one_package_is_refused(clients, caplog):
    """30,000 one-letter names fit a request, but their reply (NOT_FOUND each) would take 300 kB: the recipe is
    refused with an empty type list and one short log line, and the connection goes on."""
    client = clients()
    client.negotiate(2)
    names = ["x"] * 30_000
    with caplog.at_level(logging.WARNING, logger="sim_ursim.rtde"):
        assert client.setup_outputs(names, 125) == (0, [""])
        assert client.setup_inputs(names) == (0, [""])
    refusals = [record.getMessage() for record in caplog.records if "refused" in record.getMessage()]
    assert len(refusals) == 2 and all(len(line) < 300 and "30000 variables" in line for line in refusals)
    assert client.setup_outputs(["timestamp"], 125) == (1, ["DOUBLE"])


def test_frequency_is_decimated_from_the_control_cycle(eseries):
    controller, server = eseries
    client = RawClient(("127.0.0.1", server.port))
    try:
        client.negotiate(2)
        _, types = client.setup_outputs(["timestamp"], 100)
        client.start()
        stamps = [client.data(types)[1][0] for _ in range(15)]
    finally:
        client.close()
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    assert min(gaps) == pytest.approx(0.010, abs=1e-9)  # floor(500 / 100) = 5 cycles of 2 ms


def test_frequency_above_the_control_rate_is_capped(clients):
    client = clients()
    client.negotiate(2)
    _, types = client.setup_outputs(["timestamp"], 1000)
    client.start()
    stamps = [client.data(types)[1][0] for _ in range(10)]
    assert min(b - a for a, b in zip(stamps, stamps[1:])) == pytest.approx(0.008, abs=1e-9)


def test_unknown_and_version_gated_names_are_not_found_and_start_is_refused(clients):
    client = clients()
    client.negotiate(2)
    recipe_id, types = client.setup_outputs(["timestamp", "ft_raw_wrench", "no_such_thing"], 125)
    assert recipe_id == 0
    assert types == ["DOUBLE", "NOT_FOUND", "NOT_FOUND"]
    assert client.start() is False
    with pytest.raises(socket.timeout):
        client.receive(timeout=0.3)


def test_trailing_comma_of_ur_rtde_is_ignored(clients):
    client = clients()
    client.negotiate(2)
    payload = client.request(protocol.pack_package(PackageType.CONTROL_PACKAGE_SETUP_OUTPUTS,
                                                   struct.pack(">d", 125.0) + b"timestamp,actual_q,"))
    assert protocol.parse_setup_outputs_reply(payload, 2) == (1, ["DOUBLE", "VECTOR6D"])


def test_nothing_is_sent_unsolicited_during_setup(clients):
    client = clients()
    client.negotiate(2)
    client.setup_outputs(["timestamp"], 125)
    with pytest.raises(socket.timeout):
        client.receive(timeout=0.3)


def test_a_later_output_recipe_replaces_the_first(clients):
    client = clients()
    client.negotiate(2)
    client.setup_outputs(["timestamp", "actual_q"], 125)
    assert client.setup_outputs(["robot_mode"], 125) == (1, ["INT32"])
    client.start()
    package_type, payload = client.receive()
    assert package_type == PackageType.DATA_PACKAGE
    assert len(payload) == 1 + 4  # recipe id + one INT32: only the second recipe is streamed


def test_pause_stops_the_stream(clients):
    client = clients()
    client.negotiate(2)
    _, types = client.setup_outputs(["timestamp"], 125)
    client.start()
    client.data(types)
    assert protocol.parse_accepted_reply(client.request(protocol.pack_pause_request()))
    # A package packed before the pause was processed may still be in flight; after that, silence.
    try:
        while client.receive(timeout=0.1)[0] == PackageType.DATA_PACKAGE:
            pass
    except TimeoutError:
        pass
    with pytest.raises(socket.timeout):
        client.receive(timeout=0.3)


def test_input_recipes_are_numbered_from_one_on_every_connection(clients):
    first = clients()
    first.negotiate(2)
    assert first.setup_inputs(["input_int_register_1"]) == (1, ["INT32"])
    assert first.setup_inputs(["input_int_register_1", "input_double_register_1"]) == (2, ["INT32", "DOUBLE"])
    second = clients()
    second.negotiate(2)
    assert second.setup_inputs(["input_int_register_2"]) == (1, ["INT32"])


def test_a_variable_controlled_by_another_client_is_in_use(clients):
    owner = clients()
    owner.negotiate(2)
    owner.setup_inputs(["speed_slider_mask", "speed_slider_fraction"])
    other = clients()
    other.negotiate(2)
    assert other.setup_inputs(["input_int_register_3", "speed_slider_mask"]) == (0, ["INT32", "IN_USE"])
    assert other.setup_inputs(["input_int_register_3", "no_such_input"]) == (0, ["INT32", "NOT_FOUND"])
    owner.close()
    assert wait_for(lambda: other.setup_inputs(["speed_slider_mask"])[0] == 1)


def test_inputs_take_effect_before_start_and_read_back_as_outputs(cb3, clients):
    controller, _ = cb3
    writer = clients()
    writer.negotiate(2)
    recipe_id, types = writer.setup_inputs(["input_int_register_5", "input_double_register_6",
                                            "input_bit_registers0_to_31"])
    writer.send(protocol.pack_data_package(protocol.recipe_struct(types), recipe_id, [-42, 2.5, 0b1001]))
    assert wait_for(lambda: controller.state().input_int_registers[5] == -42)
    reader = clients()
    reader.negotiate(2)
    _, out_types = reader.setup_outputs(["input_int_register_5", "input_double_register_6",
                                         "input_bit_registers0_to_31"], 125)
    reader.start()
    assert reader.data(out_types)[1] == [-42, 2.5, 0b1001]


def test_digital_outputs_follow_the_mask(cb3, clients):
    controller, _ = cb3
    client = clients()
    client.negotiate(2)
    recipe_id, types = client.setup_inputs(["standard_digital_output_mask", "standard_digital_output",
                                            "tool_digital_output_mask", "tool_digital_output"])
    layout = protocol.recipe_struct(types)
    client.send(protocol.pack_data_package(layout, recipe_id, [0b111, 0b101, 0b11, 0b10]))
    assert wait_for(lambda: controller.state().digital_output_bits == 0b101 | (0b10 << 16))
    client.send(protocol.pack_data_package(layout, recipe_id, [0b001, 0b000, 0, 0]))  # clears DO0 only
    assert wait_for(lambda: controller.state().digital_output_bits == 0b100 | (0b10 << 16))


def test_speed_slider_is_set_only_with_its_mask(cb3, clients):
    controller, _ = cb3
    client = clients()
    client.negotiate(2)
    recipe_id, types = client.setup_inputs(["speed_slider_mask", "speed_slider_fraction"])
    layout = protocol.recipe_struct(types)
    client.send(protocol.pack_data_package(layout, recipe_id, [0, 0.2]))
    client.send(protocol.pack_data_package(layout, recipe_id, [1, 0.3]))
    assert wait_for(lambda: controller.state().target_speed_fraction == 0.3)
    client.send(protocol.pack_data_package(layout, recipe_id, [0, 0.9]))
    assert client.negotiate(2)  # answered after the package before it was applied: one reader, in order
    assert controller.state().target_speed_fraction == 0.3


def test_external_force_torque_input_reads_back_as_tcp_force(cb3, clients):
    controller, _ = cb3
    client = clients()
    client.negotiate(2)
    recipe_id, types = client.setup_inputs(["external_force_torque"])
    client.send(protocol.pack_data_package(protocol.recipe_struct(types), recipe_id, [1, 2, 3, 0.1, 0.2, 0.3]))
    assert wait_for(lambda: controller.state().actual_tcp_force.tolist() == [1, 2, 3, 0.1, 0.2, 0.3])
    _, out_types = client.setup_outputs(["actual_TCP_force", "tcp_force_scalar"], 125)
    client.start()
    force, scalar = client.data(out_types)[1]
    assert force == (1, 2, 3, 0.1, 0.2, 0.3) and scalar == pytest.approx(14 ** 0.5)


def test_input_recipe_ids_stop_at_255(clients):
    client = clients()
    client.negotiate(2)
    for expected in range(1, 256):
        assert client.setup_inputs([f"input_int_register_{expected % 48}"])[0] == expected
    assert client.setup_inputs(["input_int_register_0"])[0] == 0


def test_a_bad_input_while_streaming_is_answered_with_a_text_message(clients):
    client = clients()
    client.negotiate(2)
    _, types = client.setup_outputs(["timestamp"], 125)
    client.start()
    client.send(protocol.pack_data_package(protocol.recipe_struct(["INT32"]), 9, [1]))
    deadline = time.monotonic() + 3
    while time.monotonic() < deadline:
        package_type, payload = client.receive()
        if package_type == PackageType.TEXT_MESSAGE:
            message, source, level = protocol.parse_text_message(payload, 2, from_controller=True)
            assert "unknown input recipe 9" in message and level == protocol.MessageLevel.ERROR
            return
    pytest.fail("no text message about the unknown input recipe")


def test_client_text_message_is_accepted_silently(clients):
    client = clients()
    client.negotiate(2)
    client.send(protocol.pack_text_message("hello controller", "test", protocol.MessageLevel.INFO, 2))
    assert client.negotiate(2) is True  # still connected; the next reply is the V reply, nothing in between


def test_a_client_that_stops_reading_is_dropped_and_does_not_stall_others(eseries):
    controller, server = eseries
    names = ["timestamp", "actual_q", "actual_qd", "target_q", "target_qd", "actual_TCP_pose", "target_TCP_pose"]
    stalled = RawClient(("127.0.0.1", server.port), receive_buffer=4096)
    steady = RawClient(("127.0.0.1", server.port))
    try:
        for client in (stalled, steady):
            client.negotiate(2)
            _, types = client.setup_outputs(names, 500)
            client.start()
        stamps = []
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            stamps.append(steady.data(types)[1][0])
        gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        assert len(stamps) > 500  # ~1000 expected at 500 Hz; the stalled client costs the steady one nothing
        assert max(gaps) < 0.25
        assert wait_for(lambda: len(server.sessions()) == 1, timeout=10)
        with pytest.raises((EOFError, ConnectionResetError)):
            while True:
                stalled.receive(timeout=1.0)
    finally:
        stalled.close()
        steady.close()


def test_frozen_streams_send_nothing_then_resume(cb3, clients):
    controller, _ = cb3
    client = clients()
    client.negotiate(2)
    _, types = client.setup_outputs(["timestamp"], 125)
    client.start()
    client.data(types)
    controller.faults.freeze_streams(0.6)
    frozen_at = time.monotonic()
    # Drain what was sent before the freeze, then the next package must come only after the window.
    while True:
        client.data(types, timeout=2.0)
        if time.monotonic() - frozen_at > 0.3:
            break
    assert time.monotonic() - frozen_at >= 0.55


def test_injected_latency_delays_replies(cb3, clients):
    controller, _ = cb3
    client = clients()
    controller.faults.add_latency(0.3)
    began = time.monotonic()
    client.negotiate(2)
    assert time.monotonic() - began >= 0.29


def test_drop_generation_closes_every_connection(cb3, clients):
    controller, server = cb3
    first, second = clients(), clients()
    for client in (first, second):
        client.negotiate(2)
        _, types = client.setup_outputs(["timestamp"], 125)
        client.start()
    controller.faults.drop_connections()
    for client in (first, second):
        with pytest.raises((EOFError, ConnectionResetError)):
            while True:
                client.receive(timeout=2.0)
    assert wait_for(lambda: server.sessions() == [])
    fresh = clients()
    assert fresh.negotiate(2) is True  # a new connection after the drop is served


def _control_interface_input_recipes(offset):
    """The 23 input recipes ur_rtde's RTDEControlInterface sets up, in order (docs/protocols.md §5.8)."""
    def ints(*numbers):
        return [f"input_int_register_{n + offset}" for n in numbers]

    def doubles(count):
        return [f"input_double_register_{n + offset}" for n in range(count)]

    return [ints(0) + doubles(8) + ints(1), ints(0) + doubles(11), ints(*range(8)) + doubles(18), ints(0),
            ints(0) + doubles(9), ints(0) + doubles(6), ints(0) + doubles(4), ints(0) + doubles(1), ints(0, 1),
            ints(0) + doubles(14), ints(0), ints(0) + doubles(12), ints(0) + doubles(8), ints(0) + doubles(14),
            ints(0, 1), ints(0) + doubles(13), ints(*range(7)) + doubles(6), ints(0, 1) + doubles(7),
            ints(0) + doubles(1) + ints(1), ints(0) + doubles(10), ints(0) + doubles(6) + ints(1),
            ints(0) + doubles(18), ints(0) + ["external_force_torque"]]


@pytest.mark.parametrize("model, offset", [("ur3", 0), ("ur3e", 24)])
def test_control_interface_setup_is_accepted_with_ids_1_to_23(model, offset):
    controller, server = _serve(model)
    client = RawClient(("127.0.0.1", server.port))
    try:
        client.negotiate(2)
        outputs = (["timestamp", "robot_status_bits", "safety_status_bits", "runtime_state"]
                   + [f"output_int_register_{n + offset}" for n in range(3)]
                   + [f"output_double_register_{n + offset}" for n in range(6)])
        recipe_id, types = client.setup_outputs(outputs, 1 / controller.period)
        assert recipe_id == 1 and "NOT_FOUND" not in types
        for expected_id, names in enumerate(_control_interface_input_recipes(offset), start=1):
            assert client.setup_inputs(names)[0] == expected_id
        assert client.start() is True
        recipe_4 = protocol.recipe_struct(["INT32"])
        client.send(protocol.pack_data_package(recipe_4, 4, [255]))  # the stop-script command word
        assert wait_for(lambda: controller.state().input_int_registers[offset] == 255)
    finally:
        client.close()
        server.stop()
        controller.shutdown()
