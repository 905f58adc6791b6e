"""The fast clock (`--clock fast`, a test pipeline's option): while a program runs or the arm moves, the control
loop computes its cycles back to back, one period of simulated time each, in order; RTDE streams every one of them;
script threads run in every frame; at rest the simulator keeps real time; the RTDE input watchdog judges a client's
silence on the host's clock; a client that cannot keep up is dropped, the others are served. Real time stays the
default."""
import contextlib
import socket
import threading
import time

import numpy as np
import pytest
from click.testing import CliRunner

from rtde_recorder import RTDERecorder
from sim_ursim.__main__ import main
from sim_ursim.control_channel import send_request
from sim_ursim.controller import Controller
from sim_ursim.launch import running_simulator, simulator_process
from sim_ursim.rtde import protocol
from sim_ursim.vocabulary import RuntimeState

HOME = [0.3, -1.3, 1.4, -1.7, -1.57, 0.4]
PERIOD = 0.002   # e-series


def play(controller, body):
    """Run `def p(): body end` on the controller; returns once it has stopped (AssertionError after 30 s)."""
    assert controller.run_program("def p():\n" + "".join(f"  {line}\n" for line in body) + "end\n")
    deadline = time.monotonic() + 30
    while controller.state().program_running:
        assert time.monotonic() < deadline, "the program did not end within 30 s"
        time.sleep(0.005)


def rows_of(recorder, since, field_count=1):
    """The recorded rows from `since` to the first with runtime_state STOPPED after one PLAYING, as an array."""
    start = recorder.wait_for(lambda row: row[0] == RuntimeState.PLAYING, since=since)
    end = recorder.wait_for(lambda row: row[0] == RuntimeState.STOPPED, since=start)
    return np.array([row[1:1 + field_count] for row in recorder.rows[start:end + 1]])


def test_real_time_is_the_default_and_an_unknown_clock_is_refused():
    assert Controller("ur5e").clock == "real-time"
    with pytest.raises(ValueError, match="clock must be one of real-time, fast"):
        Controller("ur5e", clock="warp")
    result = CliRunner().invoke(main, ["--clock", "warp"])
    assert result.exit_code == 2 and "'warp' is not one of 'real-time', 'fast'" in result.output


def test_a_fast_clock_plays_simulated_seconds_in_less_wall_time_and_streams_every_cycle():
    """20 s of sleep() are 10,000 cycles, ten times the record kept for streams: every one reaches RTDE in order,
    one period apart, far sooner than 20 s."""
    with running_simulator("ur5e", initial_q=HOME, clock="fast") as simulator, \
            RTDERecorder(simulator.host, ["runtime_state", "timestamp"]) as recorder:
        controller = simulator.controller
        controller.power_up()
        began, first = time.monotonic(), len(recorder.rows)
        play(controller, ["sleep(20.0)"])
        wall = time.monotonic() - began
        timestamps = rows_of(recorder, first)[:, 0]
    assert wall < 10.0, f"20 s of simulated time took {wall:.1f} s"
    assert timestamps[-1] - timestamps[0] >= 20.0 - 1e-6
    assert np.allclose(np.diff(timestamps), PERIOD, rtol=0, atol=1e-9), "a cycle is missing or out of order"


def test_script_threads_take_their_turn_in_every_frame():
    """A thread that writes a register and syncs writes once in every cycle, and a move follows the one before in
    the next cycle: the loop waits for the script threads, as a controller runs them inside the frame."""
    with running_simulator("ur5e", initial_q=HOME, clock="fast") as simulator, \
            RTDERecorder(simulator.host, ["runtime_state", "output_int_register_0", "actual_qd"]) as recorder:
        controller = simulator.controller
        controller.power_up()
        first = len(recorder.rows)
        play(controller, ["i = 0", "while i < 1500:", "  i = i + 1", "  write_output_integer_register(0, i)",
                          "  sync()", "end", "movej([0.5, -1.3, 1.4, -1.7, -1.57, 0.4], a=3, v=2)",
                          "movej([0.3, -1.3, 1.4, -1.7, -1.57, 0.4], a=3, v=2)"])
        rows = rows_of(recorder, first, field_count=7)
    counts = rows[:, 0]
    writing = counts[(counts > 0) & (counts < 1500)]
    assert np.array_equal(np.diff(writing), np.ones(writing.size - 1)), "a frame without the thread's write"
    moving = np.flatnonzero(np.any(np.abs(rows[:, 1:]) > 1e-12, axis=1))
    assert moving.size and np.all(np.diff(moving) <= 2), "the arm rested between two moves"


def test_at_rest_a_fast_clock_keeps_real_time():
    """With no program and no motion nothing needs hurrying: the cycles keep pace with the wall clock."""
    with running_simulator("ur5e", initial_q=HOME, clock="fast") as simulator:
        controller = simulator.controller
        controller.power_up()
        time.sleep(0.1)
        cycle, began = controller.state().cycle, time.monotonic()
        time.sleep(0.5)
        cycles, wall = controller.state().cycle - cycle, time.monotonic() - began
    assert cycles <= wall / PERIOD * 1.2 + 10, f"{cycles} cycles in {wall:.2f} s at rest"


def test_the_input_watchdog_of_a_fast_clock_judges_a_clients_silence_on_the_wall_clock():
    """A client writing its register every 10 ms of wall time is alive however many cycles pass in between; once it
    stops, the program stops within about the watchdog's period."""
    import rtde_io

    with simulator_process(model="ur5e", clock="fast") as simulator:
        io = rtde_io.RTDEIOInterface(simulator.host)
        writing = threading.Event()
        writing.set()

        def write():
            count = 0
            while writing.is_set():
                count += 1
                io.setInputIntRegister(20, count)
                time.sleep(0.01)

        writer = threading.Thread(target=write, daemon=True)
        writer.start()
        try:
            script = 'def watched():\n  rtde_set_watchdog("input_int_register_20", 10, "stop")\n  sleep(3600)\nend\n'
            with socket.create_connection((simulator.host, 30002), timeout=5) as connection:
                connection.sendall(script.encode())
            wait_for_status(simulator.host, lambda state: state["program_running"])
            with RTDERecorder(simulator.host, ["timestamp"], frequency=10.0) as recorder:
                recorder.wait_for(lambda row: True)
                time.sleep(1.0)
                assert send_request(simulator.host, "status")["state"]["program_running"], simulator.output()[-2000:]
                simulated = recorder.rows[-1][0] - recorder.rows[0][0]
            assert simulated > 5.0, f"the fast clock did not hurry: {simulated:.2f} s in 1 s"
            writing.clear()
            writer.join(2)
            stopped_at = time.monotonic()
            wait_for_status(simulator.host, lambda state: not state["program_running"], timeout=3)
            assert time.monotonic() - stopped_at < 2.0
        finally:
            writing.clear()
            with contextlib.suppress(Exception):
                io.disconnect()


def wait_for_status(host, condition, timeout=5.0):
    """The control channel's status once `condition(state)` holds; AssertionError after `timeout` s."""
    deadline = time.monotonic() + timeout
    while not condition(state := send_request(host, "status")["state"]):
        assert time.monotonic() < deadline, "the simulator's state never became as expected"
        time.sleep(0.01)
    return state


def test_a_client_that_cannot_keep_up_is_dropped_and_the_others_get_every_cycle():
    """A client that reads nothing while a fast program streams 60 s of cycles is closed when its backlog
    overflows, as a controller closes a client that stops reading; the simulator and the other client go on."""
    with running_simulator("ur5e", initial_q=HOME, clock="fast") as simulator:
        controller = simulator.controller
        controller.power_up()
        stalled = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled.connect((simulator.host, 30004))
        names = ["timestamp", "actual_q", "actual_qd", "target_q", "actual_TCP_pose", "actual_current"]
        stalled.sendall(protocol.pack_protocol_version_request(2) +
                        protocol.pack_setup_outputs_request(names, 500.0, 2) + protocol.pack_start_request())
        with RTDERecorder(simulator.host, ["runtime_state", "timestamp"]) as recorder:
            first = len(recorder.rows)
            play(controller, ["sleep(60.0)"])
            timestamps = rows_of(recorder, first)[:, 0]
        assert closed_by_the_server(stalled), "the client that read nothing was not dropped"
    assert np.allclose(np.diff(timestamps), PERIOD, rtol=0, atol=1e-9)


def closed_by_the_server(connection):
    """True once `connection` has read what the server sent before it closed it (False: still open after 5 s)."""
    connection.settimeout(5)
    try:
        while connection.recv(1 << 16):
            pass
    except ConnectionResetError:
        pass
    except TimeoutError:
        return False
    finally:
        connection.close()
    return True
