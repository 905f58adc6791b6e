"""A cell program run on sim_ursim (a real process, real sockets) as one URScript program, checked independently
through ur_rtde's RTDE receive interface: the linear descent stays on its segment, the output turns on at the
waypoint before the next move, wait-input holds until the input is set and fails the run after its timeout, and a
relative waypoint lands at its tool-frame offset, also after its base is re-taught."""
import threading
import time

import numpy as np
import pytest

import ur3dq.program
import ur3dq.robot
from polling import wait_for
from sim_ursim.control_channel import send_request
from ur3dq.errors import ProgramError
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.steps import DigitalOut, Motion, RelativeWaypoint, Wait, WaitInput, Waypoint

HOME = np.array([0.0, -1.5707963267948966, 1.2, -1.2, -1.5707963267948966, 0.0])
Q_PICK = np.array([0.4, -1.3, 1.5, -1.8, -1.5707963267948966, 0.3])
TOOL_OUT_0_BIT = 1 << 16   # RTDE actual_digital_output_bits: 16-17 are the tool outputs


@pytest.fixture(scope="module")
def setup():
    import rtde_receive

    from sim_ursim.launch import simulator_process

    with simulator_process(model="ur3", initial_q=list(HOME)) as simulator:
        with ur3dq.robot.connect(simulator.host) as robot:
            robot.power_on()
            robot.brake_release()
            receive = rtde_receive.RTDEReceiveInterface(simulator.host)
            try:
                yield simulator.host, robot, receive
            finally:
                receive.disconnect()


class Sampler:
    """Samples through ur_rtde in a thread while a program runs.

    Each sample: time, TCP pose vector, digital output bits, joints, joint speeds.
    """

    def __init__(self, receive):
        self.receive, self.samples, self._stop = receive, [], threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        while not self._stop.is_set():
            self.samples.append((time.monotonic(), np.array(self.receive.getActualTCPPose()),
                                 int(self.receive.getActualDigitalOutputBits()),
                                 np.array(self.receive.getActualQ()), np.array(self.receive.getActualQd())))
            time.sleep(0.002)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc_info):
        self._stop.set()
        self._thread.join()


def waypoint(name, q, motion=None):
    model, motion = robot_model("ur3"), motion or Motion()
    return Waypoint(name, Pose.from_dual_quaternion(name, model.fk(q), "ur3", joints=tuple(q)), motion)


def distance_to_segment(point, start, end):
    direction = end - start
    t = np.clip(np.dot(point - start, direction) / np.dot(direction, direction), 0.0, 1.0)
    return float(np.linalg.norm(point - (start + t * direction)))


def test_pick_and_place_program_runs_as_one_watched_program(setup):
    host, robot, receive = setup
    robot.movej(HOME)
    assert send_request(host, "set-digital-input", pin=3, on=False)["ok"]
    ur3dq.program.run(robot, [DigitalOut("release", "tool", 0, False)])  # when it turns on is measured below
    assert wait_for(lambda: not receive.getActualDigitalOutputBits() & TOOL_OUT_0_BIT)
    pick = waypoint("pick", Q_PICK, Motion("linear", 0.05, 0.5))
    steps = [RelativeWaypoint("approach", "pick", (0, 0, -0.05, 0, 0, 0), "tool", Motion("joint", 1.0, 2.0)),
             pick,
             DigitalOut("grip", "tool", 0, True),
             Wait("settle", 0.2),
             WaitInput("part", "standard", 3, True, 20.0),
             RelativeWaypoint("retract", "pick", (0, 0, -0.05, 0, 0, 0), "tool", Motion("linear", 0.1, 0.5))]
    started = {}

    def progress(position, step):
        started[step.name] = time.monotonic()
        if step.name == "part":   # the program holds here until the input is set
            threading.Timer(0.5, lambda: send_request(host, "set-digital-input", pin=3, on=True)).start()

    with Sampler(receive) as sampler:
        plan, _ = ur3dq.program.run(robot, steps, progress=progress)
    assert list(started) == ["approach", "pick", "grip", "settle", "part", "retract"]
    approach_tcp = np.asarray(plan[0].pose.translation)
    pick_tcp = np.asarray(plan[1].pose.translation)
    samples = sampler.samples
    # the linear descent: every TCP sample between its start and the output stays on the segment
    descent = [s[1][:3] for s in samples if started["pick"] <= s[0] <= started["grip"]]
    assert len(descent) > 20
    assert max(distance_to_segment(p, approach_tcp, pick_tcp) for p in descent) <= 0.5e-3
    # the joint move to approach follows the joint interpolation: every joint at the same fraction of its travel
    q_start, q_approach = HOME, plan[0].joints
    travel = q_approach - q_start
    moving = np.abs(travel) > 0.05
    for when, _, _, q, _ in samples:
        if started["approach"] <= when <= started["pick"]:
            fractions = (q - q_start)[moving] / travel[moving]
            assert np.ptp(fractions) <= 0.01, fractions
    # the output turns on with the arm at pick, and the retract starts only after it (and after the input)
    first_on = next(s for s in samples if s[2] & TOOL_OUT_0_BIT)
    assert np.linalg.norm(first_on[1][:3] - pick_tcp) <= 1e-4
    held = [s for s in samples if started["part"] <= s[0] <= started["part"] + 0.4]
    assert held and all(np.linalg.norm(s[1][:3] - pick_tcp) <= 1e-4 for s in held)
    # the relative waypoint lands 5 cm behind pick along pick's tool z (≤ 0.1 mm)
    final = np.array(receive.getActualTCPPose())[:3]
    expected = plan[1].pose.transform_point([0, 0, -0.05])
    assert np.linalg.norm(final - expected) <= 1e-4


def test_wait_input_timeout_fails_the_run_naming_the_step(setup):
    host, robot, receive = setup
    robot.movej(HOME)
    assert send_request(host, "set-digital-input", pin=5, on=False)["ok"]
    steps = [waypoint("here", HOME + [0.1, 0, 0, 0, 0, 0]), WaitInput("sensor", "standard", 5, True, 0.5),
             waypoint("never", HOME)]
    begun = time.monotonic()
    with pytest.raises(ProgramError, match=r"step 'sensor' \(wait-input\): input standard DI5 did not turn on "
                                           r"within 0.5 s"):
        ur3dq.program.run(robot, steps)
    assert time.monotonic() - begun < 10
    assert np.max(np.abs(np.array(receive.getActualQ()) - (HOME + [0.1, 0, 0, 0, 0, 0]))) < 1e-3


def test_relative_waypoint_follows_its_retouched_base(setup):
    host, robot, receive = setup
    robot.movej(HOME)
    for q in (Q_PICK, Q_PICK + [0.15, 0.1, -0.1, 0.05, 0.1, 0.2]):   # taught, then re-taught elsewhere
        base = waypoint("base", q)
        above = RelativeWaypoint("above", "base", (0.01, -0.02, -0.04, 0, 0, 0.3), "tool")
        plan, _ = ur3dq.program.run(robot, [base, above])
        expected = plan[0].pose.transform_point([0.01, -0.02, -0.04])
        assert np.linalg.norm(np.array(receive.getActualTCPPose())[:3] - expected) <= 1e-4


def test_a_joint_move_blends_into_a_linear_one(setup):
    host, robot, receive = setup
    robot.movej(HOME)
    pick = waypoint("pick", Q_PICK, Motion("linear", 0.1, 1.0))
    steps = [RelativeWaypoint("above", "pick", (0, 0, -0.08, 0, 0, 0), "tool", Motion("joint", 1.0, 2.0, 0.02)),
             pick]
    with Sampler(receive) as sampler:
        plan, _ = ur3dq.program.run(robot, steps)
    assert plan[0].blend == 0.02
    above = np.asarray(plan[0].pose.translation)
    # blended: the arm never stops at "above" (it passes within the radius without resting)
    near = [s for s in sampler.samples if np.linalg.norm(s[1][:3] - above) <= 0.02]
    assert near and min(np.linalg.norm(sample[4]) for sample in near) > 0.05
    np.testing.assert_allclose(np.array(receive.getActualQ()), Q_PICK, atol=1e-4)


def test_a_program_stopped_as_it_leaves_where_it_ends_fails_instead_of_waiting_forever(setup):
    """A closed program (out to a waypoint, back to the start) stopped by another thread just as the arm leaves:
    the arm rests where the program ends, but its last step never ran. The run fails at once with a ProgramError
    (it used to wait forever, no timeout counting once the program had ended: the screen's Stop hung so)."""
    host, robot, receive = setup
    robot.movej(HOME)
    slow = Motion("joint", 0.05, 0.5)   # rad/s, rad/s²: the stop lands within the 2 mrad of "at rest on target"
    steps = [waypoint("out", HOME + np.array([0.3, 0, 0, 0, 0, 0]), slow), waypoint("back", HOME, slow)]
    failure = []

    def run():
        try:
            ur3dq.program.run(robot, steps)
        except ProgramError as error:
            failure.append(error)

    runner = threading.Thread(target=run, daemon=True)
    runner.start()
    assert wait_for(lambda: abs(receive.getActualQd()[0]) > 0.005, timeout=10)
    robot.stop()
    runner.join(10.0)
    assert not runner.is_alive(), "the run still waits 10 s after the stop"
    assert failure and "ended before it reported its last step" in str(failure[0]), failure
    assert np.max(np.abs(robot.joints() - HOME)) < 2e-3   # the case at hand: at rest where the program ends
