"""The controller model and motion engine (no servers): modes, safety, motions, I/O.

Trajectory tests drive a stopped controller cycle by cycle with `step()`, so every cycle is seen and timings are
exact whatever the machine load; behaviour tied to the clock (period, safety stops, waits) uses the real loop.
"""
import math
import sys
import threading
import time
import types

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from polling import wait_for
from sim_ursim import kinematics
from sim_ursim.controller import JOINT_HISTORY_CYCLES, Controller
from sim_ursim.messages import SafetyModeMessage
from sim_ursim.models import robot_model
from sim_ursim.urscript.builtins import BUILTINS
from sim_ursim.urscript.values import ScriptError
from sim_ursim.vocabulary import CommandRefused, JointMode, RobotMode, RuntimeState, SafetyMode, UnlockTooEarly

HOME = [0.0, -1.2, 1.2, -1.5, -1.5, 0.0]


def stepped_ready(model="ur3", **options):
    """A controller without its loop thread, stepped to RUNNING."""
    c = Controller(model, initial_q=options.pop("initial_q", HOME), mode_delay=0.05, **options)
    c.brake_release()
    while c.step().robot_mode != RobotMode.RUNNING:
        pass
    return c


@pytest.fixture
def stepped():
    return stepped_ready()


@pytest.fixture
def controller():
    c = Controller("ur3", initial_q=HOME, mode_delay=0.05, unlock_delay=0.5)
    c.start()
    c.power_up()
    yield c
    c.shutdown()


def run_and_trace(controller, motion_handle, max_cycles=5000):
    """Snapshots of every cycle of a stepped controller until the motion ends and the arm is at rest."""
    trace = [controller.state()]
    while (not motion_handle.done or trace[-1].motion_active) and len(trace) < max_cycles:
        trace.append(controller.step())
    assert motion_handle.done, "motion did not finish in time"
    return trace


def moving_interval(trace):
    """Simulated seconds between the first and the last cycle in which the joints moved."""
    moving = [s.timestamp for s in trace if np.any(s.actual_qd != 0)]
    return moving[-1] - moving[0] + trace[1].timestamp - trace[0].timestamp


# ------------------------------------------------------------------------------------------ modes
def test_power_on_brake_release_and_power_off_walk_through_the_robot_modes():
    c = Controller("ur3e", mode_delay=0.05)
    c.start()
    try:
        assert c.period == pytest.approx(0.002)
        state = c.state()
        assert (state.robot_mode, state.joint_mode[0], state.power_on) == (RobotMode.POWER_OFF, JointMode.POWER_OFF,
                                                                          False)
        c.power_on()
        assert c.state().robot_mode in (RobotMode.POWER_OFF, RobotMode.POWER_ON)  # snapshot of the last cycle
        modes = {c.wait_cycle(c.state().cycle, 1).robot_mode for _ in range(100)}
        assert {RobotMode.POWER_ON, RobotMode.IDLE} <= modes and RobotMode.RUNNING not in modes
        c.brake_release()
        state = c.power_up()
        assert (state.robot_mode, state.joint_mode, state.brakes_released) == (
            RobotMode.RUNNING, (JointMode.RUNNING,) * 6, True)
        assert state.robot_status_bits & 1
        c.power_off()
        state = c.wait_cycle(c.state().cycle, 1)
        assert (state.robot_mode, state.power_on, state.robot_status_bits & 1) == (RobotMode.POWER_OFF, False, 0)
    finally:
        c.shutdown()


def test_control_loop_keeps_its_period_on_a_steady_clock():
    c = Controller("ur3")
    c.start()
    try:
        first = c.wait_cycle(c.state().cycle, 1)
        began = time.monotonic()
        time.sleep(1.0)
        last = c.state()
        elapsed = time.monotonic() - began
        # Simulated time tracks wall time (skipped cycles are folded into longer steps, never lost).
        assert last.timestamp - first.timestamp == pytest.approx(elapsed, abs=0.1)
        assert last.cycle - first.cycle == pytest.approx(elapsed * 125, abs=13)
    finally:
        c.shutdown()


def test_motions_are_refused_unless_running_and_normal():
    c = Controller("ur3")
    c.start()
    try:
        with pytest.raises(CommandRefused, match="robot mode is POWER_OFF"):
            c.movej(HOME)
        c.power_up()
        c.protective_stop("test")
        with pytest.raises(CommandRefused, match="safety mode is PROTECTIVE_STOP"):
            c.speedj([0.1, 0, 0, 0, 0, 0])
    finally:
        c.shutdown()


def test_bad_arguments_name_the_problem(controller):
    with pytest.raises(ValueError, match="q must be 6 numbers"):
        controller.movej([0, 0, 0])
    with pytest.raises(ValueError, match="a must be > 0"):
        controller.movej(HOME, a=0)
    with pytest.raises(ValueError, match="speed slider fraction"):
        controller.set_speed_slider(1.5)
    with pytest.raises(ValueError, match="exceeds the joint speed limits"):
        controller.speedj([10, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match="unknown"):
        Controller("ur4")
    with pytest.raises(ValueError, match="does not fit model ur3"):
        Controller("ur3", version="5.11.1")


# ------------------------------------------------------------------------------------------ movej / movel
@pytest.mark.parametrize("model", ["ur3", "ur3e"])
def test_movej_follows_the_trapezoid_timing_and_lands_exactly(model):
    stepped = stepped_ready(model)
    target = np.array(HOME) + [1.0, 0.5, -0.25, 0, 0, 0]
    trace = run_and_trace(stepped, stepped.movej(target, a=1.4, v=1.05))
    assert stepped.state().actual_q.tolist() == pytest.approx(target.tolist(), abs=1e-12)
    assert moving_interval(trace) == pytest.approx(1.0 / 1.05 + 1.05 / 1.4, abs=2 * stepped.period)
    peak = max(abs(s.actual_qd[0]) for s in trace)
    assert peak == pytest.approx(1.05, rel=0.01)
    assert max(abs(s.actual_qd[1]) for s in trace) == pytest.approx(0.525, rel=0.01)  # synchronised: half travel


@settings(max_examples=15, deadline=None)
@given(start=st.lists(st.floats(-3, 3), min_size=6, max_size=6), end=st.lists(st.floats(-3, 3), min_size=6, max_size=6),
       speed=st.floats(0.5, 10), acceleration=st.floats(0.5, 20))  # slower only lengthens the same trapezoid
def test_any_movej_lands_exactly_and_respects_every_joint_speed_limit(start, end, speed, acceleration):
    stepped = stepped_ready(initial_q=start)
    # Cycle budget: 3 × the slowest trapezoid these limits allow (a fixed budget once cut long slow moves short).
    slowest_speed = min(speed, float(np.min(stepped.model.max_joint_speed)))
    slowest_acceleration = min(acceleration, float(np.min(stepped.model.max_joint_acceleration)))
    travel = float(np.max(np.abs(np.subtract(end, start))))
    budget = 3 * (travel / slowest_speed + slowest_speed / slowest_acceleration) / stepped.period
    trace = run_and_trace(stepped, stepped.movej(end, a=acceleration, v=speed), max_cycles=int(budget) + 100)
    assert trace[-1].actual_q.tolist() == pytest.approx(end, abs=1e-12)
    peak = np.max(np.abs([s.actual_qd for s in trace]), axis=0)
    assert np.all(peak <= stepped.model.max_joint_speed * (1 + 1e-9))
    assert np.max(peak) <= speed * (1 + 1e-9)


def test_movej_time_argument_sets_the_duration(stepped):
    target = np.array(HOME) + [0.3, 0, 0, 0, 0, 0]
    trace = run_and_trace(stepped, stepped.movej(target, t=2.0))
    assert moving_interval(trace) == pytest.approx(2.0, abs=2 * stepped.period)


def test_speed_slider_stretches_trajectory_time(stepped):
    stepped.set_speed_slider(0.5)
    target = np.array(HOME) + [0.5, 0, 0, 0, 0, 0]
    trace = run_and_trace(stepped, stepped.movej(target, a=1.4, v=1.05))
    full_speed = 2 * math.sqrt(0.5 / 1.4)
    assert moving_interval(trace) == pytest.approx(2 * full_speed, abs=3 * stepped.period)
    assert trace[-1].target_speed_fraction == 0.5


def test_movej_outside_the_joint_limits_is_refused_before_moving(controller):
    with pytest.raises(CommandRefused, match="joint 0 at 7.0000 rad is outside its limits"):
        controller.movej([7.0, -1.2, 1.2, -1.5, -1.5, 0])
    assert not controller.state().motion_active


def test_movel_keeps_the_tcp_on_a_straight_line(stepped):
    start = stepped.state().actual_tcp_pose.copy()
    goal = start + [0.05, -0.08, 0.04, 0, 0, 0]
    trace = run_and_trace(stepped, stepped.movel(goal, a=1.2, v=0.25))
    direction = (goal[:3] - start[:3]) / np.linalg.norm(goal[:3] - start[:3])
    for state in trace:
        offset = state.actual_tcp_pose[:3] - start[:3]
        assert np.linalg.norm(offset - direction * offset.dot(direction)) < 1e-7
        assert state.actual_tcp_pose[3:] == pytest.approx(start[3:].tolist(), abs=1e-7)
    assert trace[-1].actual_tcp_pose.tolist() == pytest.approx(goal.tolist(), abs=1e-9)
    assert max(np.linalg.norm(s.actual_tcp_speed[:3]) for s in trace) == pytest.approx(0.25, rel=0.02)


def test_tcp_pose_is_dh_fk_of_the_joints_with_the_tcp_offset(controller):
    controller.set_tcp([0, 0, 0.1, 0, 0, 0.5])
    state = controller.wait_cycle(controller.state().cycle, 1)
    expected = kinematics.tcp_pose(controller.model.dh, state.actual_q, [0, 0, 0.1, 0, 0, 0.5])
    assert state.actual_tcp_pose.tolist() == pytest.approx(expected.tolist(), abs=1e-12)
    assert state.tcp_offset.tolist() == [0, 0, 0.1, 0, 0, 0.5]
    assert controller.ik(state.actual_tcp_pose).tolist() == pytest.approx(state.actual_q.tolist(), abs=1e-8)


def test_every_setter_is_in_state_as_soon_as_it_returns(controller):
    """A command's effect is visible to the next statement: no waiting for the control cycle (issue 9 move 2)."""
    for n in range(300):
        offset = [0.0, 0.0, 0.01 * (n % 7 + 1), 0.0, 0.0, 0.1 * (n % 5)]
        controller.set_tcp(offset)
        state = controller.state()
        assert state.tcp_offset.tolist() == offset
        expected = kinematics.tcp_pose(controller.model.dh, state.actual_q, offset)
        assert state.actual_tcp_pose.tolist() == pytest.approx(expected.tolist(), abs=1e-12)
        controller.set_payload(0.1 * (n % 3), [0.0, 0.0, 0.01 * (n % 4)])
        assert controller.state().payload == pytest.approx(0.1 * (n % 3))
        assert controller.state().payload_cog.tolist() == pytest.approx([0.0, 0.0, 0.01 * (n % 4)])
        controller.io.set_int_register("output", 3, n)
        assert controller.state().output_int_registers[3] == n
        controller.io.set_standard_digital_out(2, n % 2 == 0)
        assert bool(controller.state().standard_digital_output_bits & 4) == (n % 2 == 0)
        controller.set_external_force_torque([float(n), 0, 0, 0, 0, 0])
        assert controller.state().actual_tcp_force[0] == n
    controller.set_tcp([0, 0, 0, 0, 0, 0])


def test_io_writes_in_a_batch_commit_once_and_are_all_in_state(controller):
    """An RTDE input package's many register writes commit the snapshot once (rtde/inputs.py uses io.batch())."""
    commits = []
    io = controller.io
    commit = io.on_change
    io.on_change = lambda: (commits.append(1), commit())
    try:
        with io.batch():
            for n in range(10):
                io.set_int_register("input", n, 100 + n)
            io.set_standard_digital_out(1, True)
        assert len(commits) == 1
        state = controller.state()
        assert state.input_int_registers[:10].tolist() == list(range(100, 110))
        assert state.standard_digital_output_bits & 2
        io.set_int_register("input", 0, 7)  # outside a batch: one commit per write
        assert len(commits) == 2 and controller.state().input_int_registers[0] == 7
    finally:
        io.on_change = commit


def test_blended_moves_overlap_and_keep_the_speed_continuous(stepped):
    first = np.array(HOME) + [0.6, 0, 0, 0, 0, 0]
    second = first + [0, 0.4, 0, 0, 0, 0]
    unblended = (2 * math.sqrt(0.6 / 1.4)) + (2 * math.sqrt(0.4 / 1.4))
    first_motion = stepped.movej(first, r=0.05)
    second_motion = stepped.movej(second)
    trace = run_and_trace(stepped, second_motion)
    assert first_motion.succeeded and second_motion.succeeded
    assert trace[-1].actual_q.tolist() == pytest.approx(second.tolist(), abs=1e-12)
    assert moving_interval(trace) < unblended - 0.1
    speed_jumps = [np.max(np.abs(b.actual_qd - a.actual_qd)) for a, b in zip(trace, trace[1:])]
    assert max(speed_jumps) <= 1.4 * 2 * stepped.period * 1.01  # at most the two superposed accelerations


def test_a_tcp_set_while_a_blended_movel_runs_applies_to_the_next_move_only(stepped):
    """PolyScope sets the next Move node's TCP as soon as the blended move before it returns, while the arm is
    still on that move: its line stays the line of the TCP it was commanded with (before, the rest of it was solved
    for the new TCP, a jump that protective-stopped the arm)."""
    tool_a, tool_b = [0, 0, 0.05, 0, 0, 0], [0, 0.12, 0.2, 0.4, 0, 0]
    stepped.set_tcp(tool_a)
    start = stepped.fk(HOME)
    first_target = start + [0.15, 0, 0, 0, 0, 0]
    first = stepped.movel(first_target, v=0.25, r=0.02)
    trace = [stepped.state()]
    while not first.done:
        trace.append(stepped.step())
    stepped.set_tcp(tool_b)
    second_target = stepped.fk(stepped.state().actual_q) + [0, 0.1, -0.05, 0, 0, 0]
    second = stepped.movel(second_target, v=0.25)
    trace += run_and_trace(stepped, second)
    assert first.succeeded and second.succeeded, (first.error, second.error)
    assert all(s.safety_mode == SafetyMode.NORMAL for s in trace)
    line = (first_target - start)[:3] / np.linalg.norm((first_target - start)[:3])
    arm_a = kinematics.ArmKinematics(stepped.model.dh, tool_a)
    for state in trace[:len(trace) // 4]:   # the first move, well before its blend zone
        off_line = arm_a.tcp_pose(state.actual_q)[:3] - start[:3]
        assert np.linalg.norm(off_line - line * (off_line @ line)) < 1e-9
    assert trace[-1].actual_tcp_pose.tolist() == pytest.approx(second_target.tolist(), abs=1e-9)
    steps = [np.max(np.abs(b.actual_q - a.actual_q)) / stepped.period for a, b in zip(trace, trace[1:])]
    assert max(steps) < 2.0   # rad/s: no jump where the next move takes over


# ------------------------------------------------------------------------------------------ stops and speeds
def test_stopj_decelerates_at_the_requested_rate(stepped):
    move = stepped.movej(np.array(HOME) + [3.0, 0, 0, 0, 0, 0], a=1.4, v=1.0)
    state = stepped.state()
    while state.actual_qd[0] < 0.999:
        state = stepped.step()
    stop = stepped.stopj(2.0)
    trace = run_and_trace(stepped, stop)
    assert move.error == "stopped by stopj"
    assert trace[-1].timestamp - state.timestamp == pytest.approx(0.5, abs=2 * stepped.period)
    assert trace[-1].actual_q[0] - state.actual_q[0] == pytest.approx(0.25, abs=0.01)  # v²/2a
    assert all(abs(b.actual_qd[0] - a.actual_qd[0]) <= 2.0 * stepped.period + 1e-9 for a, b in zip(trace, trace[1:]))


def test_speedj_runs_then_stops_after_its_time(stepped):
    trace = run_and_trace(stepped, stepped.speedj([0.2, 0, 0, 0, 0, -0.4], a=2.0, t=0.5))
    assert max(s.actual_qd[5] for s in trace) == pytest.approx(0, abs=1e-9)
    assert min(s.actual_qd[5] for s in trace) == pytest.approx(-0.4, rel=0.01)
    assert not np.any(trace[-1].actual_qd)


def test_speedj_into_a_joint_limit_raises_a_protective_stop():
    c = Controller("ur3", initial_q=[6.2, -1.2, 1.2, -1.5, -1.5, 0], mode_delay=0.05)
    c.start()
    try:
        c.power_up()
        handle = c.speedj([1.0, 0, 0, 0, 0, 0], a=5.0)
        assert handle.wait(3)
        assert "joint 0 position limit" in handle.error
        state = c.wait_cycle(c.state().cycle, 1)
        assert state.safety_mode == SafetyMode.PROTECTIVE_STOP
        assert state.actual_q[0] <= 2 * math.pi
    finally:
        c.shutdown()


def test_servoj_tracks_a_stream_of_targets(controller):
    q = np.array(HOME)
    for _ in range(50):
        q = q + [0.002, 0, 0, 0, 0, 0]
        controller.servoj(q, t=0.008, lookahead_time=0.1, gain=300)
        controller.wait_cycle(controller.state().cycle, 1)
    state = controller.wait_cycle(controller.wait_cycle(controller.state().cycle, 1).cycle, 1)
    assert state.actual_q[0] == pytest.approx(q[0], abs=1e-9)
    with pytest.raises(ValueError, match="lookahead_time"):
        controller.servoj(q, lookahead_time=1.0)


def test_speedl_moves_the_tcp_along_the_twist(stepped):
    start = stepped.state().actual_tcp_pose.copy()
    run_and_trace(stepped, stepped.speedl([0, 0, 0.05, 0, 0, 0], a=0.5, t=0.4))
    moved = stepped.state().actual_tcp_pose - start
    # ramp 0.1 s up, 0.3 s at 5 cm/s, 0.1 s down: 0.0025 + 0.015 + 0.0025 m
    assert moved[2] == pytest.approx(0.02, abs=0.001)
    assert np.abs(moved[:2]).max() < 1e-6


SPEEDL_START = [0.0, -1.2, 1.0, -1.0, -1.5, 0.3]
SLOW_RISE = [0, 0, 0.02, 0, 0, 0]  # 2 cm/s straight up


@pytest.mark.parametrize("slider", [1.0, 0.5, 0.2])
def test_speedl_repeated_every_cycle_keeps_its_speed_under_the_slider(slider):
    """ur_rtde's speed thread re-issues speedl every cycle: the ramp must continue, not restart from the measured
    speed (which the slider has already scaled) each time."""
    c = stepped_ready(initial_q=SPEEDL_START)
    c.set_speed_slider(slider)
    for _ in range(int(0.5 / c.period)):
        c.speedl(SLOW_RISE, 0.25, 0.0)
        state = c.step()
    assert state.actual_tcp_speed == pytest.approx(np.multiply(SLOW_RISE, slider), abs=1e-9)


def test_speedj_repeated_every_cycle_keeps_its_speed_under_the_slider(stepped):
    stepped.set_speed_slider(0.5)
    for _ in range(int(0.5 / stepped.period)):
        stepped.speedj([0, 0, 0.2, 0, 0, 0], 1.0, 0.0)
        state = stepped.step()
    assert state.actual_qd == pytest.approx([0, 0, 0.1, 0, 0, 0], abs=1e-9)


def test_repeated_speedl_on_the_running_loop_never_protective_stops(controller):
    """The reported scenario, on the real loop: 40 speedl calls 8 ms apart at 2 cm/s."""
    controller.movej(SPEEDL_START, a=10, v=3).wait(10)
    fastest = 0.0
    for _ in range(40):
        controller.speedl(SLOW_RISE, 0.25, 0.0)
        time.sleep(0.008)
        state = controller.state()
        fastest = max(fastest, float(np.abs(state.actual_qd).max()))
    controller.stopl(1.0).wait(5)
    assert state.safety_mode == SafetyMode.NORMAL
    assert fastest < 0.3


def test_a_stalled_loop_runs_every_missed_cycle_one_period_each(controller):
    """A controller never skips a cycle: when the host runs the loop late (here another thread keeps Python's GIL
    for 0.2 s at a time), the missed cycles run back to back afterwards, each one period, and every snapshot is
    kept in order for the streams (cycles_after). Before, a late loop covered the stall in one long cycle."""
    controller.speedj([0.1, 0, 0, 0, 0, 0], a=10.0)
    first = controller.state().cycle
    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.2)
    try:
        began = time.monotonic()
        while time.monotonic() - began < 0.5:
            pass  # pure Python: the control thread waits for the GIL
    finally:
        sys.setswitchinterval(interval)
    cycles_due = (time.monotonic() - began) / controller.period
    assert wait_for(lambda: controller.state().cycle - first >= cycles_due)  # caught up with the wall clock
    states = controller.cycles_after(first)
    assert [s.cycle for s in states] == list(range(first + 1, first + 1 + len(states)))
    assert len(states) >= cycles_due
    steps = np.diff([s.timestamp for s in states])
    assert steps == pytest.approx(np.full(len(steps), controller.period), abs=1e-12)
    moved = np.diff([s.actual_q[0] for s in states])
    assert moved[-10:] == pytest.approx(np.full(10, 0.1 * controller.period), rel=1e-6)


# ------------------------------------------------------------------------------------------ safety
class RecordingRunner:
    """A stand-in URScript runner (our own hook interface, not a client library) that records the calls."""

    def __init__(self):
        self.calls = []
        self.is_running = True

    def submit(self, source, origin):
        self.calls.append(("submit", origin))

    def stop(self):
        self.calls.append(("stop",))
        self.is_running = False

    def pause(self):
        self.calls.append(("pause",))

    def resume(self):
        self.calls.append(("resume",))


def test_protective_stop_decelerates_fails_the_motion_stops_the_program_and_unlocks_after_the_delay():
    stepped = stepped_ready(unlock_delay=1.0)
    runner = RecordingRunner()
    stepped.attach_program_runner(runner)
    stepped.set_program_state(True)
    bus = stepped.messages.subscribe()
    move = stepped.movej(np.array(HOME) + [2.0, 0, 0, 0, 0, 0])
    for _ in range(80):
        moving = stepped.step()
    stopped_at = time.monotonic()
    stepped.protective_stop("collision")
    assert move.done and move.error == "protective stop: collision"
    assert ("stop",) in runner.calls
    trace = [moving] + [stepped.step() for _ in range(40)]
    decelerations = [(a.actual_qd[0] - b.actual_qd[0]) / stepped.period for a, b in zip(trace, trace[1:])]
    assert max(decelerations) == pytest.approx(10.0, rel=0.01)  # a controlled stop, not a halt
    assert trace[1].actual_qd[0] > 0 and not np.any(trace[-1].actual_qd)
    state = trace[-1]
    assert (state.safety_mode, state.safety_status_bits & 0b100, state.runtime_state, state.protective_stopped) == (
        SafetyMode.PROTECTIVE_STOP, 0b100, RuntimeState.STOPPED, True)
    assert isinstance(bus.get(timeout=1), SafetyModeMessage)
    with pytest.raises(UnlockTooEarly, match="Cannot unlock protective stop until 5s"):
        stepped.unlock_protective_stop()
    time.sleep(max(0.0, stopped_at + 1.05 - time.monotonic()))
    stepped.unlock_protective_stop()
    assert stepped.state().safety_mode == SafetyMode.NORMAL


def test_emergency_stop_halts_at_once_and_needs_release_and_power_on(controller):
    controller.movej(np.array(HOME) + [2.0, 0, 0, 0, 0, 0])
    assert wait_for(lambda: controller.state().actual_qd[0] > 0.3)  # well under way
    controller.emergency_stop()
    first = controller.wait_cycle(controller.state().cycle, 1)
    second = controller.wait_cycle(first.cycle, 1)
    assert not np.any(second.actual_qd) and np.array_equal(first.actual_q, second.actual_q)
    assert (second.safety_mode, second.robot_mode, second.emergency_stopped) == (
        SafetyMode.ROBOT_EMERGENCY_STOP, RobotMode.POWER_OFF, True)
    assert second.safety_status_bits & (1 << 7)
    with pytest.raises(CommandRefused, match="emergency stop is active"):
        controller.power_on()
    controller.release_emergency_stop()
    assert controller.power_up().robot_mode == RobotMode.RUNNING


# ------------------------------------------------------------------------------------------ freedrive, I/O, program
def test_freedrive_lets_the_arm_be_moved_by_hand_and_blocks_motions(controller):
    with pytest.raises(CommandRefused, match="only in freedrive"):
        controller.move_joints_by_hand(HOME)
    controller.set_freedrive(True)
    pushed = np.array(HOME) + [0.1, 0.2, 0, 0, 0, 0.3]
    controller.move_joints_by_hand(pushed)
    state = controller.wait_cycle(controller.state().cycle, 1)
    assert state.actual_q.tolist() == pytest.approx(pushed.tolist()) and state.freedrive
    with pytest.raises(CommandRefused, match="freedrive"):
        controller.movej(HOME)
    controller.set_freedrive(False)
    assert controller.movej(HOME).wait(5)


def test_io_and_registers_appear_in_the_snapshot_read_only(controller):
    controller.io.set_standard_digital_out(3, True)
    controller.io.set_tool_digital_out(1, True)
    controller.io.set_int_register("input", 24, -7)
    controller.io.set_double_register("output", 0, 2.5)
    controller.io.set_bit_register_word("input", 32, 0b101)
    controller.io.set_standard_digital_in(2, True)
    controller.set_payload(1.5, [0, 0, 0.05])
    state = controller.wait_cycle(controller.state().cycle, 1)
    assert state.digital_output_bits == (1 << 3) | (1 << 17)
    assert state.digital_input_bits == 1 << 2
    assert (state.input_int_registers[24], state.output_double_registers[0]) == (-7, 2.5)
    assert state.input_bit_registers[32] and not state.input_bit_registers[33] and state.input_bit_registers[34]
    assert controller.io.bit_register_word("input", 32) == 0b101
    assert (state.payload, state.payload_cog.tolist()) == (1.5, [0, 0, 0.05])
    with pytest.raises(ValueError):
        state.actual_q[0] = 1.0
    with pytest.raises(ValueError, match="input integer register index must be an integer 0..47"):
        controller.io.set_int_register("input", 48, 1)


def test_program_state_hooks_drive_runtime_state_and_status_bits(controller):
    runner = RecordingRunner()
    controller.attach_program_runner(runner)
    controller.run_program("movej([0,0,0,0,0,0])", "test")
    controller.set_program_state(True)
    state = controller.wait_cycle(controller.state().cycle, 1)
    assert (state.runtime_state, state.robot_status_bits & 2) == (RuntimeState.PLAYING, 2)
    controller.pause_program()
    state = controller.wait_cycle(controller.state().cycle, 1)
    assert state.runtime_state == RuntimeState.PAUSED
    controller.resume_program()
    controller.stop_program()
    state = controller.wait_cycle(controller.state().cycle, 1)
    assert state.runtime_state == RuntimeState.STOPPED
    assert runner.calls == [("submit", "test"), ("pause",), ("resume",), ("stop",)]


def test_pause_halts_the_arm_on_its_path_and_resume_finishes_the_move(stepped):
    stepped.set_program_state(True)
    target = np.array(HOME) + [1.0, 0, 0, 0, 0, 0]
    move = stepped.movej(target)
    for _ in range(60):
        stepped.step()
    stepped.pause_program()
    trace = [stepped.step() for _ in range(100)]
    paused = trace[-1]
    assert not np.any(paused.actual_qd) and paused.speed_scaling == 0.0 and not move.done
    assert HOME[0] < paused.actual_q[0] < target[0]
    assert max(abs(b.actual_qd[0] - a.actual_qd[0]) for a, b in zip(trace, trace[1:])) < 0.05  # ramped, no jolt
    stepped.resume_program()
    run_and_trace(stepped, move)
    assert move.succeeded and stepped.state().actual_q.tolist() == pytest.approx(target.tolist(), abs=1e-12)
    assert stepped.state().speed_scaling == 1.0


def test_motion_wait_honours_timeout_and_cancel(controller):
    move = controller.movej(np.array(HOME) + [1.0, 0, 0, 0, 0, 0])
    assert move.wait(timeout=0.05) is False
    cancel = threading.Event()
    threading.Timer(0.05, cancel.set).start()
    assert move.wait(timeout=5, cancel=cancel) is False and not move.done
    assert move.wait(timeout=5) and move.succeeded


def test_joint_positions_history_gives_the_measured_joints_of_earlier_cycles(stepped):
    """URScript get_actual_joint_positions_history(steps) (ur_rtde's getActualJointPositionsHistory): the joints
    `steps` control cycles ago, read from the cycles the controller ran."""
    history = BUILTINS["get_actual_joint_positions_history"]
    script = types.SimpleNamespace(controller=stepped)  # what the built-in reads of its thread's context
    stepped.speedj([0.5, -0.2, 0.0, 0.0, 0.3, 0.0], 4.0)
    seen = [stepped.step().actual_q for _ in range(40)]
    for steps in (0, 1, 7, 39):
        assert history(script, steps) == list(seen[-1 - steps])
    for bad in (1.5, -1, JOINT_HISTORY_CYCLES):
        with pytest.raises(ScriptError, match="steps must be a whole number from 0"):
            history(script, bad)


def test_tcp_and_elbow_speeds_are_the_finite_difference_with_the_present_tcp():
    """speeds_between reuses the forward kinematics of the previous cycle's joints; after a TCP change it must use
    the new TCP for both ends, as a finite difference computed from scratch does."""
    arm = kinematics.ArmKinematics(robot_model("ur5e").dh, np.zeros(6))
    dt = 0.002
    previous_q, q = np.array([0.1, -1.2, 1.0, -0.5, 1.4, 0.3]), np.array([0.1002, -1.1995, 1.0004, -0.5, 1.4, 0.301])
    for tcp in (np.zeros(6), np.array([0.0, 0.05, 0.2, 0.0, 0.3, 0.0])):
        arm.poses_at(previous_q)  # the cycle before: its joints' kinematics (with the old TCP on the second pass)
        arm.tcp_offset = tcp
        arm.poses_at(q)
        twist, elbow = arm.speeds_between(previous_q, q, dt)
        new, old = (kinematics.tcp_matrix(arm.dh, joints, tcp) for joints in (q, previous_q))
        expected_twist = np.concatenate([(new[:3, 3] - old[:3, 3]) / dt,
                                         kinematics.matrix_to_rotation_vector(new[:3, :3] @ old[:3, :3].T) / dt])
        elbows = [kinematics.joint_frames(arm.dh, joints)[2][:3, 3] for joints in (q, previous_q)]
        assert twist == pytest.approx(expected_twist, abs=1e-9)
        assert elbow == pytest.approx((elbows[0] - elbows[1]) / dt, abs=1e-9)


def test_the_same_script_line_again_commits_nothing():
    """The main script thread reports its line each time it starts waiting (RTDE script_control_line); waiting again
    at the same line (a socket read in a loop) must not republish the snapshot, which marks the next cycle as
    changed and costs a full snapshot."""
    controller = Controller(model="ur5e")
    controller.set_script_control_line(12)
    published = controller.state()
    controller.set_script_control_line(12)
    assert controller.state() is published
    controller.set_script_control_line(13)
    assert controller.state().script_control_line == 13


def test_a_command_wakes_no_thread_waiting_for_a_cycle():
    """A command's commit publishes no new cycle: the threads waiting for one (streamers, script threads) must sleep
    on, not wake up only to find no new cycle (at the control rate each wake-up is a turn of the GIL)."""
    controller = Controller(model="ur5e")
    wake_ups = []
    condition = controller._board._changed
    original_wait = condition.wait
    condition.wait = lambda timeout=None: wake_ups.append(1) or original_wait(timeout)
    waiter = threading.Thread(target=controller.wait_cycle, args=(controller.state().cycle, 2.0))
    waiter.start()
    wait_for(lambda: wake_ups, timeout=2.0)
    for fraction in (0.5, 0.6, 0.7, 0.8, 0.9):
        controller.set_speed_slider(fraction)
        time.sleep(0.02)  # time for a woken waiter to wait again
    controller.step()
    waiter.join(timeout=2.0)
    assert len(wake_ups) == 1
