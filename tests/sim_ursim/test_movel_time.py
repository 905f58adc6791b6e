"""movel with a time t: kept when the joints can follow, slowed (as speed scaling slows a controller) when t is
unfeasibly short — URCL's InstructionExecutorTest.unfeasible_times_succeeds."""
import numpy as np
import pytest

from test_controller import moving_interval, run_and_trace, stepped_ready

START = [-1.57, -1.6, 1.6, -0.7, 0.7, 0.2]
URCL_TARGET = [-0.203, 0.263, 0.559, 0.68, -1.083, -2.076]  # URCL's moveL target from START


def test_an_unfeasibly_short_movel_time_slows_the_motion_instead_of_stopping_the_arm():
    controller = stepped_ready("ur5", initial_q=START)
    motion = controller.movel(URCL_TARGET, a=1.4, v=1.04, t=0.1)
    trace = run_and_trace(controller, motion)
    assert motion.error is None and not trace[-1].protective_stopped
    assert trace[-1].actual_tcp_pose.tolist() == pytest.approx(URCL_TARGET, abs=1e-9)
    assert moving_interval(trace) > 0.1
    assert max(float(np.max(np.abs(s.actual_qd) / controller.model.max_joint_speed)) for s in trace) <= 1.0


def test_a_feasible_movel_time_is_kept():
    controller = stepped_ready("ur5", initial_q=START)
    goal = controller.state().actual_tcp_pose + [0.02, 0.0, -0.01, 0.0, 0.0, 0.0]
    trace = run_and_trace(controller, controller.movel(goal, a=1.2, v=0.25, t=1.5))
    assert moving_interval(trace) == pytest.approx(1.5, abs=2 * controller.period)
