"""RTDE as UR's own clients use it: long setup packages, the full variable table, the input watchdog.

The client here speaks the wire protocol the way UR's RTDE_Python_Client_Library (rtde/rtde.py, serialize.py)
does — `>HB` header, protocol 2, `>d` frequency + comma-joined names, `>B` recipe id on data — written from that
client, not from sim_ursim's own packers.
"""
import queue
import socket
import struct
import time

import pytest

from polling import wait_for
from sim_ursim import kinematics
from sim_ursim.launch import running_simulator
from sim_ursim.rtde import variables

V, v_, O, I, S, P, U = 86, 118, 79, 73, 83, 80, 85   # noqa: E741  (RTDE's package type letters)
FORMATS = {"BOOL": "?", "UINT8": "B", "UINT32": "I", "UINT64": "Q", "INT32": "i", "DOUBLE": "d",
           "VECTOR3D": "3d", "VECTOR6D": "6d", "VECTOR6INT32": "6i", "VECTOR6UINT32": "6I"}

# UR's record_configuration.xml (RTDE_Python_Client_Library, examples/): its default, uncommented "out" recipe.
UR_RECORD_OUT = ("timestamp,target_q,target_qd,target_qdd,target_current,target_moment,actual_q,actual_qd,"
                 "actual_current,joint_control_output,actual_TCP_pose,actual_TCP_speed,actual_TCP_force,"
                 "target_TCP_pose,target_TCP_speed,actual_digital_input_bits,joint_temperatures,"
                 "actual_execution_time,robot_mode,joint_mode,safety_status,actual_tool_accelerometer,"
                 "speed_scaling,target_speed_fraction,actual_momentum,actual_main_voltage,actual_robot_voltage,"
                 "actual_robot_current,actual_joint_voltage,actual_digital_output_bits,runtime_state,"
                 "joint_position_deviation_ratio").split(",")


class PyrtdeLikeClient:
    """The requests and replies of UR's Python RTDE client, on a plain socket."""

    def __init__(self, host):
        self.sock = socket.create_connection((host, 30004), timeout=5)
        self.buffer = b""

    def close(self):
        self.sock.close()

    def send(self, kind, payload=b""):
        self.sock.sendall(struct.pack(">HB", len(payload) + 3, kind) + payload)

    def receive(self, wanted):
        """Payload of the next package of type `wanted` (data packages skipped unless wanted)."""
        while True:
            while len(self.buffer) >= 3 and len(self.buffer) >= struct.unpack_from(">H", self.buffer)[0]:
                size, kind = struct.unpack_from(">HB", self.buffer)
                payload, self.buffer = self.buffer[3:size], self.buffer[size:]
                if kind == wanted:
                    return payload
            chunk = self.sock.recv(65536)
            if not chunk:
                raise EOFError("controller closed the connection")
            self.buffer += chunk

    def handshake(self):
        self.send(V, struct.pack(">H", 2))
        assert self.receive(V) == b"\x01"

    def setup_outputs(self, names, frequency=125.0):
        self.send(O, struct.pack(">d", frequency) + ",".join(names).encode())
        reply = self.receive(O)
        return reply[0], reply[1:].decode().split(",")

    def setup_inputs(self, names):
        self.send(I, ",".join(names).encode())
        reply = self.receive(I)
        return reply[0], reply[1:].decode().split(",")

    def start(self):
        self.send(S)
        return self.receive(S) == b"\x01"

    def data(self, types):
        payload = self.receive(U)
        return struct.unpack(">B" + "".join(FORMATS[t] for t in types), payload)

    def send_inputs(self, recipe_id, fmt, *values):
        self.send(U, struct.pack(">B" + fmt, recipe_id, *values))


@pytest.fixture
def client_of():
    opened = []

    def connect(host):
        client = PyrtdeLikeClient(host)
        client.handshake()
        opened.append(client)
        return client

    yield connect
    for client in opened:
        client.close()


def test_ur_record_configuration_default_recipe_streams(client_of):
    with running_simulator(model="ur5e") as sim:
        client = client_of(sim.host)
        recipe_id, types = client.setup_outputs(UR_RECORD_OUT)
        assert recipe_id != 0 and "NOT_FOUND" not in types
        assert types[-1] == "DOUBLE"
        assert client.start()
        assert len(client.data(types)) > len(UR_RECORD_OUT)


def test_every_output_urcl_lists_is_served_in_one_9_kb_setup_package_on_5_26(client_of):
    names = [name for name, variable in variables.OUTPUTS.items() if variable.available_in((5, 26, 0))]
    payload_bytes = len(",".join(names))
    assert len(names) >= 406 and payload_bytes > 4 * 2048
    with running_simulator(model="ur5e", version="5.26.0") as sim:
        client = client_of(sim.host)
        recipe_id, types = client.setup_outputs(names, 10.0)
        assert recipe_id != 0 and "NOT_FOUND" not in types and len(types) == len(names)
        assert client.start()
        values = client.data(types)
        assert values[0] == recipe_id


def test_unknown_and_too_new_names_answer_not_found_without_closing(client_of):
    with running_simulator(model="ur3", version="3.15.8") as sim:
        client = client_of(sim.host)
        recipe_id, types = client.setup_outputs(["timestamp", "collision_detection_ratio", "no_such_output"])
        assert recipe_id == 0 and types == ["DOUBLE", "NOT_FOUND", "NOT_FOUND"]
        recipe_id, types = client.setup_outputs(["timestamp", "joint_position_deviation_ratio"])
        assert recipe_id != 0 and types == ["DOUBLE", "DOUBLE"]


# --- rtde_set_watchdog ----------------------------------------------------------------------------------------

WATCHED_PROGRAM = """def watched():
  rtde_set_watchdog("input_int_register_0", 4, "{action}")
  write_output_integer_register(0, 1)
  while True:
    sync()
  end
end
"""


def _watched_program(sim, client, action):
    """Start a program that arms a 4 Hz watchdog (250 ms) on input_int_register_0; return the input recipe id."""
    recipe_id, types = client.setup_inputs(["input_int_register_0"])
    assert recipe_id != 0 and types == ["INT32"]
    controller = sim.controller
    controller.power_up()
    assert controller.run_program(WATCHED_PROGRAM.format(action=action), "test")
    assert wait_for(lambda: controller.state().output_int_registers[0] == 1, timeout=5)
    return recipe_id


def _kick_for(client, recipe_id, seconds, rate=50.0):
    """Send input_int_register_0 at `rate` Hz for `seconds`; returns the monotonic time of the last send."""
    deadline = time.monotonic() + seconds
    while True:
        client.send_inputs(recipe_id, "i", 0)
        last = time.monotonic()
        if last >= deadline:
            return last
        time.sleep(1.0 / rate)


@pytest.mark.parametrize("action", ["PAUSE", "pause"])
def test_watchdog_pause_pauses_the_program_when_inputs_stop(client_of, action):
    with running_simulator(model="ur5e") as sim:
        client = client_of(sim.host)
        recipe_id = _watched_program(sim, client, action)
        stopped_kicking = _kick_for(client, recipe_id, 1.0)  # 4 watchdog periods kicked in time
        state = sim.controller.state()
        assert state.program_running and not state.program_paused
        assert wait_for(lambda: sim.controller.state().program_paused, timeout=2)
        assert time.monotonic() - stopped_kicking >= 0.25  # not before one period without an update


def test_watchdog_stop_stops_the_program(client_of):
    with running_simulator(model="ur5e") as sim:
        client = client_of(sim.host)
        recipe_id = _watched_program(sim, client, "STOP")
        _kick_for(client, recipe_id, 0.6)
        assert sim.controller.state().program_running
        assert wait_for(lambda: not sim.controller.state().program_running, timeout=2)


def test_watchdog_ignore_keeps_the_program_running(client_of):
    with running_simulator(model="ur5e") as sim:
        client = client_of(sim.host)
        _watched_program(sim, client, "IGNORE")
        assert not wait_for(lambda: not sim.controller.state().program_running, timeout=0.5)
        assert not sim.controller.state().program_paused


def test_watchdog_bad_action_is_a_runtime_error():
    with running_simulator(model="ur5e") as sim:
        messages = sim.controller.messages.subscribe()
        sim.controller.run_program('rtde_set_watchdog("input_int_register_0", 10, "EXPLODE")\n', "test")
        texts = []

        def reported():
            try:
                texts.append(getattr(messages.get_nowait(), "text", ""))
            except queue.Empty:
                pass
            return any("rtde_set_watchdog" in text and "EXPLODE" in text for text in texts)

        assert wait_for(reported, timeout=3)


FORWARD_KINEMATICS_CLIENT = """
import sys, rtde_control
control = rtde_control.RTDEControlInterface(sys.argv[1])
print(control.getForwardKinematics([0, -1.57, 1.57, -1.57, -1.57, 0], [0, 0, 0.1, 0, 0, 0]), flush=True)
control.stopScript()
control.disconnect()
"""


def test_ur_rtde_forward_kinematics_with_tcp_answers_instead_of_hanging():
    """Issue 15 §9: ur_rtde 1.6.5 getForwardKinematics(q, tcp) (input recipe 13: one int + 12 doubles)."""
    import subprocess
    import sys

    import numpy as np

    with running_simulator(model="ur5e") as sim:
        done = subprocess.run([sys.executable, "-c", FORWARD_KINEMATICS_CLIENT, sim.host], capture_output=True,
                              text=True, timeout=60)
        assert done.returncode == 0, done.stderr[-2000:]
        pose = [float(v) for v in done.stdout.strip().strip("[]").split(",")]
        flange = np.array(sim.controller.fk([0, -1.57, 1.57, -1.57, -1.57, 0]))  # no TCP offset set
    # The flange pose moved 0.1 m along the flange z axis (URScript get_forward_kin(q, tcp)).
    z_axis = kinematics.rotation_vector_to_matrix(flange[3:])[:, 2]
    assert len(pose) == 6 and np.linalg.norm(np.array(pose[:3]) - flange[:3] - 0.1 * z_axis) < 1e-6


# ur_rtde sends GET_JOINT_TORQUES (38) as a streaming command and reads the output registers without waiting for
# the script, so a first call returns what the registers held before: the value of interest is the second one.
JOINT_TORQUES_CLIENT = """
import sys, time, rtde_control
control = rtde_control.RTDEControlInterface(sys.argv[1])
control.getJointTorques()
time.sleep(0.1)
print(control.getJointTorques(), flush=True)
control.stopScript()
control.disconnect()
"""


def test_ur_rtde_get_joint_torques_answers_from_the_running_script():
    """Issue 15 §5: getJointTorques() used to return stale registers because get_joint_torques killed the script."""
    import subprocess
    import sys

    import numpy as np

    with running_simulator(model="ur5e") as sim:
        wrench = np.array([0.0, 0.0, -20.0, 0.0, 0.0, 0.0])
        sim.controller.set_external_force_torque(wrench)
        assert wait_for(lambda: np.allclose(sim.controller.state().actual_tcp_force, wrench), timeout=2)
        done = subprocess.run([sys.executable, "-c", JOINT_TORQUES_CLIENT, sim.host], capture_output=True,
                              text=True, timeout=60)
        assert done.returncode == 0, done.stderr[-2000:]
        torques = np.array([float(v) for v in done.stdout.strip().strip("[]").split(",")])
        state = sim.controller.state()
        jacobian = kinematics.geometric_jacobian(sim.controller.model.dh, state.actual_q, state.tcp_offset)
    assert np.allclose(torques, jacobian.T @ wrench, atol=1e-6) and np.linalg.norm(torques) > 1.0
