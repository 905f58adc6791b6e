"""Built-ins that client scripts reach (sim_ursim.urscript.builtins.clients, list arithmetic, aliases), run through
the real interpreter on a real controller; expected values computed independently here (numpy, UR's manual)."""
import threading

import numpy as np
import pytest

from sim_ursim import kinematics
from sim_ursim.controller import Controller
from sim_ursim.urscript.builtins import BUILTINS
from sim_ursim.urscript.interpreter import Execution, compile_program
from sim_ursim.urscript.parser import parse

HOME = [0.0, -1.2, 1.0, -1.0, -1.5, 0.3]


@pytest.fixture(scope="module")
def controller():
    c = Controller("ur5e", initial_q=HOME, mode_delay=0.01)
    c.start()
    c.power_up()
    yield c
    c.shutdown()


def run(controller, source, timeout=30.0):
    """(globals, error) after running `source` to its end."""
    execution = Execution(compile_program(parse(source), BUILTINS), controller, BUILTINS)
    result = {}
    worker = threading.Thread(target=lambda: result.setdefault("error", execution.run()), daemon=True)
    worker.start()
    worker.join(timeout)
    assert not worker.is_alive(), "program did not finish"
    return execution.globals, result["error"]


def value_of(controller, expression):
    values, error = run(controller, f"result = {expression}\n")
    assert error is None, error
    return values["result"]


@pytest.mark.parametrize("expression, expected", [
    ('str_len("hello")', 5),
    ('str_empty("")', True),
    ('str_at("hello", 1)', "e"),
    ('str_find("hello world", "o", 5)', 7),
    ('str_find("hello", "z")', -1),
    ('str_sub("hello world", 6)', "world"),
    ('str_sub("hello world", 0, 5)', "hello"),
    ("get_list_length([1, 2, 3])", 3),
    ("get_list_length(p[0, 0, 0, 0, 0, 0])", 6),
    ("[1, 2, 3] + [10, 20, 30]", [11, 22, 33]),
    ("[1.0, 2.0] * 0.5", [0.5, 1.0]),
    ("[4.0, 8.0] / 4", [1.0, 2.0]),
    ("transpose([[1, 2, 3], [4, 5, 6]])", [[1.0, 4.0], [2.0, 5.0], [3.0, 6.0]]),
    ("inv([[2, 0], [0, 4]])", [[0.5, 0.0], [0.0, 0.25]]),
])
def test_values(controller, expression, expected):
    assert value_of(controller, expression) == expected


def test_random_is_in_unit_interval_and_varies(controller):
    values = [value_of(controller, "random()") for _ in range(5)]
    assert all(0.0 <= v < 1.0 for v in values) and len(set(values)) > 1


def test_wrench_trans_matches_the_rigid_body_transform(controller):
    pose = [0.1, -0.2, 0.3, 0.2, -0.4, 1.1]
    wrench = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]
    got = np.array(value_of(controller, f"wrench_trans(p{pose}, {wrench})"))
    rotation = kinematics.rotation_vector_to_matrix(pose[3:])
    origin = np.array(pose[:3])
    force = rotation.T @ np.array(wrench[:3])
    moment = rotation.T @ (np.array(wrench[3:]) - np.cross(origin, wrench[:3]))
    assert np.allclose(got, np.concatenate([force, moment]))


def test_errors_name_the_problem(controller):
    for source, fragment in [('x = str_at("ab", 5)\n', "str_at"), ("x = inv([[1, 2], [2, 4]])\n", "singular"),
                             ("set_tool_voltage(5)\n", "set_tool_voltage"),
                             ("x = [1, 2] + [1, 2, 3]\n", "equal length")]:
        _, error = run(controller, source)
        assert error is not None and fragment in error.text


def test_analog_inputs_and_tool_voltage(controller):
    values, error = run(controller, "a = get_standard_analog_in(0)\nb = get_analog_in(2)\nset_tool_voltage(24)\n")
    state = controller.state()
    assert error is None
    assert values["a"] == state.standard_analog_input0 and values["b"] == state.tool_analog_input0


def test_optimove_and_freedrive_keyword_form(controller):
    target = [0.1, -1.2, 1.0, -1.0, -1.5, 0.3]
    _, error = run(controller, f"optimovej({target}, a=0.3, v=0.3)\n"
                               "freedrive_mode(freeAxes=[1, 1, 1, 0, 0, 0], feature=p[0, 0, 0, 0, 0, 0])\n"
                               "end_freedrive_mode()\n")
    assert error is None
    assert np.allclose(controller.state().actual_q, target, atol=1e-4)


def test_movec_passes_the_via_point_and_ends_at_the_target(controller):
    run(controller, f"movej({HOME})\n")
    start = np.array(controller.state().actual_tcp_pose)
    via = start + np.array([0.03, 0.03, 0.0, 0, 0, 0])
    end = start + np.array([0.06, 0.0, 0.0, 0, 0, 0])
    passed = []
    stop = threading.Event()

    def watch():
        while not stop.is_set():
            state = controller.wait_cycle(controller.state().cycle, timeout=0.1)
            passed.append(np.linalg.norm(np.array(state.actual_tcp_pose[:3]) - via[:3]))

    watcher = threading.Thread(target=watch)
    watcher.start()
    _, error = run(controller, f"movec(p{via.tolist()}, p{end.tolist()}, a=0.5, v=0.1)\n")
    stop.set()
    watcher.join()
    assert error is None
    assert min(passed) < 2e-3  # through the via point (within the blend of the arc's pieces)
    assert np.allclose(controller.state().actual_tcp_pose[:3], end[:3], atol=1e-4)


def test_movec_takes_joint_positions_through_forward_kinematics(controller):
    """UR's script manual: pose_via and pose_to may be joint positions (URCL's MOVEC_JOINT points send them)."""
    run(controller, f"movej({HOME})\n")
    q_via = np.array(HOME) + np.array([0.05, 0.0, 0.0, 0.0, 0.0, 0.0])
    q_to = np.array(HOME) + np.array([0.10, 0.0, 0.0, 0.0, 0.0, 0.0])
    _, error = run(controller, f"movec({q_via.tolist()}, {q_to.tolist()}, a=0.5, v=0.1)\n")
    assert error is None
    expected = kinematics.tcp_pose(controller.model.dh, q_to, controller.state().tcp_offset)
    assert np.allclose(controller.state().actual_tcp_pose[:3], expected[:3], atol=1e-4)


def test_joint_torques_are_the_external_load_through_the_jacobian(controller):
    assert value_of(controller, "get_joint_torques()") == [0.0] * 6  # free arm: nothing beyond its own dynamics
    wrench = np.array([5.0, -3.0, 10.0, 0.2, 0.1, -0.3])
    controller.set_external_force_torque(wrench)
    try:
        assert wait_for_force(controller, wrench)
        got = np.array(value_of(controller, "get_joint_torques()"))
        state = controller.state()
        jacobian = kinematics.geometric_jacobian(controller.model.dh, state.actual_q, state.tcp_offset)
        assert np.allclose(got, jacobian.T @ np.array(state.actual_tcp_force)) and np.linalg.norm(got) > 1.0
    finally:
        controller.set_external_force_torque(np.zeros(6))
        wait_for_force(controller, np.zeros(6))


def wait_for_force(controller, wrench):
    for _ in range(100):
        state = controller.wait_cycle(controller.state().cycle, timeout=0.1)
        if np.allclose(state.actual_tcp_force, wrench):
            return True
    return False


def test_ft_rtde_input_enable_and_set_target_payload_with_transition_time(controller):
    values, error = run(controller, "ft_rtde_input_enable(True, 0.5, [0, 0, 0.01], [0, 0, 0.02])\n"
                                    "enable_external_ft_sensor(False)\n"
                                    "set_target_payload(1.5, [0, 0, 0.05], [0, 0, 0, 0, 0, 0], 0.5)\n"
                                    "m = get_target_payload()\n")
    assert error is None and values["m"] == 1.5
    _, error = run(controller, "ft_rtde_input_enable(1)\n")
    assert error is not None and "ft_rtde_input_enable" in error.text


def test_speedj_with_zero_acceleration_keeps_the_current_speeds(controller):
    _, error = run(controller, "speedj([0, 0, 0, 0, 0, 0.1], 0.5, 0.4)\nspeedj([0, 0, 0, 0, 0, 0.1], 0.0, 0.2)\n"
                               "stopj(2.0)\n")
    assert error is None
    _, error = run(controller, "speedj([0, 0, 0, 0, 0, 0.2], 0.0, 0.1)\n")  # a change with a = 0: no change
    assert error is None and abs(controller.state().target_qd[5]) < 1e-9


def test_an_over_fast_speedj_saturates_at_the_joint_speed_limit_keeping_its_direction(controller):
    limit = float(controller.model.max_joint_speed[0])
    values, error = run(controller, f"speedj([{2 * limit}, {limit}, 0, 0, 0, 0], 20.0, 0.5)\n"
                                    "qd = get_target_joint_speeds()\nstopj(20.0)\n")
    assert error is None  # URCL's spline asks a few ppm over the limit; a controller saturates, not fails
    assert values["qd"][:2] == pytest.approx([limit, limit / 2], rel=1e-6)


def test_force_mode_in_free_space_drifts_along_the_compliant_axis_until_ended(controller):
    run(controller, f"movej({HOME})\n")
    start = np.array(controller.state().actual_tcp_pose)
    values, error = run(controller, "force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, 10, 0, 0, 0], 2, "
                                    "[0.1, 0.1, 0.05, 0.3, 0.3, 0.3])\n"
                                    "sleep(0.5)\n"
                                    "v = get_actual_tcp_speed()\n"
                                    "end_force_mode()\n"
                                    "sleep(0.3)\n")
    assert error is None
    assert abs(values["v"][2] - 0.05) < 1e-3 and max(abs(values["v"][0]), abs(values["v"][1])) < 1e-3
    moved = np.array(controller.state().actual_tcp_pose) - start
    assert moved[2] > 0.01 and np.linalg.norm(controller.state().actual_tcp_speed) < 1e-6
    _, error = run(controller, "force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0], [0, 0, 1, 0, 0, 0], 2, "
                               "[0.1, 0.1, 0.1, 0.3, 0.3, 0.3])\n")
    assert error is not None and "selection_vector" in error.text
    run(controller, f"movej({HOME})\n")
