"""sim_ursim's RTDE input watchdogs (sim_ursim/rtde/watchdog.py) on a clock of the test's own: a period without
an input update fires the action; a stall of the simulator itself (its checks far apart, the packages that came
in meanwhile not read yet) starts the period again, and input waiting unread in the client's socket holds the
action back, instead of stopping a client that kept sending."""
import socket
from types import SimpleNamespace

from sim_ursim.rtde.server import Session
from sim_ursim.rtde.watchdog import STALL, InputWatchdogs
from sim_ursim.tcp_server import Connection


class FakeController:
    """What the watchdogs use of a controller: whether the program is paused, and stopping it."""

    def __init__(self):
        self.stopped = 0

    def state(self):
        return SimpleNamespace(program_paused=False)

    def stop_program(self):
        self.stopped += 1


def watchdogs_at(times):
    """(InputWatchdogs whose clock reads `times[0]`, the list to set the time through, its controller)."""
    controller = FakeController()
    watchdogs = InputWatchdogs(controller, clock=lambda: times[0])
    watchdogs._thread = SimpleNamespace(is_alive=lambda: True)   # no checker thread: the test calls check()
    return watchdogs, controller


def arm(watchdogs, frequency=10.0):
    watchdogs.arm("input_int_register_20", frequency, "stop", program_ended=lambda: False)


def test_a_period_without_an_update_stops_the_program():
    times = [0.0]
    watchdogs, controller = watchdogs_at(times)
    arm(watchdogs)
    for t in (0.01, 0.02, 0.05, 0.09):
        times[0] = t
        watchdogs.note_update(["input_int_register_20"])
        assert watchdogs.check() == []
    for t in (0.1, 0.15, 0.185):   # checked in time, no update since 0.09
        times[0] = t
        assert watchdogs.check() == []
    times[0] = 0.195
    assert watchdogs.check() == [("input_int_register_20", "stop")] and controller.stopped == 1


def test_a_stall_of_the_simulator_starts_the_period_again():
    times = [0.0]
    watchdogs, controller = watchdogs_at(times)
    arm(watchdogs)
    times[0] = 0.01
    watchdogs.note_update(["input_int_register_20"])
    assert watchdogs.check() == []
    times[0] = 0.01 + STALL + 0.25   # the simulator was starved: the client's packages wait in the socket
    assert watchdogs.check() == [] and controller.stopped == 0
    times[0] += 0.005
    watchdogs.note_update(["input_int_register_20"])   # read now
    assert watchdogs.check() == []
    last = times[0]
    for step in range(1, 20):   # then the client really stops: checked in time, one period after its last update
        times[0] = last + 0.005 * step
        assert watchdogs.check() == []
    times[0] = last + 0.105
    assert watchdogs.check() == [("input_int_register_20", "stop")] and controller.stopped == 1


def test_input_waiting_unread_holds_the_action_back_until_it_is_read():
    """Loaded test runs: the checker ran on time while the thread reading the heartbeat's client was held back;
    the client wrote every 10-20 ms, nothing was read for 101 ms, and a healthy motion was stopped."""
    times = [0.0]
    watchdogs, controller = watchdogs_at(times)
    unread = {"input_int_register_20": False}
    watchdogs.unread_input = unread.get
    arm(watchdogs)
    times[0] = 0.01
    watchdogs.note_update(["input_int_register_20"])
    unread["input_int_register_20"] = True   # the client's next packages are in the socket, not read yet
    for step in range(1, 60):   # checked on time all along: no stall of the checker
        times[0] = 0.01 + 0.005 * step
        assert watchdogs.check() == []
    watchdogs.note_update(["input_int_register_20"])   # read at last
    unread["input_int_register_20"] = False
    last = times[0]
    for step in range(1, 20):   # then nothing more comes: stopped one period after the last package
        times[0] = last + 0.005 * step
        assert watchdogs.check() == [] and controller.stopped == 0
    times[0] = last + 0.105
    assert watchdogs.check() == [("input_int_register_20", "stop")] and controller.stopped == 1


def test_a_session_tells_whether_its_client_sent_what_is_not_read_yet():
    server_side, client_side = socket.socketpair()
    with server_side, client_side:
        session = Session(Connection(server_side, ("127.0.0.1", 1), 0), 1, backlog_limit=1024)
        assert not session.has_unread_input()
        client_side.sendall(b"\x00\x08U\x01\x00\x00\x00\x01")
        assert session.has_unread_input() and session.has_unread_input()   # looking does not take it
        assert len(server_side.recv(64)) == 8
        assert not session.has_unread_input()
        client_side.close()   # a client gone leaves nothing to wait for
        assert not session.has_unread_input()
