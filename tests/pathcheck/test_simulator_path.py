"""End to end: the path the check samples is the path the simulator runs. A URScript program (movel with a turn,
then movej) goes to a sim_ursim process on its secondary port; ur_rtde's RTDE receive interface records the TCP
and the joints while it runs; every recorded point must lie within the check's sampling tolerance of its samples,
the arm must end on the joints the check predicted (same IK branch), and no protective stop may occur."""
import contextlib
import itertools
import math
import socket
import struct
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from polling import wait_for
from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import Margins, PathPlan, PathSegment, check_path
from ur3dq.pathcheck.geometry import segment_segment_distance

rtde_receive = pytest.importorskip("rtde_receive")

UR3 = robot_model("ur3")
START = [0.2, -1.3, 1.3, -1.5708, -1.5708, 0.3]
JOINT_TARGET = np.array([-0.4, -1.5, 1.6, -1.9, -1.3, -0.2])
PRIMARY_PORT, SECONDARY_PORT = 30001, 30002
ROBOT_MESSAGE, ERROR_CODE_MESSAGE = 20, 6   # primary-port package type, robot message sub-type
DASHBOARD_PORT = 29999
NORMAL, PROTECTIVE_STOP = 1, 3  # RTDE safety modes
# A line across the arm's plane through θ5 = 0.01 (tool nearly parallel to wrist 1's axis), from these joints.
NEAR_SINGULAR_MIDDLE = np.array([0.0, -1.3, 1.9, -2.2, 0.01, 0.5])
NEAR_SINGULAR_START = UR3.ik(DualQuaternion.from_translation([0.0, 0.05, 0.0]) * UR3.fk(NEAR_SINGULAR_MIDDLE),
                             NEAR_SINGULAR_MIDDLE)


def dashboard(host, *commands):
    with socket.create_connection((host, DASHBOARD_PORT), timeout=5) as sock:
        reader = sock.makefile("r")
        reader.readline()
        for command in commands:
            sock.sendall(command.encode() + b"\n")
            reader.readline()


@contextlib.contextmanager
def running_arm(initial_q):
    """(host, RTDE receiver) of a simulated UR3 process at `initial_q`, powered and RUNNING."""
    from sim_ursim.launch import simulator_process

    with simulator_process(model="ur3", initial_q=initial_q) as process:
        dashboard(process.host, "power on", "brake release")
        receiver = rtde_receive.RTDEReceiveInterface(process.host)
        try:
            assert wait_for(lambda: receiver.getRobotMode() == 7, timeout=10), "the simulator never got RUNNING"
            yield process.host, receiver
        finally:
            receiver.disconnect()


@pytest.fixture
def arm(request):
    """(host, RTDE receiver) of a powered simulated UR3 starting at START (or the joints of an indirect parameter)."""
    with running_arm([float(v) for v in getattr(request, "param", START)]) as arm:
        yield arm


def test_the_sampled_path_is_the_path_the_simulator_reports_over_rtde(arm):
    host, receiver = arm
    start = np.array(receiver.getActualQ())
    # The line: 12 cm across and 5 cm down while the tool turns 40° about its own axis.
    goal = DualQuaternion.from_translation([0.08, 0.09, -0.05]) * UR3.fk(start) * \
        DualQuaternion.from_axis_angle([0.0, 0.0, 1.0], math.radians(40))
    plan = PathPlan(start, [PathSegment("line", "linear", target_pose=goal.to_array(), speed=0.1, acceleration=1.2),
                            PathSegment("swing", "joint", target_joints=JOINT_TARGET, speed=1.0, acceleration=1.4)])
    margins = Margins()
    result = check_path(UR3, plan, margins=margins)
    assert result.ok, result.summary()
    line, swing = result.steps

    x, y, z, rx, ry, rz = (float(v) for v in goal.to_ur_pose())
    program = (f"def checked():\n  movel(p[{x!r}, {y!r}, {z!r}, {rx!r}, {ry!r}, {rz!r}], a=1.2, v=0.1)\n"
               f"  movej([{', '.join(repr(float(v)) for v in JOINT_TARGET)}], a=1.4, v=1.0)\nend\n")
    tcp, joints = [], []
    with socket.create_connection((host, SECONDARY_PORT), timeout=5) as sock:
        sock.sendall(program.encode())
        assert wait_for(lambda: np.linalg.norm(np.array(receiver.getActualQ()) - start) > 1e-6, timeout=5)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            tcp.append(receiver.getActualTCPPose())
            joints.append(receiver.getActualQ())
            if np.allclose(joints[-1], JOINT_TARGET, atol=1e-6):
                break
            time.sleep(0.002)
    assert receiver.getSafetyMode() == NORMAL, "the simulator stopped the arm"
    tcp, joints = np.array(tcp), np.array(joints)
    assert np.allclose(joints[-1], JOINT_TARGET, atol=1e-6), "the program did not finish"

    # Split the recording at the joints where the line ends: the check predicted them (IK continuity).
    end_of_line = int(np.argmin(np.linalg.norm(joints - line.end_joints, axis=1)))
    assert np.linalg.norm(joints[end_of_line] - line.end_joints) < 1e-4
    line_tcp, swing_joints = tcp[:end_of_line + 1], joints[end_of_line:]
    assert len(line_tcp) > 50 and len(swing_joints) > 20    # the recording covers both moves

    positions = dqarray.translation_unchecked(dqarray.from_ur_pose(line_tcp))
    nearest = np.min(np.linalg.norm(positions[:, None] - line.tcp[None], axis=2), axis=1)
    print(f"line: {len(positions)} RTDE samples, farthest {nearest.max() * 1000:.3f} mm from a check sample")
    assert nearest.max() <= margins.tcp_resolution
    # And on the sampled polyline itself (point to segment distance): the simulator runs the same line.
    to_polyline = np.min(segment_segment_distance(positions[:, None], positions[:, None], line.tcp[None, :-1],
                                                  line.tcp[None, 1:]), axis=1)
    print(f"line: farthest {to_polyline.max() * 1e6:.2f} µm from the sampled polyline")
    assert to_polyline.max() <= 1e-5
    # Orientation: each recorded pose against the sample nearest in position (SLERP about one fixed axis).
    index = np.argmin(np.linalg.norm(positions[:, None] - line.tcp[None], axis=2), axis=1)
    _, turn = dqarray.pose_distance(dqarray.from_ur_pose(line_tcp), UR3.fk_batch(line.joints[index]))
    assert turn.max() <= math.radians(40) * margins.tcp_resolution / 0.1 + 1e-6
    # The joint move: every recorded joint vector within the joint resolution of the sampled joint line.
    gap = np.min(np.max(np.abs(swing_joints[:, None] - swing.joints[None]), axis=2), axis=1)
    print(f"swing: {len(swing_joints)} RTDE samples, farthest {math.degrees(gap.max()):.4f}° from a check sample")
    assert gap.max() <= margins.joint_resolution


def movel_program(pose, a, v) -> bytes:
    x, y, z, rx, ry, rz = (float(c) for c in pose.to_ur_pose())
    return f"def line():\n  movel(p[{x!r}, {y!r}, {z!r}, {rx!r}, {ry!r}, {rz!r}], a={a}, v={v})\nend\n".encode()


@pytest.mark.parametrize("arm", [NEAR_SINGULAR_START], indirect=True, ids=["near-singular start"])
def test_a_line_refused_for_the_wrist_singularity_is_one_the_simulator_stops(arm):
    host, receiver = arm
    start = np.array(receiver.getActualQ())
    goal = DualQuaternion.from_translation([0.0, -0.05, 0.0]) * UR3.fk(NEAR_SINGULAR_MIDDLE)
    result = check_path(UR3, PathPlan(start, [PathSegment("across", "linear", target_pose=goal.to_array(),
                                                          speed=0.1)]))
    checks = {problem.check for problem in result.problems}
    assert {"wrist", "joint_speed"} <= checks, result.summary()
    with socket.create_connection((host, PRIMARY_PORT), timeout=5) as primary, \
            socket.create_connection((host, SECONDARY_PORT), timeout=5) as sock:
        sock.sendall(movel_program(goal, 1.2, 0.1))
        stopped = wait_for(lambda: receiver.getSafetyMode() == PROTECTIVE_STOP, timeout=15)
        errors = error_code_messages(primary, until=lambda found: found, timeout=5)
    assert stopped, \
        f"no protective stop: safety mode {receiver.getSafetyMode()}, joints {receiver.getActualQ()}, " \
        f"started at {start.tolist()}"
    assert not np.allclose(receiver.getActualQ(), result.steps[0].end_joints, atol=1e-3)
    # as a controller reports it: a C204 (path sanity check) error on the primary port naming the singularity
    assert errors and errors[0][:2] == (204, 3) and "close to singularity" in errors[0][2], errors


def error_code_messages(sock, until, timeout):
    """[(code, argument, text)] of the error-code robot messages (type 20, sub-type 6) read from a primary-port
    socket until `until(found)` or `timeout` s (docs/protocols.md: robot messages)."""
    buffer, found = b"", []
    deadline = time.monotonic() + timeout
    sock.settimeout(0.2)
    while time.monotonic() < deadline and not until(found):
        try:
            buffer += sock.recv(65536)
        except TimeoutError:
            continue
        while len(buffer) >= 5 and len(buffer) >= int.from_bytes(buffer[:4], "big"):
            size = int.from_bytes(buffer[:4], "big")
            packet, buffer = buffer[:size], buffer[size:]
            if packet[4] == ROBOT_MESSAGE and packet[14] == ERROR_CODE_MESSAGE:
                code, argument = struct.unpack_from(">ii", packet, 15)
                found.append((code, argument, packet[15 + 17:].decode("utf-8", "replace")))
    return found


@pytest.fixture(scope="module")
def shared_arm():
    """One simulated UR3 for the property test's examples (each starts where the previous one ended)."""
    with running_arm(START) as arm:
        yield arm


def urscript_move(segment) -> str:
    if segment.move == "joint":
        return f"  movej([{', '.join(repr(float(v)) for v in segment.target_joints)}], a=1.4, v={segment.speed})\n"
    x, y, z, rx, ry, rz = (float(c) for c in DualQuaternion.from_array(segment.target_pose).to_ur_pose())
    return f"  movel(p[{x!r}, {y!r}, {z!r}, {rx!r}, {ry!r}, {rz!r}], a=1.2, v={segment.speed})\n"


# Each program ends by writing its own number to output integer register 12, and the test waits for that number: the
# evidence that *this* program ran to its end. Waiting on the arm's position alone passed at once for a program that
# moves nowhere (the arm already rests there) before it had even started; the next example's program, sent on
# another connection, could then be replaced by that late one, and the arm stayed put (seen once at stop 20).
_PROGRAM_NUMBERS = itertools.count(1)
FINISHED_REGISTER = 12


# Exclusive (run alone after the parallel pass): six programs on one simulator, each waited for up to 20 s.
@pytest.mark.exclusive
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.one_of(
    st.tuples(st.just("linear"), st.tuples(*[st.floats(-0.08, 0.08)] * 3)),
    st.tuples(st.just("joint"), st.tuples(*[st.floats(-0.3, 0.3)] * 6))), min_size=1, max_size=3))
def test_what_the_check_accepts_the_simulator_runs_to_the_predicted_joints_without_a_stop(shared_arm, moves):
    host, receiver = shared_arm
    start = np.array(receiver.getActualQ())
    home = UR3.fk(START)
    segments = []
    for i, (move, values) in enumerate(moves):
        if move == "joint":
            segments.append(PathSegment(f"j{i}", "joint", target_joints=np.array(START) + values, speed=1.0))
        else:
            pose = DualQuaternion.from_translation(values) * home
            segments.append(PathSegment(f"l{i}", "linear", target_pose=pose.to_array(), speed=0.25))
    result = check_path(UR3, PathPlan(start, segments))
    assume(result.ok)
    end = result.steps[-1].end_joints
    number = next(_PROGRAM_NUMBERS)
    program = ("def accepted():\n" + "".join(urscript_move(s) for s in segments)
               + f"  write_output_integer_register({FINISHED_REGISTER}, {number})\nend\n")
    with socket.create_connection((host, SECONDARY_PORT), timeout=5) as sock:
        sock.sendall(program.encode())
        finished = wait_for(lambda: receiver.getSafetyMode() != NORMAL
                            or receiver.getOutputIntRegister(FINISHED_REGISTER) == number, timeout=20)
    assert receiver.getSafetyMode() == NORMAL, "the simulator stopped a path the check accepted"
    assert finished, f"program {number} did not run to its end within 20 s"
    arrived = wait_for(lambda: np.allclose(receiver.getActualQ(), end, atol=1e-5)
                       and not np.any(receiver.getActualQd()), timeout=2)
    assert arrived, f"the arm ended at {receiver.getActualQ()}, the check predicted {end.tolist()}"
