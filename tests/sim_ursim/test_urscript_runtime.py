"""ProgramRunner on the controller: program state, key/exception messages, replacement, stop, pause, sec programs;
and the next goal: ur_rtde's RTDEControlInterface uploading its control script to a simulator."""
import queue
import socket
import threading
import time

import numpy as np
import pytest

from controller_time import wait_cycles
from polling import wait_for
from powered_simulator import powered_simulator
from sim_ursim.controller import Controller
from sim_ursim.messages import KeyMessage, RuntimeExceptionMessage, TextMessage
from sim_ursim.urscript.builtins import BUILTINS
from sim_ursim.urscript.runtime import ProgramRunner
from sim_ursim.vocabulary import RuntimeState

HOME = [0.0, -1.2, 1.0, -1.0, -1.5, 0.3]
LONG_MOVE = "movej([1.5, -1.2, 1.0, -1.0, -1.5, 0.3], a=0.5, v=0.2)\n"


@pytest.fixture
def controller():
    """A started, powered-up UR3 controller with a ProgramRunner attached."""
    c = Controller("ur3", initial_q=HOME, mode_delay=0.01)
    c.attach_program_runner(ProgramRunner(c))
    c.start()
    c.power_up()
    yield c
    c.shutdown()


def receiver_reaches(read, expected, atol):
    """True once `read()` (an RTDEReceiveInterface getter) is within atol of `expected`, False after 2 s.

    The control interface learns that a move ended through its own RTDE connection; the receive interface's
    connection may still be a few packages behind on a loaded machine, so its view is given time to catch up.
    """
    return wait_for(lambda: np.allclose(read(), expected, rtol=0, atol=atol), timeout=2.0)


def drain(messages):
    """Every message waiting in a subscription queue."""
    result = []
    while True:
        try:
            result.append(messages.get_nowait())
        except queue.Empty:
            return result


def runtime_state(controller):
    """runtime_state of the next published cycle (set_program_state takes effect at the next snapshot)."""
    return controller.wait_cycle(controller.state().cycle, timeout=1.0).runtime_state


def test_program_state_and_key_messages_follow_a_program(controller):
    runner = controller.program_runner
    messages = controller.messages.subscribe()
    assert runner.submit('def greet():\n  textmsg("hello")\n  sleep(0.2)\nend\n', "test")
    assert runner.is_running and runner.program_name == "greet"
    assert runtime_state(controller) == RuntimeState.PLAYING
    assert controller.state().robot_status_bits & 0b10
    assert runner.wait_until_stopped(3.0)
    assert runtime_state(controller) == RuntimeState.STOPPED
    assert not runner.is_running
    kinds = [(type(m).__name__, getattr(m, "title", None), m.text) for m in drain(messages)]
    assert kinds == [("KeyMessage", "PROGRAM_XXX_STARTED", "greet"), ("TextMessage", None, "hello"),
                     ("KeyMessage", "PROGRAM_XXX_STOPPED", "greet")]


def test_statement_lines_run_as_one_program(controller):
    runner = controller.program_runner
    messages = controller.messages.subscribe()
    runner.submit('set_standard_digital_out(0, True)\nset_standard_digital_out(1, True)\ntextmsg("both")\n')
    assert runner.wait_until_stopped(3.0)
    assert controller.io.standard_digital_outputs & 0b11 == 0b11
    assert [m.text for m in drain(messages) if isinstance(m, TextMessage)] == ["both"]


def test_runtime_error_is_published_and_the_program_stops(controller):
    runner = controller.program_runner
    messages = controller.messages.subscribe()
    runner.submit("def broken():\n  x = [1, 2]\n  y = x[2]\n  textmsg(\"not reached\")\nend\n")
    assert runner.wait_until_stopped(3.0)
    assert runtime_state(controller) == RuntimeState.STOPPED
    received = drain(messages)
    (error,) = [m for m in received if isinstance(m, RuntimeExceptionMessage)]
    assert (error.line, error.column) == (3, 7) and "index out of range" in error.text
    assert not any(isinstance(m, TextMessage) for m in received)
    assert isinstance(received[-1], KeyMessage) and received[-1].title == "PROGRAM_XXX_STOPPED"


RECURSIVE = "def runaway():\n  def deeper(n):\n    return deeper(n + 1)\n  end\n  deeper(0)\nend\n"


@pytest.mark.parametrize("in_thread", [False, True])
def test_runaway_recursion_is_a_stack_overflow_that_ends_the_program(controller, in_thread):
    """A recursive program does not crash the interpreter: a controller reports a runtime error (stack overflow)
    at the recursive call and stops the program, so a client waiting for its end sees it end."""
    runner = controller.program_runner
    messages = controller.messages.subscribe()
    source = RECURSIVE if not in_thread else RECURSIVE.replace(
        "  deeper(0)\n", "  thread worker():\n    deeper(0)\n  end\n  handle = run worker()\n  join handle\n")
    assert runner.submit(source, "test")
    assert runner.wait_until_stopped(10.0)
    assert runtime_state(controller) == RuntimeState.STOPPED
    received = drain(messages)
    (error,) = [m for m in received if isinstance(m, RuntimeExceptionMessage)]
    assert error.line == 3 and error.text == "runtime_error:stack overflow:"
    assert isinstance(received[-1], KeyMessage) and received[-1].title == "PROGRAM_XXX_STOPPED"


def test_any_exception_in_a_program_thread_ends_the_program_as_a_runtime_error_with_its_line():
    """Whatever fails inside the interpreter (here a built-in with a bug) ends the program as a runtime error at
    the failing line: nothing is left PLAYING."""
    def broken_builtin(ctx):
        raise KeyError("a bug in the simulator")

    c = Controller("ur3", initial_q=HOME, mode_delay=0.01)
    c.attach_program_runner(ProgramRunner(c, builtins={**BUILTINS, "broken_builtin": broken_builtin}))
    c.start()
    try:
        messages = c.messages.subscribe()
        assert c.program_runner.submit("def buggy():\n  sleep(0.01)\n  broken_builtin()\nend\n", "test")
        assert c.program_runner.wait_until_stopped(5.0)
        assert runtime_state(c) == RuntimeState.STOPPED and not c.state().program_running
        (error,) = [m for m in drain(messages) if isinstance(m, RuntimeExceptionMessage)]
        assert error.line == 3 and "simulator internal error (KeyError" in error.text
    finally:
        c.shutdown()


def test_compile_error_is_published_and_leaves_the_running_program_alone(controller):
    runner = controller.program_runner
    messages = controller.messages.subscribe()
    runner.submit("def waiting():\n  sleep(1.0)\nend\n")
    assert not runner.submit('txtmsg("typo")\n')
    assert runner.is_running and runner.program_name == "waiting"
    errors = [m for m in drain(messages) if isinstance(m, RuntimeExceptionMessage)]
    assert [(e.line, e.column, e.text) for e in errors] == [(1, 1, "compile_error_name_not_found:txtmsg:")]
    runner.stop()


def test_a_new_program_replaces_the_running_one(controller):
    runner = controller.program_runner
    messages = controller.messages.subscribe()
    runner.submit("def first():\n  while True:\n    sync()\n  end\nend\n")
    assert wait_for(lambda: runner.is_running)
    runner.submit('def second():\n  textmsg("second ran")\nend\n')
    assert runner.wait_until_stopped(3.0)
    keys = [(m.title, m.text) for m in drain(messages) if isinstance(m, KeyMessage)]
    assert keys == [("PROGRAM_XXX_STARTED", "first"), ("PROGRAM_XXX_STOPPED", "first"),
                    ("PROGRAM_XXX_STARTED", "second"), ("PROGRAM_XXX_STOPPED", "second")]


def test_stop_interrupts_a_move_and_the_arm_comes_to_rest(controller):
    runner = controller.program_runner
    runner.submit(LONG_MOVE)
    assert wait_for(lambda: controller.state().actual_q[0] > HOME[0] + 0.005)  # the arm is moving
    started = time.monotonic()
    controller.stop_program()
    stopped_after = time.monotonic() - started
    assert not runner.is_running
    # Within two control cycles (measured: ≤ 1 cycle), plus 50 ms for a busy 2-core CI machine.
    assert stopped_after < 2 * controller.period + 0.05
    assert runtime_state(controller) == RuntimeState.STOPPED
    assert wait_for(lambda: not controller.state().motion_active, timeout=2.0)
    assert controller.state().actual_q[0] < 1.0


def _thread_runs(native_id):
    """Times the kernel has put a thread of this process on a CPU so far (/proc's schedstat)."""
    with open(f"/proc/self/task/{native_id}/schedstat", encoding="ascii") as stats:
        return int(stats.read().split()[2])


def test_a_thread_waiting_for_its_move_sleeps_until_the_move_ends_or_it_is_stopped():
    """A script thread waiting for a move is woken by the move's end or by a stop, not every control cycle (at
    500 Hz that was 500 wake-ups a second, each needing the GIL); a stop still ends the wait at once."""
    c = Controller("ur3e", initial_q=HOME, mode_delay=0.01)
    c.attach_program_runner(ProgramRunner(c))
    c.start()
    try:
        c.power_up()
        assert c.run_program(f"def long_move():\n  {LONG_MOVE}end\n")
        wait_for(lambda: c.state().motion_active, timeout=2.0)
        script_thread = next(t for t in threading.enumerate() if t.name == "urscript-long_move")
        runs_before = _thread_runs(script_thread.native_id)
        time.sleep(0.5)  # 250 control cycles of the move
        runs = _thread_runs(script_thread.native_id) - runs_before
        stopped = time.monotonic()
        c.stop_program()
        script_thread.join(timeout=2.0)
        assert not script_thread.is_alive() and time.monotonic() - stopped < 0.5
    finally:
        c.shutdown()
    assert runs <= 40


def test_replacing_a_moving_program_stops_its_move(controller):
    runner = controller.program_runner
    runner.submit(LONG_MOVE)
    assert wait_for(lambda: controller.state().motion_active)
    runner.submit("def idle():\n  sleep(0.5)\nend\n")
    assert wait_for(lambda: not controller.state().motion_active, timeout=2.0)
    runner.stop()


def test_pause_holds_the_program_and_resume_continues_it(controller):
    runner = controller.program_runner
    runner.submit("def counting():\n  n = 0\n  while True:\n    n = n + 1\n    write_output_integer_register(3, n)\n"
                  "    sync()\n  end\nend\n")
    assert wait_for(lambda: controller.io.output_int_registers[3] > 2)
    controller.pause_program()
    assert runtime_state(controller) == RuntimeState.PAUSED
    held = controller.io.output_int_registers[3]
    wait_cycles(controller, 12)  # 0.1 s of controller time
    assert controller.io.output_int_registers[3] - held <= 1  # at most the statement already under way
    controller.resume_program()
    assert runtime_state(controller) == RuntimeState.PLAYING
    assert wait_for(lambda: controller.io.output_int_registers[3] > held + 3)
    controller.stop_program()
    assert not runner.is_running


def test_pause_brings_a_moving_arm_to_rest_and_resume_finishes_the_move(controller):
    runner = controller.program_runner
    target = [0.8, -1.2, 1.0, -1.0, -1.5, 0.3]
    runner.submit(f"def move():\n  movej({target}, a=2.0, v=0.8)\n  textmsg(\"arrived\")\nend\n")
    assert wait_for(lambda: controller.state().actual_q[0] > 0.1)
    controller.pause_program()
    assert wait_for(lambda: not controller.state().motion_active, timeout=2.0)
    held = controller.state().actual_q[0]
    assert held < target[0] - 0.05
    wait_cycles(controller, 25)  # 0.2 s of controller time
    assert controller.state().actual_q[0] == held and runner.is_running
    controller.resume_program()
    assert runner.wait_until_stopped(5.0)
    np.testing.assert_allclose(controller.state().actual_q, target, atol=1e-9)


@pytest.mark.parametrize("end", ["stop", "replace", "finish"])
def test_freedrive_a_program_switched_on_ends_with_the_program(controller, end):
    """As on a controller: freedrive_mode() lasts while its program runs (a stopped, replaced or finished program
    leaves no freedrive behind); the teach button's freedrive is the operator's and stays."""
    runner = controller.program_runner
    seconds = 0.1 if end == "finish" else 60
    assert runner.submit(f"def teach():\n  freedrive_mode()\n  sleep({seconds})\nend\n", "test")
    assert wait_for(lambda: controller.state().freedrive, timeout=2)
    if end == "stop":
        runner.stop()
    elif end == "replace":
        assert runner.submit('def other():\n  textmsg("next")\n  sleep(5)\nend\n', "test")
    assert wait_for(lambda: not controller.state().freedrive, timeout=2)
    runner.stop()
    controller.set_freedrive(True)   # the teach button
    assert runner.submit('def short():\n  textmsg("hi")\nend\n', "test")
    assert runner.wait_until_stopped(2)
    assert controller.state().freedrive


def test_secondary_program_runs_alongside_and_leaves_program_state_alone(controller):
    runner = controller.program_runner
    runner.submit("def main_program():\n  sleep(0.5)\nend\n")
    assert runner.submit("sec set_output():\n  set_standard_digital_out(5, True)\nend\n")
    assert wait_for(lambda: controller.io.standard_digital_outputs & (1 << 5))
    assert runner.is_running and runner.program_name == "main_program"
    runner.stop()


def test_protective_stop_ends_the_program(controller):
    runner = controller.program_runner
    runner.submit(LONG_MOVE)
    assert wait_for(lambda: controller.state().motion_active)
    controller.protective_stop("test")
    assert wait_for(lambda: not runner.is_running, timeout=2.0)
    assert runtime_state(controller) == RuntimeState.STOPPED


@pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning")  # inside urx 0.11
def test_program_state_agrees_on_rtde_dashboard_and_primary_views():
    """A program sent on 30002: runtime_state / robot_status_bits (RTDE fields), dashboard `running` and
    `programState` (ur_rtde DashboardClient) and primary isProgramRunning (urx's parser) agree at every stage."""
    dashboard_client = pytest.importorskip("dashboard_client")
    ursecmon = pytest.importorskip("urx.ursecmon")
    from sim_ursim.launch import running_simulator

    with running_simulator(model="ur3") as sim:
        sim.controller.power_up()
        secondary = ursecmon.SecondaryMonitor(sim.host)
        secondary._s_secondary.settimeout(5.0)  # urx's 0.5 s read timeout kills its reader on a loaded box
        dashboard = dashboard_client.DashboardClient(sim.host)
        dashboard.connect()

        def views():
            state = sim.controller.wait_cycle(sim.controller.state().cycle, timeout=1.0)
            secondary.wait()  # a fresh primary state packet
            return (state.runtime_state, dashboard.running(), dashboard.programState().split()[0],
                    secondary.is_program_running())

        try:
            assert wait_for(lambda: views() == (RuntimeState.STOPPED, False, "STOPPED", False))
            with socket.create_connection((sim.host, 30002), timeout=2.0) as client:
                client.sendall(b"def agree():\n  sleep(1.5)\nend\n")
                assert wait_for(lambda: views() == (RuntimeState.PLAYING, True, "PLAYING", True))
                assert sim.controller.state().robot_status_bits & 0b10
                dashboard.pause()
                assert wait_for(lambda: views() == (RuntimeState.PAUSED, True, "PAUSED", True))
                dashboard.play()
                assert wait_for(lambda: views() == (RuntimeState.PLAYING, True, "PLAYING", True))
                assert wait_for(lambda: views() == (RuntimeState.STOPPED, False, "STOPPED", False), timeout=4.0)
        finally:
            secondary.close()
            dashboard.disconnect()


# ------------------------------------------------------------------------------------------------ the next goal


@pytest.fixture
def ur_rtde_modules():
    """ur_rtde's Python modules (the tests below need the real client)."""
    return (pytest.importorskip("dashboard_client"), pytest.importorskip("rtde_control"),
            pytest.importorskip("rtde_receive"))


def test_ur_rtde_control_interface_runs_its_uploaded_script_on_the_simulator(ur_rtde_modules):
    """The real ur_rtde 1.6.5 uploads its 38 kB rtde_control script (CB3 3.15) on 30003; our interpreter runs it
    unmodified and executes moveJ / moveL / FK / isSteady / stopScript through the RTDE register handshake."""
    dashboard_client, rtde_control, rtde_receive = ur_rtde_modules
    with powered_simulator(model="ur3") as sim:
        control = rtde_control.RTDEControlInterface(sim.host)  # raises unless runtime_state reaches PLAYING
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            assert receive.getRuntimeState() == RuntimeState.PLAYING
            target = [0.2, -1.0, 0.8, -1.0, -1.5, 0.3]
            assert control.moveJ(target, 1.05, 1.4)
            assert receiver_reaches(receive.getActualQ, target, atol=1e-6)
            pose = control.getForwardKinematics()
            np.testing.assert_allclose(pose, receive.getActualTCPPose(), atol=1e-6)
            raised = list(pose)
            raised[2] += 0.05
            assert control.moveL(raised, 0.25, 1.2)
            assert receiver_reaches(receive.getActualTCPPose, raised, atol=1e-5)
            assert control.isSteady()
            control.stopScript()
            assert wait_for(lambda: receive.getRuntimeState() == RuntimeState.STOPPED, timeout=3.0)
        finally:
            control.disconnect()
            receive.disconnect()


def test_ur_rtde_control_script_of_an_e_series_5_24_runs(ur_rtde_modules):
    """The 5.24 variant of the script (50 kB: matrices, dynamics functions) compiles and serves moveJ."""
    dashboard_client, rtde_control, rtde_receive = ur_rtde_modules
    with powered_simulator(model="ur3e", version="5.24.0") as sim:
        control = rtde_control.RTDEControlInterface(sim.host)
        receive = rtde_receive.RTDEReceiveInterface(sim.host)
        try:
            target = [0.1, -1.1, 0.9, -1.0, -1.5, 0.3]
            assert control.moveJ(target, 3.0, 4.0)
            assert receiver_reaches(receive.getActualQ, target, atol=1e-6)
            control.stopScript()
        finally:
            control.disconnect()
            receive.disconnect()
