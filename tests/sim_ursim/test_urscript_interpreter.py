"""URScript interpreter on the real controller model: semantics, built-ins, threads, motion, registers, errors."""
import math
import queue
import threading
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from polling import wait_for
from sim_ursim import kinematics
from sim_ursim.controller import Controller
from sim_ursim.messages import TextMessage
from sim_ursim.urscript.builtins import BUILTINS
from sim_ursim.urscript.interpreter import CompileError, Execution, compile_program
from sim_ursim.urscript.parser import parse

HOME = [0.0, -1.2, 1.0, -1.0, -1.5, 0.3]


def _powered_controller():
    c = Controller("ur3", initial_q=HOME, mode_delay=0.01)
    c.start()
    c.power_up()
    return c


@pytest.fixture
def controller():
    """A started UR3 controller, powered up with the brakes released: one per test, so the TCP, registers, outputs
    and arm position a test leaves behind never reach another."""
    c = _powered_controller()
    yield c
    c.shutdown()


@pytest.fixture(scope="module")
def arithmetic_controller():
    """A controller shared by the generated arithmetic examples only: they evaluate expressions and change nothing."""
    c = _powered_controller()
    yield c
    c.shutdown()


class Outcome:
    """What a finished run left behind: globals, the run-time error (or None), and the text messages."""

    def __init__(self, execution, error, texts):
        self.globals = execution.globals
        self.error = error
        self.texts = texts


def run(controller, source, timeout=20.0):
    """Compile and run `source` to the end on `controller` (in a helper thread, bounded by `timeout`)."""
    program = compile_program(parse(source), BUILTINS)
    execution = Execution(program, controller, BUILTINS)
    messages = controller.messages.subscribe()
    result = {}
    worker = threading.Thread(target=lambda: result.setdefault("error", execution.run()), daemon=True)
    worker.start()
    worker.join(timeout)
    if worker.is_alive():
        execution.cancel()
        worker.join(2.0)
        raise AssertionError(f"program did not finish within {timeout} s")
    controller.messages.unsubscribe(messages)
    texts = []
    while True:
        try:
            message = messages.get_nowait()
        except queue.Empty:
            break
        if isinstance(message, TextMessage):
            texts.append(message.text)
    return Outcome(execution, result["error"], texts)


def value_of(controller, expression):
    """The value URScript computes for `expression`."""
    outcome = run(controller, f"result = {expression}\n")
    assert outcome.error is None, outcome.error
    return outcome.globals["result"]


# ------------------------------------------------------------------------------------------ expressions & scopes


@pytest.mark.parametrize(
    "expression, expected",
    [
        ("1 + 2 * 3", 7),
        ("7 / 2", 3.5),
        ("7 % 3", 1),
        ("-2 - -3", 1),
        ("2 < 3 and not 3 < 2", True),
        ("True xor True", False),
        ("[1, 2] == [1, 2]", True),
        ('"ab" + "cd"', "abcd"),
        ("pow(2, 10)", 1024.0),
        ("floor(-1.5)", -2),
        ("norm([3, 4])", 5.0),
        ("length([1, 2, 3])", 3),
        ("r2d(d2r(90))", pytest.approx(90.0)),
        ("atan2(1, 1)", pytest.approx(math.pi / 4)),
        ("to_str(p[1, 2, 3, 0, 0, 0])", "p[1.0, 2.0, 3.0, 0.0, 0.0, 0.0]"),
        ("to_str([True, 2, 0.5])", "[True, 2, 0.5]"),
        ("integer_to_binary_list(5)[2]", True),
        ("binary_list_to_integer([True, False, True])", 5),
    ],
)
def test_expression_values(controller, expression, expected):
    assert value_of(controller, expression) == expected


def _expressions():
    """Random integer expressions over + - * with parentheses, as (URScript text, Python text)."""
    leaves = st.integers(min_value=-50, max_value=50).map(lambda n: (f"({n})", f"({n})"))

    def combine(children):
        return st.tuples(children, st.sampled_from(["+", "-", "*"]), children).map(
            lambda t: (f"{t[0][0]} {t[1]} {t[2][0]}", f"{t[0][1]} {t[1]} {t[2][1]}")
        )

    return st.recursive(leaves, combine, max_leaves=12)


@settings(max_examples=40, deadline=None)
@given(_expressions())
def test_arithmetic_agrees_with_python_precedence(arithmetic_controller, pair):
    urscript, python = pair
    assert value_of(arithmetic_controller, urscript) == eval(python)  # noqa: S307 - our own generated integer arithmetic


def test_functions_defaults_keywords_recursion_and_scopes(controller):
    source = """def prog():
  global total = 0
  def add(a, b=10):
    total = total + a + b
    local temporary = 1
    return a + b
  end
  def fact(n):
    if n <= 1:
      return 1
    end
    return n * fact(n - 1)
  end
  first = add(1)
  second = add(1, b=2)
  third = fact(5)
end
"""
    outcome = run(controller, source)
    assert outcome.error is None
    assert (outcome.globals["first"], outcome.globals["second"], outcome.globals["third"]) == (11, 3, 120)
    assert outcome.globals["total"] == 14
    assert "temporary" not in outcome.globals


def test_local_declaration_shadows_a_global(controller):
    source = "x = 1\ndef f():\n  local x = 5\n  x = x + 1\n  return x\nend\ny = f()\n"
    outcome = run(controller, source)
    assert (outcome.globals["x"], outcome.globals["y"]) == (1, 6)


def test_while_break_continue_and_elif(controller):
    source = """i = 0
evens = 0
while True:
  i = i + 1
  if i > 10:
    break
  elif i % 2 == 1:
    continue
  else:
    evens = evens + 1
  end
end
"""
    assert run(controller, source).globals["evens"] == 5


def test_lists_and_poses_are_values(controller):
    source = "a = [1, 2, 3]\nb = a\nb[0] = 9\nq = p[0, 0, 0, 0, 0, 0]\nq[2] = 0.5\nm = [[1, 2], [3, 4]]\nm[1][0] = 7\n"
    g = run(controller, source).globals
    assert g["a"] == [1, 2, 3] and g["b"] == [9, 2, 3]
    assert g["q"] == [0, 0, 0.5, 0, 0, 0] and g["m"] == [[1, 2], [7, 4]]


def test_matrix_elements(controller):
    g = run(controller, "m = [[1, 2], [3, 4]]\nm[0, 1] = 9\nx = m[1, 0]\n").globals
    assert g["m"] == [[1, 9], [3, 4]] and g["x"] == 3


def test_halt_ends_the_program(controller):
    outcome = run(controller, 'textmsg("before")\nhalt\ntextmsg("after")\n')
    assert outcome.error is None and outcome.texts == ["before"]


def test_textmsg_concatenates_its_two_arguments(controller):
    assert run(controller, 'textmsg("value: ", 1.5)\n').texts == ["value: 1.5"]


# ------------------------------------------------------------------------------------------ errors


@pytest.mark.parametrize(
    "source, line, column, text",
    [
        ('txtmsg("x")\n', 1, 1, "compile_error_name_not_found:txtmsg:"),
        ("def prog():\n  x = 1\n  y = undefined_name + 1\nend\n", 3, 7, "compile_error_name_not_found:undefined_name:"),
        ("h = run nothread()\n", 1, 5, "compile_error_name_not_found:nothread:"),
    ],
)
def test_compile_errors_name_line_and_column(source, line, column, text):
    with pytest.raises(CompileError) as caught:
        compile_program(parse(source), BUILTINS)
    assert (caught.value.line, caught.value.column, caught.value.text) == (line, column, text)


@pytest.mark.parametrize(
    "source, line, column, fragment",
    [
        ("x = 1\ny = x / 0\n", 2, 5, "division by zero"),
        ("a = [1, 2]\nb = a[2]\n", 2, 5, "index out of range"),
        ('x = 1 + "a"\n', 1, 5, "type mismatch"),
        ("a = [1]\na[0.5] = 2\n", 2, 3, "index must be an integer"),
        ("def f(a):\n  return a\nend\nf(1, 2)\n", 4, 1, "takes 1 arguments"),
        ("movej([0, 0, 0])\n", 1, 1, "q must be a list of 6 numbers"),
    ],
)
def test_runtime_errors_stop_the_program_with_position(controller, source, line, column, fragment):
    outcome = run(controller, source + 'textmsg("not reached")\n')
    assert outcome.error is not None
    assert (outcome.error.line, outcome.error.column) == (line, column)
    assert fragment in outcome.error.text
    assert "not reached" not in outcome.texts


# ------------------------------------------------------------------------------------------ threads


def test_thread_run_join_and_shared_globals(controller):
    source = """def prog():
  global count = 0
  thread counter():
    while count < 5:
      count = count + 1
      sync()
    end
  end
  handle = run counter()
  join handle
  textmsg("joined at ", count)
end
"""
    outcome = run(controller, source)
    assert outcome.error is None and outcome.texts == ["joined at 5"]


def test_kill_stops_a_thread(controller):
    source = """def prog():
  global ticks = 0
  thread ticker():
    while True:
      ticks = ticks + 1
      sync()
    end
  end
  handle = run ticker()
  sleep(0.1)
  kill handle
  frozen = ticks
  sleep(0.1)
  textmsg(ticks - frozen)
end
"""
    outcome = run(controller, source)
    assert outcome.error is None and outcome.texts == ["0"]


def test_killing_a_moving_thread_aborts_its_move(controller):
    source = """def prog():
  thread mover():
    movej([1.5, -1.2, 1.0, -1.0, -1.5, 0.3], a=1.0, v=0.5)
  end
  handle = run mover()
  sleep(0.3)
  kill handle
  while not is_steady():
    sync()
  end
  rest = get_actual_joint_positions()
end
"""
    outcome = run(controller, source)
    assert outcome.error is None
    assert outcome.globals["rest"][0] < 1.0, "the killed thread's move went on to its target"
    run(controller, f"movej({HOME}, a=4.0, v=3.0)\n")


def test_critical_section_is_not_interleaved(controller):
    """Another thread cannot run between enter_critical and exit_critical, even over many statements."""
    source = """def prog():
  global shared = 0
  global seen_odd = False
  thread observer():
    while True:
      if shared % 2 == 1:
        seen_odd = True
      end
      sync()
    end
  end
  handle = run observer()
  i = 0
  while i < 30:
    enter_critical
    shared = shared + 1
    j = 0
    while j < 300:
      j = j + 1
    end
    shared = shared + 1
    exit_critical
    i = i + 1
    sync()
  end
  kill handle
end
"""
    outcome = run(controller, source)
    assert outcome.error is None and outcome.globals["seen_odd"] is False


def test_a_busy_loop_is_suspended_until_the_next_frame_when_its_slice_is_used_up(controller):
    from sim_ursim.urscript.script_thread import MIN_STATEMENTS_PER_FRAME, STATEMENTS_PER_SECOND

    # Two statements per iteration: the loop test and the assignment (counting only the assignment gave 5-6 frames).
    # Every used-up slice waits for a newer cycle than the one it saw, so the bound holds however loaded the box is.
    iterations = 1000
    source = f"i = 0\nwhile i < {iterations}:\n  i = i + 1\nend\n"
    parse(source)  # the parser is built before the clock starts
    first_cycle = controller.state().cycle
    outcome = run(controller, source)
    frames = controller.state().cycle - first_cycle
    assert outcome.error is None and outcome.globals["i"] == iterations
    per_frame = max(MIN_STATEMENTS_PER_FRAME, int(STATEMENTS_PER_SECOND * controller.period))
    assert frames >= 2 * iterations // per_frame - 1


def test_runtime_error_in_a_thread_stops_the_program(controller):
    source = """def prog():
  thread broken():
    x = [1][3]
  end
  run broken()
  sleep(5)
  textmsg("not reached")
end
"""
    started = time.monotonic()
    outcome = run(controller, source)
    assert outcome.error is not None and "index out of range" in outcome.error.text
    assert outcome.error.line == 3 and time.monotonic() - started < 3


# ------------------------------------------------------------------------------------------ motion


def test_movej_completes_at_the_target(controller):
    target = [0.3, -1.0, 0.8, -1.2, -1.5, 0.0]
    outcome = run(controller, f"movej({target}, a=3.0, v=2.0)\nq = get_actual_joint_positions()\n")
    assert outcome.error is None
    np.testing.assert_allclose(outcome.globals["q"], target, atol=1e-9)
    np.testing.assert_allclose(controller.state().actual_q, target, atol=1e-9)


def test_movel_reaches_the_pose(controller):
    source = """start = get_actual_tcp_pose()
goal = pose_trans(start, p[0.0, 0.0, 0.05, 0, 0, 0])
movel(goal, a=1.0, v=0.2)
reached = get_actual_tcp_pose()
distance = pose_dist(reached, goal)
"""
    outcome = run(controller, source)
    assert outcome.error is None
    assert outcome.globals["distance"] < 1e-9


def test_movej_to_a_pose_uses_inverse_kinematics(controller):
    source = """q0 = get_actual_joint_positions()
goal = get_forward_kin([0.1, -1.1, 0.9, -1.2, -1.5, 0.2])
movej(goal, a=3.0, v=2.0)
error = pose_dist(get_actual_tcp_pose(), goal)
"""
    outcome = run(controller, source)
    assert outcome.error is None and outcome.globals["error"] < 1e-9


def test_blended_sequence_ends_on_the_last_target_without_stopping_between(controller):
    waypoints = [[0.2, -1.2, 1.0, -1.0, -1.5, 0.3], [0.4, -1.1, 0.9, -1.0, -1.5, 0.3],
                 [0.6, -1.2, 1.0, -1.0, -1.5, 0.3]]
    source = "\n".join(
        [f"movej({waypoints[0]}, a=4.0, v=2.0, r=0.02)", f"movej({waypoints[1]}, a=4.0, v=2.0, r=0.02)",
         f"movej({waypoints[2]}, a=4.0, v=2.0, r=0)"]) + "\n"
    run(controller, "movej([0.0, -1.2, 1.0, -1.0, -1.5, 0.3], a=4.0, v=2.0)\n")
    speeds = []
    sampling = threading.Event()

    def sample():
        while not sampling.is_set():
            speeds.append(float(np.max(np.abs(controller.state().actual_qd))))
            time.sleep(controller.period)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    outcome = run(controller, source)
    sampling.set()
    sampler.join()
    assert outcome.error is None
    np.testing.assert_allclose(controller.state().actual_q, waypoints[2], atol=1e-9)
    fast = [i for i, s in enumerate(speeds) if s > 0.05]
    between_first_and_last_fast_sample = speeds[fast[0]:fast[-1] + 1]
    assert min(between_first_and_last_fast_sample) > 1e-3, "the arm came to rest between blended moves"


def test_speedj_without_time_returns_once_the_speed_is_reached_and_stopj_brings_rest(controller):
    source = """speedj([0.2, 0, 0, 0, 0, 0], 2.0)
reached = get_actual_joint_speeds()
stopj(4.0)
after_stop = get_actual_joint_speeds()
"""
    outcome = run(controller, source)
    assert outcome.error is None
    assert outcome.globals["reached"][0] == pytest.approx(0.2, abs=2.0 * 2 * controller.period)
    assert max(abs(v) for v in outcome.globals["after_stop"]) < 1e-9
    run(controller, f"movej({HOME}, a=4.0, v=3.0)\n")


def test_servoj_stream_is_followed(controller):
    source = """q = get_actual_joint_positions()
start = q[5]
i = 0
while i < 50:
  q[5] = q[5] + 0.002
  servoj(q, t=0.008, lookahead_time=0.1, gain=300)
  i = i + 1
end
stopj(10)
final = get_actual_joint_positions()
"""
    outcome = run(controller, source)
    assert outcome.error is None
    assert outcome.globals["final"][5] - outcome.globals["start"] == pytest.approx(0.1, abs=0.01)
    run(controller, f"movej({HOME}, a=4.0, v=3.0)\n")


def test_stop_interrupts_a_blocking_move_within_two_cycles(controller):
    program = compile_program(parse("movej([1.5, -1.2, 1.0, -1.0, -1.5, 0.3], a=0.5, v=0.2)\n"), BUILTINS)
    execution = Execution(program, controller, BUILTINS)
    worker = threading.Thread(target=execution.run, daemon=True)
    worker.start()
    assert wait_for(lambda: controller.state().actual_q[0] > HOME[0] + 0.005)  # the move is under way
    assert worker.is_alive()
    cancelled_at = time.monotonic()
    execution.cancel()
    worker.join(2.0)
    elapsed = time.monotonic() - cancelled_at
    controller.stopj(10.0).wait(5.0)
    assert not worker.is_alive()
    # Within two control cycles (measured: ≤ 1 cycle), plus 50 ms for a busy 2-core CI machine.
    assert elapsed < 2 * controller.period + 0.05
    run(controller, f"movej({HOME}, a=4.0, v=3.0)\n")


# ------------------------------------------------------------------------------------------ registers and I/O


def test_register_handshake_through_controller_registers(controller):
    """The program waits for input int register 5, doubles input float register 5 and answers on outputs."""
    source = """def handshake():
  write_output_integer_register(5, 1)
  while read_input_integer_register(5) == 0:
    sync()
  end
  write_output_float_register(5, 2 * read_input_float_register(5))
  write_output_integer_register(5, 2)
end
"""
    controller.io.set_int_register("input", 5, 0)
    program = compile_program(parse(source), BUILTINS)
    execution = Execution(program, controller, BUILTINS)
    worker = threading.Thread(target=execution.run, daemon=True)
    worker.start()
    deadline = time.monotonic() + 2.0
    while controller.io.output_int_registers[5] != 1 and time.monotonic() < deadline:
        time.sleep(0.005)
    assert controller.io.output_int_registers[5] == 1
    assert worker.is_alive()
    controller.io.set_double_register("input", 5, 1.25)
    controller.io.set_int_register("input", 5, 7)
    worker.join(2.0)
    assert not worker.is_alive() and execution.error is None
    assert controller.io.output_int_registers[5] == 2
    assert controller.io.output_double_registers[5] == 2.5
    controller.io.set_int_register("input", 5, 0)


def test_digital_outputs(controller):
    source = """set_standard_digital_out(3, True)
set_digital_out(9, True)
set_tool_digital_out(1, True)
a = get_standard_digital_out(3)
b = get_configurable_digital_out(1)
c = get_digital_out(17)
set_standard_digital_out(3, False)
d = get_digital_out(3)
"""
    g = run(controller, source).globals
    assert (g["a"], g["b"], g["c"], g["d"]) == (True, True, True, False)
    assert controller.io.configurable_digital_outputs & 0b10


def test_legacy_digital_out_variable_sets_the_output_unless_the_program_has_its_own(controller):
    """`digital_out[n]=b` (urx's set_digital_out) sets output n; a program's own `digital_out` list stays a list."""
    outcome = run(controller, "digital_out[4]=True\na = get_digital_out(4)\n")
    assert outcome.error is None and outcome.globals["a"] is True
    outcome = run(controller, "digital_out = [0, 0]\ndigital_out[1] = 7\nb = get_digital_out(1)\n")
    assert outcome.error is None and outcome.globals["digital_out"] == [0, 7] and outcome.globals["b"] is False


def test_set_tcp_changes_forward_kinematics(controller):
    source = """flange = get_forward_kin()
set_tcp(p[0, 0, 0.1, 0, 0, 0])
tool = get_forward_kin()
offset = pose_trans(pose_inv(flange), tool)
set_tcp(p[0, 0, 0, 0, 0, 0])
"""
    g = run(controller, source).globals
    np.testing.assert_allclose(g["offset"], [0, 0, 0.1, 0, 0, 0], atol=1e-9)


def test_jacobian_matches_finite_differences_of_forward_kinematics(controller):
    q = np.array([0.3, -1.1, 0.9, -1.2, -1.4, 0.2])
    g = run(controller, f"J = get_jacobian({q.tolist()})\nset_tcp(p[0, 0, 0, 0, 0, 0])\n").globals
    step = 1e-7
    for joint in range(6):
        moved = q.copy()
        moved[joint] += step
        velocity = (controller.fk(moved)[:3] - controller.fk(q)[:3]) / step
        np.testing.assert_allclose([row[joint] for row in g["J"][:3]], velocity, atol=1e-5)


def test_set_tcp_is_seen_by_the_next_statement(controller):
    """get_tcp_offset and get_jacobian right after set_tcp use the new TCP, every time (it lagged a cycle before)."""
    q = [0.3, -1.1, 0.9, -1.2, -1.4, 0.2]
    lines = []
    for n in range(60):
        z = 0.05 + 0.01 * (n % 5)
        lines.append(f"set_tcp(p[0, 0, {z}, 0, 0, 0])\noffsets[{n}] = get_tcp_offset()\nJ{n} = get_jacobian({q})\n")
    source = "offsets = [" + ", ".join(["p[0, 0, 0, 0, 0, 0]"] * 60) + "]\n" + "".join(lines)
    g = run(controller, source + "set_tcp(p[0, 0, 0, 0, 0, 0])\n").globals
    for n in range(60):
        z = 0.05 + 0.01 * (n % 5)
        assert list(g["offsets"][n]) == pytest.approx([0, 0, z, 0, 0, 0])
        expected = kinematics.geometric_jacobian(controller.model.dh, np.array(q), np.array([0, 0, z, 0, 0, 0]))
        np.testing.assert_allclose(g[f"J{n}"], expected, atol=1e-12)


def test_unsupported_builtin_compiles_but_fails_when_called(controller):
    call = "servoc(p[0.3, 0, 0.3, 0, 3.14, 0])"
    outcome = run(controller, f"if False:\n  {call}\nend\n")
    assert outcome.error is None
    outcome = run(controller, call + "\n")
    assert "servoc is not supported" in outcome.error.text


# ------------------------------------------------------------------------------------------ pose maths (pure)

finite = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False)
rotation = st.floats(min_value=-2.0, max_value=2.0, allow_nan=False)
poses = st.tuples(finite, finite, finite, rotation, rotation, rotation).map(list)


@settings(max_examples=50, deadline=None)
@given(poses, poses)
def test_pose_sub_undoes_pose_add(first, second):
    from sim_ursim.urscript.builtins.poses import pose_add, pose_sub

    back = pose_sub(None, pose_add(None, first, second), first)
    np.testing.assert_allclose(kinematics.pose_to_matrix(back), kinematics.pose_to_matrix(second), atol=1e-9)


def test_pose_add_composes_rotations_first_then_second():
    from sim_ursim.urscript.builtins.poses import pose_add

    quarter_x, quarter_z = [0, 0, 0, math.pi / 2, 0, 0], [0, 0, 0, 0, 0, math.pi / 2]
    expected = kinematics.rotation_vector_to_matrix(quarter_x[3:]) @ kinematics.rotation_vector_to_matrix(quarter_z[3:])
    np.testing.assert_allclose(kinematics.pose_to_matrix(pose_add(None, quarter_x, quarter_z))[:3, :3], expected,
                               atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(poses)
def test_pose_trans_with_pose_inv_is_identity(pose):
    from sim_ursim.urscript.builtins.poses import pose_inv, pose_trans

    np.testing.assert_allclose(pose_trans(None, pose, pose_inv(None, pose)), np.zeros(6), atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(st.tuples(st.floats(-3.0, 3.0), st.floats(-1.5, 1.5), st.floats(-3.0, 3.0)).map(list))
def test_rpy_round_trip(rpy):
    from sim_ursim.urscript.builtins.poses import rotvec2rpy, rpy2rotvec

    np.testing.assert_allclose(rotvec2rpy(None, rpy2rotvec(None, rpy)), rpy, atol=1e-9)


def test_rpy_convention_is_z_y_x():
    from sim_ursim.urscript.builtins.poses import rpy2rotvec

    np.testing.assert_allclose(rpy2rotvec(None, [0, 0, math.pi / 2]), [0, 0, math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(rpy2rotvec(None, [math.pi / 2, 0, 0]), [math.pi / 2, 0, 0], atol=1e-12)


def test_interpolate_pose_end_points_and_middle():
    from sim_ursim.urscript.builtins.poses import interpolate_pose

    start, end = [0, 0, 0, 0, 0, 0], [0.2, 0, 0, 0, 0, 1.0]
    np.testing.assert_allclose(interpolate_pose(None, start, end, 0.0), start, atol=1e-12)
    np.testing.assert_allclose(interpolate_pose(None, start, end, 1.0), end, atol=1e-12)
    np.testing.assert_allclose(interpolate_pose(None, start, end, 0.5), [0.1, 0, 0, 0, 0, 0.5], atol=1e-12)
