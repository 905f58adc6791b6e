"""A script's `speedj(qd, a, t)` with t shorter than the control cycle (docs/ursim.md): the arm moves in whole
cycles, and the thread's commands share a cycle's time as UR's manual (thread scheduling) describes — four
`speedj(qd, a, 0.002)` per 8 ms CB3 cycle, the cycle moving at qd. Before, each such call moved the arm for 2 ms of
an 8 ms cycle and took the whole cycle, so a script thread streaming speeds that way (ur_rtde's speed thread) moved
a CB3 at a quarter of the commanded speed."""
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from polling import wait_for
from sim_ursim.controller import Controller
from sim_ursim.launch import running_simulator
from sim_ursim.vocabulary import RobotMode

HOME = [0.0, -1.2, 1.0, -1.0, -1.5, 0.3]
QD = [0.5, 0, 0, 0, 0, 0]


@pytest.fixture
def cb3():
    """A CB3 (8 ms cycle) controller without its loop thread, stepped to RUNNING."""
    c = Controller("ur5", initial_q=HOME, mode_delay=0.01)
    c.brake_release()
    while c.step().robot_mode != RobotMode.RUNNING:
        pass
    return c


def test_short_held_speedj_moves_a_whole_cycle_and_the_next_ones_share_it(cb3):
    thread = object()  # the script thread that holds its speed commands
    start = cb3.state().actual_q[0]
    first = cb3.speedj(QD, a=1000.0, t=0.002, hold_owner=thread)
    assert not first.done
    moved = cb3.step().actual_q[0] - start
    assert first.done and moved == pytest.approx(0.5 * 0.008)  # one whole cycle at qd
    for _ in range(3):  # 2 + 2 + 2 ms more of the same cycle: over at once, the arm does not move again
        assert cb3.speedj(QD, a=1000.0, t=0.002, hold_owner=thread).done
    fifth = cb3.speedj(QD, a=1000.0, t=0.002, hold_owner=thread)
    assert not fifth.done  # the cycle's 8 ms are used up: this one needs the next cycle
    assert cb3.step().actual_q[0] - start == pytest.approx(2 * 0.5 * 0.008)
    assert fifth.done


def test_a_cycle_that_passed_without_a_command_leaves_no_time_to_share(cb3):
    thread = object()
    cb3.speedj(QD, a=1000.0, t=0.002, hold_owner=thread)
    cb3.step()
    held = cb3.step().actual_q[0]  # the thread was late: the arm held still for a cycle
    late = cb3.speedj(QD, a=1000.0, t=0.002, hold_owner=thread)
    assert not late.done and cb3.state().actual_q[0] == held
    assert cb3.step().actual_q[0] - held == pytest.approx(0.5 * 0.008)


UR_RTDE_SPEEDJ_EXAMPLE = """
import sys, rtde_control, rtde_receive
control = rtde_control.RTDEControlInterface(sys.argv[1])
receiver = rtde_receive.RTDEReceiveInterface(sys.argv[1])
acceleration, dt = 0.5, 1.0 / 500  # ur_rtde's speedj example, as published (a 500 Hz loop, also on a CB3)
joint_speed = [0.0] * 6
start, began = receiver.getActualQ()[0], receiver.getTimestamp()
for i in range(1000):
    t_start = control.initPeriod()
    control.speedJ(joint_speed, acceleration, dt)
    joint_speed[0] += 0.0005
    joint_speed[1] += 0.0005
    control.waitPeriod(t_start)
ended = receiver.getTimestamp()
control.speedStop()
print(receiver.getActualQ()[0] - start, ended - began, flush=True)
control.stopScript()
control.disconnect()
receiver.disconnect()
"""


def test_ur_rtde_speedj_example_on_a_cb3_moves_as_far_as_its_speeds_integrate_to():
    """The example ramps the base speed evenly to 0.5 rad/s: the joint travels the mean speed (0.25 rad/s) times
    the time the loop ran. Each speedJ waits for the control script's handshake through the RTDE stream, so on a
    CB3 the 1000 steps take about 8 s of controller time, not 2 s. The simulator moved a quarter of that (0.50 rad
in 8.0 s)."""
    with running_simulator(model="ur5", initial_q=[-1.54, -1.83, -2.28, -0.59, 1.60, 0.023]) as sim:
        sim.controller.power_up()
        done = subprocess.run([sys.executable, "-c", UR_RTDE_SPEEDJ_EXAMPLE, sim.host], capture_output=True,
                              text=True, timeout=120)
        assert done.returncode == 0, done.stderr[-2000:]
        travelled, duration = (float(value) for value in done.stdout.strip().splitlines()[-1].split())
        assert wait_for(lambda: not np.any(sim.controller.state().actual_qd))
    integrated = 0.25 * duration
    assert travelled == pytest.approx(integrated, rel=0.1), f"{travelled:.3f} rad in {duration:.2f} s"


STREAM = """def stream():
  k = 0
  while k < 150:
    speedj([0.1, 0, 0, 0, 0, 0], 1000, get_steptime())
    k = k + 1
  end
  write_output_integer_register(0, 1)
end
"""


def test_a_thread_streaming_held_speedj_moves_the_arm_every_cycle_while_the_host_runs_it_late():
    """URCL's splines send one speedj(qd, a, steptime) per cycle. When the host runs the interpreter's thread late
    (here another thread keeps Python's GIL busy), the control loop waits for that thread's next command before the
    next cycle, as a controller runs its script threads inside the frame: the simulator is late, the arm moves at qd
    every cycle. Before, the loop went on and the arm held still in 60-80 % of the cycles, which a client
    integrating the stream (URCL's spline test) reads as a wrong velocity."""
    with running_simulator(model="ur5") as sim:
        controller = sim.controller
        controller.power_up()
        assert controller.run_program(STREAM, "test")
        assert wait_for(lambda: controller.state().actual_qd[0] > 0, timeout=30)
        first = controller.state().cycle
        stop = threading.Event()
        hog = threading.Thread(target=lambda: [None for _ in iter(stop.is_set, True)])  # pure Python, GIL-bound
        hog.start()
        try:
            assert wait_for(lambda: controller.state().output_int_registers[0] == 1, timeout=60)
        finally:
            stop.set()
            hog.join()
        speeds = np.array([state.actual_qd[0] for state in controller.cycles_after(first)])
    moving = np.nonzero(speeds > 0)[0]
    window = speeds[moving[0]:moving[-1] + 1]
    held = int(np.sum(window < 0.1 - 1e-9))
    assert held <= 0.05 * len(window), f"the arm held still in {held} of {len(window)} cycles"


STEPS = """def steps():
  write_output_float_register(1, 100.0)
  sleep(0.1)
  i = 1
  while i < 40:
    write_output_float_register(1, i)
    speedj([0.01, 0, 0, 0, 0, 0], 1.0, get_steptime())
    i = i + 1
  end
  write_output_float_register(1, 200.0)
end
"""


def test_each_cycle_of_held_speedj_steps_carries_the_register_its_step_wrote():
    """URCL's spline thread writes its spline time to an output register, then runs one speedj per cycle; its test
    waits for the one package whose time reads below 0.01 (the first step). Before, the thread woke as soon as the
    cycle had moved its step, while that cycle's snapshot was still being built, and its next write went into it:
    a third of the values never reached the stream (the first one among them: 'Trajectory didn't start')."""
    with running_simulator(model="ur5") as sim:
        controller = sim.controller
        controller.power_up()
        last = controller.state().cycle
        assert controller.run_program(STEPS, "test")
        written: list[float] = []
        deadline = time.monotonic() + 10
        while not written or written[-1] != 200.0:
            assert time.monotonic() < deadline, "the program did not end within 10 s"
            states = controller.cycles_after(last, timeout=1)
            last = states[-1].cycle if states else last
            written += [float(state.output_double_registers[1]) for state in states]
    steps = [int(value) for value in written if 0 < value < 100]
    assert sorted(set(steps)) == list(range(1, 40)), f"steps missing from the cycles: {set(range(1, 40)) - set(steps)}"
