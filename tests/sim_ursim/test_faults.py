"""Fault injection: the Faults object, its effect on a served connection, and the control channel."""
import json
import socket
import time

import pytest

from polling import wait_for
from robot_target import needs_simulator
from sim_ursim.control_channel import CONTROL_PORT, MAX_REQUEST_BYTES, execute, send_request
from sim_ursim.faults import Faults
from sim_ursim.vocabulary import RobotMode, SafetyMode

pytestmark = needs_simulator


class FakeClock:
    """A settable clock so freeze windows are tested without sleeping."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def dashboard_connection(host):
    connection = socket.create_connection((host, 29999), timeout=10)
    reader = connection.makefile("r", encoding="utf-8")
    assert reader.readline().startswith("Connected")
    return connection, reader


def timed_reply(connection, reader, line):
    began = time.monotonic()
    connection.sendall((line + "\n").encode())
    reply = reader.readline()
    return reply, time.monotonic() - began


# ------------------------------------------------------------------------------------------ the Faults object
def test_freeze_window_opens_and_closes_with_the_clock():
    clock = FakeClock()
    faults = Faults(clock)
    assert not faults.streams_frozen
    faults.freeze_streams(2.0)
    assert faults.streams_frozen and faults.frozen_remaining() == pytest.approx(2.0)
    clock.now += 1.999
    assert faults.streams_frozen
    clock.now += 0.002
    assert not faults.streams_frozen and faults.frozen_remaining() == 0.0


def test_latency_generation_and_reset():
    faults = Faults()
    faults.add_latency(0.05)
    assert faults.latency == 0.05
    assert faults.drop_connections() == 1 and faults.drop_connections() == 2 and faults.generation == 2
    assert faults.wait_generation(after=1, timeout=0.01) == 2
    faults.freeze_streams(10)
    faults.reset()
    assert (faults.latency, faults.streams_frozen, faults.generation) == (0.0, False, 2)


@pytest.mark.parametrize("value", [-1, float("nan"), float("inf"), "soon"])
def test_bad_durations_are_named(value):
    with pytest.raises(ValueError, match="seconds must be"):
        Faults().freeze_streams(value)


# ------------------------------------------------------------------------------------------ on a served connection
def test_drop_connections_closes_a_dashboard_client(sim):
    connection, reader = dashboard_connection(sim.host)
    try:
        sim.controller.faults.drop_connections()
        connection.settimeout(5)
        assert connection.recv(100) == b""
        fresh, fresh_reader = dashboard_connection(sim.host)  # new connections are welcome
        fresh.close()
    finally:
        connection.close()


def test_latency_delays_every_reply(sim):
    connection, reader = dashboard_connection(sim.host)
    try:
        sim.controller.faults.add_latency(0.5)
        reply, elapsed = timed_reply(connection, reader, "robotmode")
        assert reply == "Robotmode: POWER_OFF\n" and elapsed >= 0.5
        sim.controller.faults.reset()
        reply, elapsed = timed_reply(connection, reader, "robotmode")
        assert reply == "Robotmode: POWER_OFF\n" and elapsed < 0.5
    finally:
        connection.close()


def test_frozen_controller_answers_only_after_the_window(sim):
    connection, reader = dashboard_connection(sim.host)
    try:
        sim.controller.faults.freeze_streams(0.6)
        reply, elapsed = timed_reply(connection, reader, "safetymode")
        assert reply == "Safetymode: NORMAL\n" and elapsed >= 0.5
    finally:
        connection.close()


# ------------------------------------------------------------------------------------------ control channel
def test_an_over_long_control_request_is_refused_and_the_client_dropped(sim):
    """What a control-channel connection may buffer is bounded (issue 10 item 8)."""
    with socket.create_connection((sim.host, CONTROL_PORT), timeout=5.0) as sock:
        try:
            sock.sendall(b"x" * (MAX_REQUEST_BYTES + 10))
        except (BrokenPipeError, ConnectionResetError):
            pass
        reader = sock.makefile("rb")
        reply = json.loads(reader.readline())
        assert reply["ok"] is False and "longer than" in reply["error"]
        assert reader.readline() == b""  # dropped
    assert send_request(sim.host, "status")["ok"]  # others are still served


def test_control_channel_injects_safety_faults(sim):
    sim.controller.power_up()
    assert send_request(sim.host, "protective-stop", reason="bumped")["ok"]
    assert sim.controller.state().safety_mode == SafetyMode.PROTECTIVE_STOP
    assert send_request(sim.host, "emergency-stop") == {"ok": True, "message": "emergency stop pressed"}
    state = sim.controller.state()
    assert (state.safety_mode, state.robot_mode) == (SafetyMode.ROBOT_EMERGENCY_STOP, RobotMode.POWER_OFF)
    assert send_request(sim.host, "release-emergency-stop")["ok"]
    assert sim.controller.state().safety_mode == SafetyMode.NORMAL
    status = send_request(sim.host, "status")["message"]
    assert status.startswith("robot POWER_OFF, safety NORMAL")


def test_control_channel_transport_faults_and_errors(sim):
    assert send_request(sim.host, "freeze", seconds=5)["ok"] and sim.controller.faults.streams_frozen
    assert send_request(sim.host, "latency", seconds=0.01)["ok"] and sim.controller.faults.latency == 0.01
    assert send_request(sim.host, "reset")["ok"] and not sim.controller.faults.streams_frozen
    generation = sim.controller.faults.generation
    assert send_request(sim.host, "drop-connections")["ok"] and sim.controller.faults.generation == generation + 1
    assert send_request(sim.host, "freeze", seconds=-1) == {"ok": False, "error": "freeze: seconds must be a "
                                                                                  "finite number ≥ 0, got -1"}
    assert send_request(sim.host, "explode")["error"].startswith("unknown command 'explode'")
    assert send_request(sim.host, "freeze")["error"] == "freeze: needs the argument 'seconds'"


def test_control_channel_hand_guiding(sim):
    sim.controller.power_up()
    assert send_request(sim.host, "move-by-hand", q=[0.1] * 6)["error"].startswith(
        "move-by-hand: the arm can be moved by hand only in freedrive")
    assert send_request(sim.host, "freedrive", on=True)["ok"]
    assert send_request(sim.host, "move-by-hand", q=[0.1] * 6)["ok"]
    assert sim.controller.state().actual_q.tolist() == pytest.approx([0.1] * 6)


def test_execute_without_a_stop_hook_refuses_shutdown(sim):
    assert execute({"command": "shutdown"}, sim.controller)["ok"] is False
    assert execute("not a dict", sim.controller)["ok"] is False
    assert CONTROL_PORT == 29998


# ------------------------------------------------------------------------------------------ seen by ur_rtde
def test_faults_from_the_command_line_are_seen_by_ur_rtde():
    # ur_rtde's RTDE constructors hold the GIL, hence a simulator process (see sim_ursim.launch).
    import rtde_receive

    from sim_ursim.launch import simulator_process

    with simulator_process(model="ur3e") as sim:
        receiver = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            assert send_request(sim.host, "emergency-stop")["ok"]
            assert wait_for(receiver.isEmergencyStopped, timeout=5.0)
            assert receiver.getSafetyMode() == SafetyMode.ROBOT_EMERGENCY_STOP
            assert send_request(sim.host, "release-emergency-stop")["ok"]
            assert wait_for(lambda: not receiver.isEmergencyStopped(), timeout=5.0)
            before = receiver.getTimestamp()
            assert send_request(sim.host, "freeze", seconds=1.0)["ok"]
            time.sleep(0.5)
            frozen_at = receiver.getTimestamp()
            time.sleep(0.3)
            assert receiver.getTimestamp() == frozen_at and receiver.isConnected()  # nothing arrives, link kept
            # streaming again, time moved on
            assert wait_for(lambda: receiver.getTimestamp() > frozen_at + 0.5, timeout=5.0)
            assert frozen_at - before < 0.1
            assert send_request(sim.host, "drop-connections")["ok"]
            assert wait_for(lambda: not receiver.isConnected(), timeout=5.0)
            receiver.reconnect()
            assert receiver.isConnected() and wait_for(lambda: receiver.getTimestamp() > frozen_at + 1.0, timeout=5.0)
        finally:
            receiver.disconnect()
