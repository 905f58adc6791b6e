"""Dashboard server (29999) driven by ur_rtde's real DashboardClient and by raw sockets.

Tests that only use the dashboard run against UR3DQ_TEST_HOST when it names an official URSim (`robot_host`);
tests that look inside the simulator (`sim`) are about sim_ursim itself.
"""
import socket
import time

import dashboard_client
import pytest

from sim_ursim.dashboard import protocol
from sim_ursim.launch import running_simulator

MODE_TIMEOUT = 30.0  # an official URSim takes seconds to power on; the simulator a fraction of one


def connected(host):
    client = dashboard_client.DashboardClient(host)
    client.connect()
    return client


def wait_for_reply(ask, expected, timeout=MODE_TIMEOUT):
    """Poll `ask()` until it returns `expected` (as URCL does after power on / brake release)."""
    deadline = time.monotonic() + timeout
    reply = ask()
    while reply != expected and time.monotonic() < deadline:
        time.sleep(0.05)
        reply = ask()
    return reply


def raw_exchange(host, lines):
    """Greeting and one reply per line over a plain socket."""
    with socket.create_connection((host, 29999), timeout=5) as connection:
        reader = connection.makefile("r", encoding="utf-8", newline="\n")
        replies = [reader.readline()]
        for line in lines:
            connection.sendall((line + "\n").encode())
            replies.append(reader.readline())
        return replies


# ------------------------------------------------------------------------------------------ with ur_rtde
def test_power_on_and_brake_release_walk_the_robot_modes(robot_host):
    client = connected(robot_host)
    try:
        client.powerOff()
        assert wait_for_reply(client.robotmode, "Robotmode: POWER_OFF") == "Robotmode: POWER_OFF"
        client.powerOn()
        assert wait_for_reply(client.robotmode, "Robotmode: IDLE") == "Robotmode: IDLE"
        client.brakeRelease()
        assert wait_for_reply(client.robotmode, "Robotmode: RUNNING") == "Robotmode: RUNNING"
        assert client.safetymode() == "Safetymode: NORMAL"
        client.powerOff()
        assert wait_for_reply(client.robotmode, "Robotmode: POWER_OFF") == "Robotmode: POWER_OFF"
    finally:
        client.disconnect()


def test_identity_replies_of_a_cb3_controller(sim):
    client = connected(sim.host)
    try:
        assert client.polyscopeVersion() == "3.15.8.106339"  # ur_rtde extracts the number
        assert client.getRobotModel() == "UR3"
        assert client.getLoadedProgram() == "No program loaded"
        assert client.programState() == "STOPPED <unnamed>"
        assert client.running() is False
        client.addToLog("hello from a test")
        client.popup("message")
        client.closePopup()
        client.closeSafetyPopup()
        # 5.6+ only: ur_rtde checks the version itself and answers without asking a CB3
        assert client.isInRemoteControl() is False
    finally:
        client.disconnect()


def test_e_series_answers_the_version_gated_commands():
    with running_simulator(model="ur3e") as simulator:
        client = connected(simulator.host)
        try:
            assert client.polyscopeVersion() == "5.11.1.108318"
            assert client.getSerialNumber() == simulator.controller.model.serial_number
            assert client.isInRemoteControl() is True
            assert client.safetystatus() == "Safetystatus: NORMAL"
        finally:
            client.disconnect()


def test_protective_stop_unlock_honours_the_five_second_rule(sim):
    sim.controller.power_up()
    client = connected(sim.host)
    try:
        sim.controller.protective_stop("test")
        stopped_at = time.monotonic()
        assert client.safetymode() == "Safetymode: PROTECTIVE_STOP"
        with pytest.raises(RuntimeError, match="Cannot unlock protective stop until 5s after occurrence"):
            client.unlockProtectiveStop()
        assert client.safetymode() == "Safetymode: PROTECTIVE_STOP"
        time.sleep(max(0.0, stopped_at + 5.1 - time.monotonic()))
        client.unlockProtectiveStop()
        assert client.safetymode() == "Safetymode: NORMAL"
    finally:
        client.disconnect()


def test_restart_safety_within_the_unlock_delay_is_refused_and_leaves_the_stop_latched():
    """`restart safety` clears a protective stop and powers off, but not within the 5 s after the stop: then it
    answers with the unlock rule's text and changes nothing (it replied "Restarting safety", powered off and left
    PROTECTIVE_STOP latched)."""
    with running_simulator(model="ur3", unlock_delay=1.0) as sim:
        sim.controller.power_up()
        sim.controller.protective_stop("test")
        stopped_at = time.monotonic()
        replies = raw_exchange(sim.host, ["restart safety", "safetymode", "robotmode"])
        assert replies[1:] == [protocol.UNLOCK_TOO_EARLY + "\n", "Safetymode: PROTECTIVE_STOP\n",
                               "Robotmode: RUNNING\n"]
        time.sleep(max(0.0, stopped_at + 1.1 - time.monotonic()))
        replies = raw_exchange(sim.host, ["restart safety", "safetymode", "robotmode"])
        assert replies[1:] == ["Restarting safety\n", "Safetymode: NORMAL\n", "Robotmode: POWER_OFF\n"]


def test_load_installation_answers_as_polyscope_for_present_and_missing_files(sim, tmp_path):
    (tmp_path / "default.installation").write_bytes(b"installation")
    sim.controller.programs_directory = str(tmp_path)
    replies = raw_exchange(sim.host, ["load installation default.installation",
                                      "load installation nowhere.installation"])
    assert replies[1:] == ["Loading installation: default.installation\n", "File not found: nowhere.installation\n"]


def test_load_play_pause_stop_run_a_script_through_the_runner(sim, tmp_path):
    program = tmp_path / "wave.script"
    program.write_text("def wave():\n  movej([0.5, -1.2, 1.2, -1.5, -1.5, 0], a=1.4, v=1.05)\n  sleep(30)\nend\n")
    sim.controller.programs_directory = str(tmp_path)
    sim.controller.power_up()
    client = connected(sim.host)
    try:
        with pytest.raises(RuntimeError, match="File not found: missing.script"):
            client.loadURP("missing.script")
        client.loadURP("wave.script")
        assert client.getLoadedProgram() == f"Loaded program: {program}"
        assert client.programState() == "STOPPED wave.script"
        client.play()
        assert wait_for_reply(client.programState, "PLAYING wave.script", 5) == "PLAYING wave.script"
        assert client.running() is True
        assert wait_for_reply(lambda: round(float(sim.controller.state().actual_q[0]), 6), 0.5, 10) == 0.5
        client.pause()
        assert client.programState() == "PAUSED wave.script"
        client.play()
        assert client.programState() == "PLAYING wave.script"
        client.stop()
        assert client.programState() == "STOPPED wave.script"
        assert client.running() is False
        client.stop()  # nothing runs any more: still "Stopped" (ur_rtde raises on any other reply)
    finally:
        client.disconnect()


def test_play_fails_when_the_robot_is_not_running(sim, tmp_path):
    (tmp_path / "idle.script").write_text("def idle():\n  sleep(1)\nend\n")
    sim.controller.programs_directory = str(tmp_path)
    client = connected(sim.host)
    try:
        client.loadURP("idle.script")
        with pytest.raises(RuntimeError, match="Failed to execute: play"):
            client.play()
    finally:
        client.disconnect()


# ------------------------------------------------------------------------------------------ raw socket
def test_greeting_unknown_command_and_quit(sim):
    replies = raw_exchange(sim.host, ["robotmode", "make coffee", "safetystatus", "quit"])
    assert replies == ["Connected: Universal Robots Dashboard Server\n", "Robotmode: POWER_OFF\n",
                       "could not understand: 'make coffee'\n", "could not understand: 'safetystatus'\n",
                       "Disconnected\n"]


def test_several_clients_are_served_at_once(sim):
    sockets = [socket.create_connection((sim.host, 29999), timeout=5) for _ in range(4)]
    try:
        readers = [s.makefile("r", encoding="utf-8") for s in sockets]
        assert all(r.readline() == protocol.GREETING + "\n" for r in readers)
        for s in reversed(sockets):
            s.sendall(b"get robot model\n")
        assert [r.readline() for r in readers] == ["UR3\n"] * 4
    finally:
        for s in sockets:
            s.close()


def test_shutdown_stops_the_simulator(sim):
    replies = raw_exchange(sim.host, ["shutdown"])
    assert replies[1] == "Shutting down\n"
    assert sim.wait(timeout=5)
    deadline = time.monotonic() + 10
    while sim.controller.running and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not sim.controller.running
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection((sim.host, 29999), timeout=2)


# ------------------------------------------------------------------------------------------ protocol (pure)
@pytest.mark.parametrize("line, expected", [
    ("power on", ("power on", "")),
    ("  Power   On \r\n", ("power on", "")),
    ("load /programs/My Prog.script", ("load", "/programs/My Prog.script")),
    ("load installation default.installation", ("load installation", "default.installation")),
    ("addToLog Hello World", ("addtolog", "Hello World")),
    ("popup Mind the gap", ("popup", "Mind the gap")),
    ("close popup", ("close popup", "")),
    ("power onwards", (None, "power onwards")),
    ("robotmode please", (None, "robotmode please")),
])
def test_parse_command_splits_the_command_from_its_argument(line, expected):
    assert protocol.parse_command(line) == expected


def test_pure_replies_follow_the_controller_state():
    from sim_ursim.controller import Controller

    cb3, e_series = Controller("ur3"), Controller("ur5e", version="5.4.0")
    assert protocol.handle("safetystatus", cb3).text == "could not understand: 'safetystatus'"
    assert protocol.handle("safetystatus", e_series).text == "Safetystatus: NORMAL"
    assert protocol.handle("get serial number", e_series).text == "could not understand: 'get serial number'"
    assert protocol.handle("get robot model", e_series).text == "could not understand: 'get robot model'"
    assert protocol.handle("get robot model", cb3).text == "UR3"
    assert protocol.handle("PolyscopeVersion", e_series).text == "URSoftware 5.4.0.0 (Jan 01 2022)"
    assert protocol.handle("quit", cb3) == protocol.Reply("Disconnected", close=True)
    assert protocol.handle("shutdown", cb3).shutdown
    assert protocol.handle("load", cb3).text == "could not understand: 'load'"
    cb3.set_program_state(True, paused=True)
    assert protocol.handle("programState", cb3).text == "PAUSED <unnamed>"
