"""sim_ursim's RTDE input watchdogs (sim_ursim/rtde/watchdog.py) on a controller whose cycles the test computes and
a clock of the test's own: a period's worth of computed cycles due after the last input update fires the action,
however much or little of the host's time passed (a starved simulator computes no cycles and blames no client, and
the cycles it catches up on were due before the packages it reads late; a silent client is caught however far apart
the checks are), and input waiting unread in the client's socket holds the action back, instead of stopping a
client that kept sending."""
import socket
from types import SimpleNamespace

from sim_ursim.rtde.server import Session
from sim_ursim.rtde.watchdog import InputWatchdogs
from sim_ursim.tcp_server import Connection, TCPServer

REGISTER = "input_int_register_20"
STOP = [(REGISTER, "stop")]
PERIOD = 0.008   # 125 Hz: a 10 Hz watchdog lets 12 cycles (96 ms) pass without an update, not 13 (104 ms)


class Host:
    """The host's clock and a controller on it: `compute(n)` is n control cycles, each due one period after the
    last (on time, or late: caught up back to back), `wait(s)` lets the host's time pass."""

    def __init__(self):
        self.now = 0.0
        self.cycle_due = 0.0
        self.stopped = 0

    def state(self):
        return SimpleNamespace(program_paused=False)

    def compute(self, cycles=1):
        self.cycle_due += cycles * PERIOD
        self.now = max(self.now, self.cycle_due)

    def wait(self, seconds):
        self.now += seconds

    def stop_program(self):
        self.stopped += 1


def armed_watchdogs(frequency=10.0):
    """(InputWatchdogs with a 10 Hz stop watchdog on REGISTER armed now, its Host); no checker thread: the test calls
    check()."""
    host = Host()
    watchdogs = InputWatchdogs(host, clock=lambda: host.now)
    watchdogs._thread = SimpleNamespace(is_alive=lambda: True)
    watchdogs.arm(REGISTER, frequency, "stop", program_ended=lambda: False)
    return watchdogs, host


def test_a_period_of_computed_cycles_without_an_update_stops_the_program():
    watchdogs, host = armed_watchdogs()
    for _ in range(12):   # the client's package every cycle
        host.compute()
        watchdogs.note_update([REGISTER])
        assert watchdogs.check() == []
    for _ in range(12):   # 12 cycles without one: 96 ms
        host.compute()
        assert watchdogs.check() == []
    host.compute()   # the 13th: 104 ms
    assert watchdogs.check() == STOP and host.stopped == 1


def test_a_starved_simulator_blames_no_client_for_its_own_pause():
    watchdogs, host = armed_watchdogs()
    host.compute(5)   # due at 40 ms
    watchdogs.note_update([REGISTER])
    host.wait(0.302)   # the host ran nothing of the simulator for three periods
    assert watchdogs.check() == [] and host.stopped == 0
    watchdogs.note_update([REGISTER])   # the client's packages, read once the simulator runs again (342 ms)
    host.compute(37)   # the loop catches up on the cycles due meanwhile (up to 336 ms), back to back
    assert watchdogs.check() == [] and host.stopped == 0
    host.compute(13)   # the cycle that applies the package (344 ms), then 12 without one (440 ms)
    assert watchdogs.check() == []
    host.compute()
    assert watchdogs.check() == STOP


def test_a_silent_client_is_caught_however_far_apart_the_checks_are():
    """A heavily loaded host runs the checker 60 ms apart or worse: the silence is counted in computed cycles, so
    the program is stopped all the same."""
    watchdogs, host = armed_watchdogs()
    host.compute()
    watchdogs.note_update([REGISTER])
    fired = []
    for _ in range(3):   # 60 ms between checks (the host late: cycles caught up back to back)
        host.wait(0.06)
        host.compute(8)
        fired += watchdogs.check()
    assert fired == STOP and host.stopped == 1


def test_input_waiting_unread_holds_the_action_back_until_it_is_read():
    """Loaded test runs: the checker ran on time while the thread reading the heartbeat's client was held back;
    the client wrote every 10-20 ms, nothing was read for 101 ms, and a healthy motion was stopped."""
    watchdogs, host = armed_watchdogs()
    unread = {REGISTER: False}
    watchdogs.unread_input = unread.get
    host.compute()
    watchdogs.note_update([REGISTER])
    unread[REGISTER] = True   # the client's next packages are in the socket, not read yet
    for _ in range(60):   # the cycles go on all along
        host.compute()
        assert watchdogs.check() == []
    watchdogs.note_update([REGISTER])   # read at last
    unread[REGISTER] = False
    for _ in range(12):   # then nothing more comes: stopped a period's worth of cycles after the last package
        host.compute()
        assert watchdogs.check() == [] and host.stopped == 0
    host.compute()
    assert watchdogs.check() == STOP and host.stopped == 1


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


def test_the_reader_leaves_a_package_in_the_socket_until_it_has_handled_it():
    """Between the reader taking a package and noting it, a look at the socket still sees it: a check in that window
    would otherwise take a client that kept writing for a silent one."""
    server_side, client_side = socket.socketpair()
    with server_side, client_side:
        connection = Connection(server_side, ("127.0.0.1", 1), 0)
        session = Session(connection, 1, backlog_limit=1024)
        chunks = TCPServer(None, "127.0.0.1", 0).read_chunks(connection, keep_until_handled=True)
        client_side.sendall(b"\x00\x08U\x01\x00\x00\x00\x01")
        assert next(chunks) == b"\x00\x08U\x01\x00\x00\x00\x01"
        assert session.has_unread_input()   # being handled: still in the socket
        client_side.sendall(b"\x00\x08U\x01\x00\x00\x00\x02")
        assert next(chunks) == b"\x00\x08U\x01\x00\x00\x00\x02"   # the first was taken, and only it
        client_side.close()
        assert next(chunks, None) is None and not session.has_unread_input()
