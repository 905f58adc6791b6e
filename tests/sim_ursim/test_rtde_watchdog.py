"""sim_ursim's RTDE input watchdogs (sim_ursim/rtde/watchdog.py) on a clock of the test's own: a period without
an input update fires the action, and a stall of the simulator itself (its checks far apart, the packages that came
in meanwhile not read yet) starts the period again instead of stopping a client that kept sending."""
from types import SimpleNamespace

from sim_ursim.rtde.watchdog import STALL, InputWatchdogs


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
