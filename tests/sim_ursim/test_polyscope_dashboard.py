"""`.urp` programs loaded and played through the dashboard (29999) over real sockets, as URCL and URSim users do:
load / play / pause / stop / programState / get loaded program / isProgramSaved, PolyScope's load errors,
sub-directories, a Move program that moves the arm, and the External Control URCap node fetching its program."""
import gzip
import queue
import socket
import threading

import numpy as np
import pytest

from dashboard_lines import LineClient
from polling import wait_for
from sim_ursim.launch import running_simulator
from sim_ursim.messages import PopupMessage
from socket_threads import join_all, shut
from urp_samples import E_SERIES_EXTERNAL_CONTROL, E_SERIES_WAIT_PROGRAM, program_xml, write_urp

Q_START = [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]
Q_MOVEJ = [0.3, -1.3, 1.4, -1.6, -1.5, 0.2]
Q_MOVEL = [0.35, -1.25, 1.35, -1.65, -1.5, 0.25]


@pytest.fixture
def programs(tmp_path):
    write_urp(tmp_path / "wait_program.urp", E_SERIES_WAIT_PROGRAM)
    write_urp(tmp_path / "cell" / "wait_program.urp", E_SERIES_WAIT_PROGRAM.replace("0.01", "0.02"))
    (tmp_path / "notes.urp").write_text("not a program\n")
    write_urp(tmp_path / "pallet.urp", program_xml("<Pallet/>"))
    return tmp_path


def test_urcl_wait_program_loads_plays_pauses_and_stops(programs):
    with running_simulator(model="ur5e", programs_directory=str(programs)) as sim:
        sim.controller.power_up()
        client = LineClient(sim.host)
        try:
            assert client.ask("load wait_program.urp") == "Loading program: wait_program.urp"
            assert client.ask("programState") == "STOPPED wait_program.urp"
            assert client.ask("get loaded program") == f"Loaded program: {programs / 'wait_program.urp'}"
            assert client.ask("isProgramSaved") == "true wait_program.urp"
            assert client.ask("play") == "Starting program"
            assert client.ask("programState") == "PLAYING wait_program.urp"
            assert sim.runner.program_name == "wait_program"
            assert client.ask("pause") == "Pausing program"
            assert client.ask("programState") == "PAUSED wait_program.urp"
            assert client.ask("play") == "Starting program"
            assert client.ask("running") == "Program running: true"
            assert client.ask("stop") == "Stopped"
            assert client.ask("programState") == "STOPPED wait_program.urp"
        finally:
            client.close()


def test_sub_directories_and_the_controllers_own_programs_path(programs):
    with running_simulator(model="ur3", programs_directory=str(programs)) as sim:
        client = LineClient(sim.host)
        try:
            assert client.ask("load cell/wait_program.urp") == "Loading program: cell/wait_program.urp"
            assert client.ask("get loaded program") == f"Loaded program: {programs / 'cell' / 'wait_program.urp'}"
            assert client.ask("load /ursim/programs/wait_program.urp") == (
                "Loading program: /ursim/programs/wait_program.urp")
            assert client.ask("programState") == "STOPPED wait_program.urp"
            assert client.ask("get loaded program") == f"Loaded program: {programs / 'wait_program.urp'}"
        finally:
            client.close()


def test_polyscope_load_errors_keep_the_loaded_program(programs):
    with running_simulator(model="ur3", programs_directory=str(programs)) as sim:
        client = LineClient(sim.host)
        try:
            assert client.ask("load wait_program.urp") == "Loading program: wait_program.urp"
            assert client.ask("load absent.urp") == "File not found: absent.urp"
            assert client.ask("load notes.urp") == "Error while loading program: notes.urp"
            assert client.ask("load pallet.urp") == "Error while loading program: pallet.urp"
            assert client.ask("programState") == "STOPPED wait_program.urp"
        finally:
            client.close()


def test_a_move_program_moves_the_arm_through_its_waypoints(tmp_path):
    waypoints = "".join(
        f'<Move motionType="{kind}" speed="{v}" acceleration="{a}" useActiveTCP="true"><children>'
        f'<Waypoint type="Fixed" name="{kind}_target"><motionParameters/><position>'
        f'<JointAngles angles="{", ".join(map(str, q))}"/><TCPOffset pose="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>'
        "</position></Waypoint></children></Move>"
        for kind, v, a, q in (("MoveJ", 1.5, 3.0, Q_MOVEJ), ("MoveL", 0.5, 2.0, Q_MOVEL)))
    write_urp(tmp_path / "moves.urp", program_xml(waypoints, name="moves", run_once=True))
    with running_simulator(model="ur5e", programs_directory=str(tmp_path), initial_q=Q_START) as sim:
        sim.controller.power_up()
        client = LineClient(sim.host)
        try:
            assert client.ask("load moves.urp") == "Loading program: moves.urp"
            assert client.ask("play") == "Starting program"
            assert wait_for(lambda: client.ask("programState") == "STOPPED moves.urp", timeout=20)
        finally:
            client.close()
        assert wait_for(lambda: not sim.controller.state().motion_active, timeout=5)
        np.testing.assert_allclose(sim.controller.state().actual_q, Q_MOVEL, atol=1e-6)


class RemotePC:
    """What URCL's ScriptSender does for the External Control URCap: answer `request_program` with a script."""

    def __init__(self, host, program):
        self.server = socket.create_server((host, 0))
        self.port = self.server.getsockname()[1]
        self.program = program
        self.requests = []
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self):
        while True:
            try:
                connection, _ = self.server.accept()
            except OSError:
                return
            with connection:
                self.requests.append(connection.recv(1024))
                connection.sendall(self.program.encode() + b"\n")
                connection.recv(1024)  # the URCap closes; URCL keeps the connection until then

    def close(self):
        shut(self.server)
        join_all([self._thread])


COUNTING_SCRIPT = """# HEADER_BEGIN
def count_node():
  write_output_integer_register(0, read_output_integer_register(0) + 1)
end
# HEADER_END
# NODE_CONTROL_LOOP_BEGINS
count_node()
# NODE_CONTROL_LOOP_ENDS"""


def test_external_control_fetches_its_program_from_the_remote_pc(tmp_path):
    two_nodes = E_SERIES_EXTERNAL_CONTROL.replace("<dataModel/>\n        </Contributed>",
                                                  "<dataModel/></Contributed><Contributed strategyClass="
                                                  '"com.fzi.externalcontrol.ExternalControlNode"/>')
    write_urp(tmp_path / "external_control.urp", two_nodes)
    with running_simulator(model="ur5e", programs_directory=str(tmp_path)) as sim:
        remote = RemotePC(sim.host, COUNTING_SCRIPT)
        sim.programs.external_control = type(sim.programs.external_control)(sim.host, remote.port)
        sim.controller.power_up()
        client = LineClient(sim.host)
        try:
            assert client.ask("load external_control.urp") == "Loading program: external_control.urp"
            assert remote.requests == []  # the program is fetched at play, not at load
            assert client.ask("play") == "Starting program"
            assert wait_for(lambda: client.ask("programState") == "STOPPED external_control.urp", timeout=10)
        finally:
            client.close()
            remote.close()
        assert remote.requests == [b"request_program\n"]
        assert sim.controller.state().output_int_registers[0] == 2  # header once, control loop at both nodes


def test_without_the_remote_pc_the_program_stops_with_the_urcaps_message(tmp_path):
    write_urp(tmp_path / "external_control.urp", E_SERIES_EXTERNAL_CONTROL)
    with running_simulator(model="ur5e", programs_directory=str(tmp_path)) as sim:
        listener = socket.create_server((sim.host, 0))
        port = listener.getsockname()[1]
        listener.close()  # a port where nothing listens
        sim.programs.external_control = type(sim.programs.external_control)(sim.host, port)
        sim.controller.power_up()
        messages = sim.controller.messages.subscribe()
        client = LineClient(sim.host)
        try:
            assert client.ask("load external_control.urp") == "Loading program: external_control.urp"
            assert client.ask("play") == "Starting program"
            assert wait_for(lambda: client.ask("programState") == "STOPPED external_control.urp", timeout=10)
        finally:
            client.close()
        popups = []
        while True:
            try:
                message = messages.get_nowait()
            except queue.Empty:
                break
            if isinstance(message, PopupMessage):
                popups.append(message)
    assert [(p.title, p.error) for p in popups] == [("Receive program failed", True)]
    assert popups[0].text.startswith(f"The connection to the remote PC at {sim.host}:{port} could not be "
                                     "established. Reason: Connection refused")


def test_pins_named_in_the_programs_installation_are_played_by_their_default_names(tmp_path):
    write_urp(tmp_path / "grip.urp", program_xml(
        '<Set type="DigitalOutput"><pin referencedName="gripper"/><digitalValue>1</digitalValue></Set>', name="grip"))
    installation = ('<Installation><IOs><DigitalOutputNames value=", , , gripper, , , , "/>'
                    '<AnalogOutputNames value="a, b"/></IOs></Installation>')
    (tmp_path / "default.installation").write_bytes(gzip.compress(installation.encode()))
    write_urp(tmp_path / "elsewhere" / "grip.urp", program_xml(
        '<Set type="DigitalOutput"><pin referencedName="gripper"/><digitalValue>1</digitalValue></Set>'))
    (tmp_path / "broken").mkdir()
    write_urp(tmp_path / "broken" / "wait.urp", E_SERIES_WAIT_PROGRAM)
    (tmp_path / "broken" / "default.installation").write_bytes(b"\x1f\x8b")
    with running_simulator(model="ur5e", programs_directory=str(tmp_path)) as sim:
        sim.controller.power_up()
        client = LineClient(sim.host)
        try:
            assert client.ask("load elsewhere/grip.urp") == "Error while loading program: elsewhere/grip.urp"
            assert client.ask("load broken/wait.urp") == "Error while loading program: broken/wait.urp"
            assert client.ask("load grip.urp") == "Loading program: grip.urp"
            assert client.ask("play") == "Starting program"
            assert wait_for(lambda: client.ask("programState") == "STOPPED grip.urp", timeout=10)
        finally:
            client.close()
        assert sim.controller.state().standard_digital_output_bits & (1 << 3)
