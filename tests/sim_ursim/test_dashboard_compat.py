"""Dashboard replies that real clients depend on: ur_rtde's DashboardClient (a real client, PyPI) and the replies
URCL's G5 dashboard client matches (src/ur/dashboard_client_implementation_g5.cpp regexes, re-played here)."""
import re
import zipfile

import dashboard_client
import pytest

from dashboard_lines import LineClient
from polling import wait_for
from sim_ursim.launch import running_simulator
from urp_samples import E_SERIES_WAIT_PROGRAM, write_urp


@pytest.fixture
def programs(tmp_path):
    """A PolyScope programs folder: URCL's wait_program.urp and a broken (truncated) program."""
    write_urp(tmp_path / "wait_program.urp", E_SERIES_WAIT_PROGRAM)
    (tmp_path / "broken.urp").write_bytes(b"\x1f\x8b")
    return tmp_path


def _ask_all(host, commands):
    client = LineClient(host)
    try:
        return [client.ask(command) for command in commands]
    finally:
        client.close()


def test_load_urp_plays_its_program_tree_and_the_urcl_dashboard_sequence_passes(programs):
    with running_simulator(model="ur5e", programs_directory=str(programs)) as sim:
        sim.controller.power_up()
        client = LineClient(sim.host)
        try:
            reply = client.ask("load wait_program.urp")
            assert re.fullmatch(r"(?:Loading program: ).*(?:wait_program.urp).*", reply)
            assert client.ask("programState") == "STOPPED wait_program.urp"
            assert client.ask("play") == "Starting program"
            assert wait_for(lambda: client.ask("programState") == "PLAYING wait_program.urp", timeout=5)
            assert client.ask("pause") == "Pausing program"
            assert client.ask("play") == "Starting program"
            assert client.ask("stop") == "Stopped"
            assert client.ask("programState") == "STOPPED wait_program.urp"
        finally:
            client.close()


def test_a_broken_urp_and_a_missing_file_give_the_controller_errors(programs):
    with running_simulator(model="ur3", programs_directory=str(programs)) as sim:
        replies = _ask_all(sim.host, ["load broken.urp", "load absent.urp", "get loaded program"])
    assert replies == ["Error while loading program: broken.urp", "File not found: absent.urp",
                       "No program loaded"]


@pytest.mark.parametrize("model", ["ur3", "ur5e"])
def test_ur_rtde_stop_with_no_program_running_succeeds(model):
    """ur_rtde's RTDEControlInterface sends dashboard `stop` after ending a crashed client's script."""
    with running_simulator(model=model) as sim:
        client = dashboard_client.DashboardClient(sim.host)
        client.connect()
        try:
            client.stop()  # raises RuntimeError unless the reply contains "Stopped"
            assert client.programState().startswith("STOPPED")
        finally:
            client.disconnect()


def test_cb3_user_role_is_stored_and_serial_number_answered_from_3_12():
    with running_simulator(model="ur3", version="3.15.8") as sim:
        replies = _ask_all(sim.host, ["setUserRole operator", "getUserRole", "setUserRole nobody", "getUserRole",
                                      "get serial number", "get robot model"])
    assert replies[:4] == ["Setting user role: operator", "OPERATOR", "Failed setting user role: nobody",
                           "OPERATOR"]
    assert re.fullmatch(r"(?:20).*", replies[4])  # URCL's pattern for the serial number
    assert replies[5] == "UR3"
    with running_simulator(model="ur3", version="3.11.0") as sim:
        assert _ask_all(sim.host, ["get serial number"]) == ["could not understand: 'get serial number'"]


def test_e_series_operational_mode_flight_report_and_support_file(tmp_path):
    with running_simulator(model="ur5e", programs_directory=str(tmp_path)) as sim:
        replies = _ask_all(sim.host, ["get operational mode", "set operational mode MANUAL", "get operational mode",
                                      "clear operational mode", "generate flight report controller",
                                      f"generate support file {tmp_path}", "getUserRole"])
    assert replies[0] == "NONE"
    assert re.fullmatch(r"(?:Operational mode ).*(?:MANUAL).*", replies[1])  # URCL's pattern, as it sends the mode
    assert replies[2] == "MANUAL"
    assert re.fullmatch(r"(?:No longer controlling the operational mode.).*", replies[3])
    assert re.fullmatch(r"(?:Flight Report generated with id:).*", replies[4])
    assert re.fullmatch(r"(?:Completed successfully:).*", replies[5])
    archive = tmp_path / replies[5].split(": ", 1)[1]
    with zipfile.ZipFile(archive) as written:
        assert "URSoftware 5." in written.read("version.txt").decode()
    assert replies[6] == "could not understand: 'getUserRole'"  # user roles are CB3-only


def test_clearing_the_operational_mode_and_remote_control_as_urcls_test_expects():
    """URCL's DashboardClientTestG5.operational_mode: `get operational mode` is NONE again once cleared, and a
    simulator configured as URSim by default (remote control not enabled) is not in remote control."""
    with running_simulator(model="ur5e", version="5.9.4", remote_control=False) as sim:
        replies = _ask_all(sim.host, ["set operational mode AUTOMATIC", "clear operational mode",
                                      "get operational mode", "is in remote control"])
    assert replies[2:] == ["NONE", "false"]
    with running_simulator(model="ur5e", version="5.9.4") as sim:
        assert _ask_all(sim.host, ["is in remote control"]) == ["true"]  # ur_rtde's RTDEControlInterface needs it
