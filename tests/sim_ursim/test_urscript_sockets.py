"""URScript socket_* built-ins over real loopback TCP, driven the way URCL's External Control script uses them.

`ReverseInterfaceServer` re-creates the PC side of URCL's ReverseInterface (src/control/reverse_interface.cpp):
it listens, and writes 8 big-endian int32 per message — read timeout [ms], six joint values × MULT_JOINTSTATE
(1e6), control mode (1 = MODE_SERVOJ, -2 = MODE_STOPPED).  The robot program below is written here after the loop
of resources/external_control.urscript (socket_open of the reverse socket, socket_read_binary_integer with a
timeout, servoj on each message, socket_send_int of a result on a second "trajectory" socket).
"""
import socket
import struct
import threading

import numpy as np
import pytest

from polling import wait_for
from sim_ursim.launch import running_simulator

MULT_JOINTSTATE = 1_000_000
MODE_SERVOJ, MODE_STOPPED = 1, -2


class ReverseInterfaceServer:
    """One listening loopback socket accepting the robot's connection; send/receive in URCL's byte format."""

    def __init__(self, host):
        self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.listener.bind((host, 0))
        self.listener.listen(1)
        self.listener.settimeout(10)
        self.port = self.listener.getsockname()[1]
        self.connection = None

    def accept(self):
        self.connection, _ = self.listener.accept()
        self.connection.settimeout(10)

    def write_joints(self, q, mode=MODE_SERVOJ, read_timeout_ms=200):
        scaled = [int(round(v * MULT_JOINTSTATE)) for v in q]
        self.connection.sendall(struct.pack(">8i", read_timeout_ms, *scaled, mode))

    def read_int(self):
        data = b""
        while len(data) < 4:
            chunk = self.connection.recv(4 - len(data))
            if not chunk:
                raise EOFError("robot closed the socket")
            data += chunk
        return struct.unpack(">i", data)[0]

    def close(self):
        if self.connection is not None:
            self.connection.close()
        self.listener.close()


ROBOT_PROGRAM = """def externalControlLike():
  MULT_jointstate = 1000000.0
  if not socket_open("{host}", {reverse_port}, "reverse_socket"):
    textmsg("reverse socket not connected")
    halt
  end
  socket_open("{host}", {trajectory_port}, "trajectory_socket")
  socket_send_int(7, "trajectory_socket")
  keep_running = True
  while keep_running:
    params_mult = socket_read_binary_integer(8, "reverse_socket", 0.5)
    if params_mult[0] > 0:
      if params_mult[8] == -2:
        keep_running = False
      else:
        q = [params_mult[2], params_mult[3], params_mult[4], params_mult[5], params_mult[6],
             params_mult[7]] / MULT_jointstate
        servoj(q, t=0.008, lookahead_time=0.1, gain=300)
      end
    end
  end
  socket_send_int(get_list_length(params_mult), "trajectory_socket")
  socket_close("reverse_socket")
  socket_close("trajectory_socket")
end
"""


@pytest.fixture
def servers():
    opened = []

    def make(host):
        server = ReverseInterfaceServer(host)
        opened.append(server)
        return server

    yield make
    for server in opened:
        server.close()


def test_external_control_style_reverse_interface_streams_servoj(servers):
    with running_simulator(model="ur5e") as sim:
        controller = sim.controller
        controller.power_up()
        reverse, trajectory = servers(sim.host), servers(sim.host)
        program = ROBOT_PROGRAM.format(host=sim.host, reverse_port=reverse.port, trajectory_port=trajectory.port)
        accepted = threading.Thread(target=lambda: (reverse.accept(), trajectory.accept()))
        accepted.start()
        assert controller.run_program(program, "test")
        accepted.join(10)
        assert trajectory.read_int() == 7
        start = np.array(controller.state().actual_q)
        target = start + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.05])
        for step in range(1, 51):  # 50 servoj set-points at 125 Hz ramping wrist 3 by 0.05 rad
            reverse.write_joints(start + (target - start) * step / 50)
            controller.wait_cycle(controller.state().cycle, timeout=0.1)
        assert wait_for(lambda: abs(controller.state().actual_q[5] - target[5]) < 1e-3, timeout=3)
        reverse.write_joints(target, mode=MODE_STOPPED)
        assert trajectory.read_int() == 9  # the last read returned [8, …]: 9 elements
        assert wait_for(lambda: not controller.state().program_running, timeout=3)


def test_reads_time_out_with_count_zero_and_stop_interrupts_a_blocking_read(servers):
    with running_simulator(model="ur5e") as sim:
        server = servers(sim.host)
        program = f"""def reader():
  socket_open("{sim.host}", {server.port}, "s")
  first = socket_read_binary_integer(2, "s", 0.2)
  socket_send_int(first[0], "s")
  line = socket_read_line("s", 0.2)
  socket_send_line(str_cat("line:", line), "s")
  forever = socket_read_byte_list(4, "s", 0)
end
"""
        accept = threading.Thread(target=server.accept)
        accept.start()
        assert sim.controller.run_program(program, "test")
        accept.join(10)
        assert server.read_int() == 0  # nothing was sent: count 0 after the 0.2 s timeout
        server.connection.sendall(b"hello\n")
        reader = server.connection.makefile("rb")
        assert reader.readline() == b"line:hello\n"
        assert wait_for(lambda: sim.controller.state().program_running, timeout=1)
        sim.controller.stop_program()  # the timeout-0 read must not keep the program alive
        assert wait_for(lambda: not sim.controller.state().program_running, timeout=2)
        server.connection.settimeout(2)
        assert server.connection.recv(1) == b""  # the program's sockets are closed when it ends


def test_socket_open_refuses_non_loopback_addresses_without_connecting():
    with running_simulator(model="ur3") as sim:
        messages = sim.controller.messages.subscribe()
        program = 'def outside():\n  textmsg(str_cat("opened:", to_str(socket_open("192.0.2.1", 50001, "x"))))\nend\n'
        assert sim.controller.run_program(program, "test")
        texts = []

        def said():
            while not messages.empty():
                texts.append(getattr(messages.get_nowait(), "text", ""))
            return "opened:False" in texts

        assert wait_for(said, timeout=3)


def test_ascii_floats_get_var_and_set_var(servers):
    with running_simulator(model="ur3") as sim:
        server = servers(sim.host)
        program = f"""def vars():
  socket_open("{sim.host}", {server.port}, "s")
  floats = socket_read_ascii_float(3, "s", 2)
  socket_set_var("SUM", floor(floats[1] + floats[2] + floats[3]), "s")
  got = socket_get_var("ANSWER", "s")
  socket_set_var("GOT", got, "s")
end
"""
        accept = threading.Thread(target=server.accept)
        accept.start()
        assert sim.controller.run_program(program, "test")
        accept.join(10)
        server.connection.sendall(b"(1.5, 2.25, -0.75)")
        reader = server.connection.makefile("rb")
        assert reader.readline() == b"SET SUM 3\n"
        assert reader.readline() == b"GET ANSWER\n"
        server.connection.sendall(b"ANSWER 42\n")
        assert reader.readline() == b"SET GOT 42\n"


# URCL's TrajectoryPointInterface (src/control/trajectory_point_interface.cpp) sends a spline point as 21 big-endian
# int32: positions, velocities, accelerations (× MULT_JOINTSTATE), duration (× MULT_TIME = 1e6), spline type
# (2 = quintic), point type (2 = joint spline).
SPLINE_QUINTIC, POINT_JOINT_SPLINE = 2, 2

# Written here after the spline execution of External Control (resources/external_control.urscript,
# jointSplineRun/jointSplineStep): the spline from the measured joints to the point, stepped once per control
# cycle by `speedj(qd, a, steptime)` with qd the spline's speed at the step's end and a the change over the step,
# the remainder (< one cycle) as a last shorter speedj. It relies on each speedj moving for exactly its t.
SPLINE_PROGRAM = """def splineLike():
  MULT = 1000000.0
  socket_open("{host}", {port}, "trajectory_socket")
  point = socket_read_binary_integer(21, "trajectory_socket", 5)
  end_q = [point[1], point[2], point[3], point[4], point[5], point[6]] / MULT
  duration = point[19] / MULT
  delta = end_q - get_joint_positions()
  steptime = get_steptime()
  def largest_change(a, b):
    largest = 0
    i = 0
    while i < 6:
      if norm(a[i] - b[i]) > largest:
        largest = norm(a[i] - b[i])
      end
      i = i + 1
    end
    return largest
  end
  last_qd = [0, 0, 0, 0, 0, 0]
  elapsed = 0.0
  while duration - elapsed > steptime:
    elapsed = elapsed + steptime
    s = elapsed / duration
    qd = delta * ((30 * pow(s, 2) - 60 * pow(s, 3) + 30 * pow(s, 4)) / duration)
    speedj(qd, largest_change(qd, last_qd) / steptime, steptime)
    last_qd = qd
  end
  speedj([0, 0, 0, 0, 0, 0], largest_change(last_qd, [0, 0, 0, 0, 0, 0]) / (duration - elapsed), duration - elapsed)
  socket_send_int(0, "trajectory_socket")
end
"""


def spline_point_message(q, duration):
    """One quintic joint-spline point ending at rest, as URCL's writeTrajectorySplinePoint sends it."""
    values = [round(v * MULT_JOINTSTATE) for v in q] + [0] * 12
    return struct.pack(">21i", *values, round(duration * 1_000_000), SPLINE_QUINTIC, POINT_JOINT_SPLINE)


def test_a_spline_stepped_by_speedj_each_cycle_ends_on_its_target(servers):
    """speedj(qd, a, t) moves for exactly t of control time, however long the interpreter takes between two
    commands (it ran on at qd meanwhile: URCL's trajectory_streaming_example pre-positioned 60 % too far)."""
    with running_simulator(model="ur5e") as sim:
        controller = sim.controller
        controller.power_up()
        trajectory = servers(sim.host)
        accepted = threading.Thread(target=trajectory.accept)
        accepted.start()
        assert controller.run_program(SPLINE_PROGRAM.format(host=sim.host, port=trajectory.port), "test")
        accepted.join(10)
        start = np.array(controller.state().actual_q)
        target = start + np.array([0.0, 0.3, -0.2, 0.0, 0.0, 0.5])
        trajectory.connection.sendall(spline_point_message(target, 1.0))
        trajectory.connection.settimeout(60)  # the arm's progress, not the wall clock, paces the program
        assert trajectory.read_int() == 0
        assert wait_for(lambda: not controller.state().program_running, timeout=10)
        reached = np.array(controller.state().actual_q)
        assert np.max(np.abs(reached - target)) < 2e-3, f"ended at {reached.tolist()}, target {target.tolist()}"


def test_a_speedj_with_time_that_nothing_follows_ramps_to_rest():
    with running_simulator(model="ur5e") as sim:
        controller = sim.controller
        controller.power_up()
        assert controller.run_program("def alone():\n  speedj([0, 0, 0, 0, 0, 0.2], 2.0, 0.1)\n  sleep(0.5)\nend\n",
                                      "test")
        assert wait_for(lambda: not controller.state().program_running, timeout=10)
        assert wait_for(lambda: not controller.state().motion_active, timeout=5)
        assert max(abs(v) for v in controller.state().actual_qd) < 1e-9


# A thread is started, then the main thread reads an integer that is already in its socket: as on a controller,
# where such a read takes no physical time, the main thread keeps its turn and kills the thread before it ran.
TURN_PROGRAM = """def keepsTurn():
  flag = 0
  seen = 0
  thread setter():
    flag = 1
  end
  socket_open("{host}", {port}, "s")
  sleep(0.3)
  i = 0
  while i < 20:
    t = run setter()
    r = socket_read_binary_integer(1, "s", 1.0)
    seen = seen + flag
    kill t
    flag = 0
    sync()
    i = i + 1
  end
  write_output_integer_register(0, seen)
  write_output_integer_register(1, 1)
end
"""


def test_a_read_of_data_already_there_keeps_the_threads_turn():
    """URCL's External Control reads a trajectory point and counts it down inside enter_critical; its main thread
    kills the trajectory thread when the client switches mode. Before, every read let other threads run, so the kill
    could fall between the two: the point was consumed, still counted, and the clean-up waited 0.5 s for it
    (URCL's switching_control_mode_with_trajectory_produces_result missed its 500 ms)."""
    with running_simulator(model="ur5e") as sim, socket.create_server((sim.host, 0)) as server:
        server.settimeout(10)
        controller = sim.controller
        assert controller.run_program(TURN_PROGRAM.format(host=sim.host, port=server.getsockname()[1]), "test")
        connection, _ = server.accept()
        with connection:
            connection.sendall(struct.pack(">20i", *range(20)))
            assert wait_for(lambda: controller.state().output_int_registers[1] == 1, timeout=10)
        assert controller.state().output_int_registers[0] == 0, "the started thread ran during reads of ready data"
