"""Faults during motion, injected into sim_ursim: each gives its own exception, in bounded time, and the arm stops."""
import signal
import threading
import time

import numpy as np
import pytest

import ur3dq.robot
from polling import wait_for
from robot_target import needs_simulator
from robot_test_support import HOME, inject, ready, set_speed_slider, simulator_state, simulator_with
from ur3dq.errors import (
    ConnectionLostError,
    EmergencyStopError,
    MotionTimeoutError,
    ProgramError,
    ProtectiveStopError,
    RobotError,
)
from ur3dq.robot import interrupts, motion

pytestmark = needs_simulator

LONG_MOVE = np.array([3.0, 0, 0, 0, 0, 0])
  # about 3.6 s at the URScript defaults: room for a late fault detection


class WhenMoving(threading.Thread):
    """`with WhenMoving(host, start, action) as watch:` runs `action` once the simulator at `host` reports a
    running program and the base joint `lead` rad from `start`: the fault lands in the middle of this motion. A
    fixed delay from the movej call does not: on a loaded machine the program may not have started yet, and a
    dashboard `stop` before the start stops nothing. `running_at` / `fired_at`: monotonic times the program was
    first seen running and the action ran. Leaving the block cancels a watch that has not fired (so it never
    fires into the next test) and, when the block raised nothing, asserts that it fired."""

    def __init__(self, host, start, action, lead=0.05, timeout=10.0):
        super().__init__(daemon=True)
        self.host, self.start_q, self.action, self.lead, self.timeout = host, start, action, lead, timeout
        self.running_at = self.fired_at = None
        self.last_state, self.furthest = None, 0.0   # what the watch saw (said when it never fired)
        self._cancelled = threading.Event()

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, exc_type, *_):
        self._cancelled.set()
        self.join(5.0)
        if exc_type is None:
            assert self.fired_at is not None, (f"the motion was never seen running (furthest from the start: "
                                               f"{self.furthest:.3f} rad; last state: {self.last_state}; the "
                                               f"motion's own error: {_last_failure.get('error')!r})")

    def run(self):
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline and not self._cancelled.is_set():
            state = simulator_state(self.host)
            self.last_state, self.furthest = state, max(self.furthest, abs(state["q"][0] - self.start_q[0]))
            if state["program_running"] and self.running_at is None:
                self.running_at = time.monotonic()
            if state["program_running"] and abs(state["q"][0] - self.start_q[0]) >= self.lead:
                self.fired_at = time.monotonic()
                self.action()
                return
            self._cancelled.wait(0.01)


#: The error of the last timed_failure, for WhenMoving to name when its watch never fired (the motion failed
#: before the fault was injected, and the assertions after the block would not run).
_last_failure = {}


def timed_failure(robot, target, **kwargs):
    """(exception, seconds until it reached us) of a movej expected to fail."""
    started = time.monotonic()
    _last_failure.clear()
    with pytest.raises(RobotError) as caught:
        robot.movej(target, **kwargs)
    _last_failure["error"] = caught.value
    return caught.value, time.monotonic() - started


def assert_at_rest_short_of(robot, target, settle=1.0):
    """The arm comes to rest (within `settle` s) away from `target`: it was stopped, not left running."""
    deadline = time.monotonic() + settle
    while np.max(np.abs(robot.state().joint_speeds)) > 5e-3:
        assert time.monotonic() < deadline, "the arm kept moving"
        time.sleep(0.02)
    assert np.max(np.abs(robot.joints() - target)) > 0.2


def test_protective_stop_during_motion(own_sim_robot, home):
    host, robot = own_sim_robot
    stopped = {}

    def protective_stop():
        stopped["at"] = time.monotonic()
        inject(host, "protective-stop", reason="test")

    with WhenMoving(host, home, protective_stop):
        error, _ = timed_failure(robot, home + LONG_MOVE)
        caught = time.monotonic()
    assert isinstance(error, ProtectiveStopError) and "unlock_protective_stop" in str(error)
    assert caught - stopped["at"] < 0.5
    with pytest.raises(ProtectiveStopError):  # no motion while stopped
        robot.movej(home)
    with pytest.raises(ProtectiveStopError, match="refused.*5"):  # the controller refuses an early unlock
        robot.unlock_protective_stop()
    assert robot.state().protective_stopped  # never unlocked by the driver itself
    time.sleep(max(0.0, stopped["at"] + 5.2 - time.monotonic()))
    robot.unlock_protective_stop()
    assert not robot.state().protective_stopped
    robot.movej(home)


def test_a_protective_stop_is_left_to_the_controller(own_sim_robot, home):
    """The controller stops the arm itself: the driver sends no stopj of its own, which (gentler) would replace the
    controller's stop and lengthen the arm's way to rest."""
    from ur3dq.robot.primary import KeyMessage
    from ur3dq.robot.primary_client import PrimaryClient

    host, robot = own_sim_robot
    primary = PrimaryClient(host)
    messages = primary.watch()
    try:
        with WhenMoving(host, home, lambda: inject(host, "protective-stop", reason="test")) as watch:
            error, _ = timed_failure(robot, home + LONG_MOVE)
        assert isinstance(error, ProtectiveStopError)
        assert wait_for(lambda: np.max(np.abs(robot.state().joint_speeds)) < 1e-6, timeout=2)
        rest_after = time.monotonic() - watch.fired_at
        time.sleep(0.3)
    finally:
        primary.unwatch(messages)
        primary.close()
    started = []
    while not messages.empty():
        message = messages.get_nowait()
        if isinstance(message, KeyMessage) and message.title.endswith("_STARTED"):
            started.append(message.text)
    assert not [name for name in started if name.startswith("ur3dq_stop")], started
    assert rest_after < 0.5, f"the arm came to rest {rest_after:.2f} s after the protective stop"


def test_a_motion_sent_into_a_new_protective_stop_is_refused_and_named(own_sim_robot, home, monkeypatch):
    """A protective stop latched after the driver's last look at the state and before its program arrives: the
    controller does not run the program, and the driver names the stop and its fix at once (no stopj after it)."""
    host, robot = own_sim_robot
    backend, send = robot._backend, robot._backend.send_program

    def send_into_a_protective_stop(program):
        inject(host, "protective-stop", reason="test")
        send(program)

    monkeypatch.setattr(backend, "send_program", send_into_a_protective_stop)
    error, elapsed = timed_failure(robot, home + LONG_MOVE)
    assert isinstance(error, ProtectiveStopError) and "unlock" in str(error) and elapsed < 1.5
    time.sleep(0.2)
    assert not simulator_state(host)["program_running"]
    assert np.max(np.abs(np.array(simulator_state(host)["q"]) - home)) < 1e-9   # it never moved


def test_emergency_stop_during_motion(own_sim_robot, home):
    host, robot = own_sim_robot
    with WhenMoving(host, home, lambda: inject(host, "emergency-stop")) as timer:
        error, _ = timed_failure(robot, home + LONG_MOVE)
        caught = time.monotonic()
    assert isinstance(error, EmergencyStopError) and caught - timer.fired_at < 1.0
    with pytest.raises(EmergencyStopError):
        robot.movej(home)


def test_program_stopped_from_the_dashboard_is_a_program_error(sim_robot, home):
    import dashboard_client

    host, robot = sim_robot
    dashboard = dashboard_client.DashboardClient(host)
    dashboard.connect()
    try:
        with WhenMoving(host, home, dashboard.stop) as timer:
            error, _ = timed_failure(robot, home + LONG_MOVE)
            caught = time.monotonic()
    finally:
        dashboard.disconnect()
    assert isinstance(error, ProgramError) and "from its target" in str(error) and caught - timer.fired_at < 1.5
    assert_at_rest_short_of(robot, home + LONG_MOVE)


def test_runtime_error_in_the_program_is_a_program_error(sim_robot, home):
    host, robot = sim_robot
    inject(host, "freedrive", on=True)  # the controller now refuses movej at run time
    error, elapsed = timed_failure(robot, home + LONG_MOVE)
    assert isinstance(error, ProgramError) and "line" in str(error) and elapsed < 1.5


def test_dropped_connection_during_motion_then_reconnect_without_resending(sim_robot, home):
    host, robot = sim_robot
    target = home + LONG_MOVE
    with WhenMoving(host, home, lambda: inject(host, "drop-connections")) as timer:
        error, _ = timed_failure(robot, target)
        caught = time.monotonic()
    assert isinstance(error, ConnectionLostError) and caught - timer.fired_at < 1.5
    time.sleep(0.5)
    status = robot.state()  # reconnects the streams with backoff
    deadline = time.monotonic() + 3.0
    while status.program_running and time.monotonic() < deadline:  # the driver's stopj may still be decelerating
        time.sleep(0.05)
        status = robot.state()
    assert status.age < 0.5 and not status.program_running
    assert_at_rest_short_of(robot, target)  # stopped, and the motion was not re-sent
    robot.power_on()  # the dashboard reconnects too
    robot.movej(home)  # usable again


def test_state_fails_during_a_long_freeze_and_reads_again_after_it(sim_robot, backend):
    """While the controller stays silent past the client libraries' read deadlines (2.5 s: ur_rtde's, and the one
    ur3dq gives urx's reader), state() raises ConnectionLostError before the freeze is over instead of waiting
    for it: the rtde backend opens no RTDE session while the primary interface is silent too, and says so. Once the
    freeze is over, state() reconnects and reads fresh state."""
    host, robot = sim_robot
    freeze = 8.0
    thawed_at = time.monotonic() + freeze
    inject(host, "freeze", seconds=freeze)
    failure = None
    while failure is None:   # the stream counts as up, its state ageing, until the library ends it
        assert time.monotonic() < thawed_at, "state() did not fail while the controller was frozen"
        try:
            robot.state()
        except ConnectionLostError as error:
            failure = error
        time.sleep(0.05)
    assert time.monotonic() < thawed_at, f"state() failed only after the freeze: {failure}"
    if backend == "rtde":
        assert "on its primary interface either" in str(failure), failure
    time.sleep(max(0.0, thawed_at - time.monotonic()))

    def fresh():
        try:
            return robot.state().age < 0.5
        except ConnectionLostError:
            return False

    assert wait_for(fresh, timeout=10.0), "state() did not read fresh state again after the freeze"


@pytest.mark.exclusive   # timed against a freeze 0.6 s past the freeze timeout: not beside a busy worker
def test_a_reading_during_a_short_freeze_waits_for_fresh_joints(sim_robot):
    """joints() while the stream is older than its freeze timeout (rtde 1 s, urx 1.5 s) but the controller thaws
    within that long again: it waits and returns joints read after the thaw, on the session it had (urx's reader,
    whose own limit is 0.5 s of silence, waits as long as ur_rtde's: a stall is not a lost connection)."""
    host, robot = sim_robot
    limit = robot._backend.freeze_timeout
    inject(host, "freeze", seconds=limit + 0.6)
    frozen_at = time.monotonic()
    assert wait_for(lambda: robot.state().age > limit + 0.05, timeout=5.0)   # stale past the freeze timeout
    assert robot._backend.connected   # the session lived through the silence: not ended, not reopened
    robot.joints()
    assert time.monotonic() - frozen_at >= limit + 0.6   # it waited for the thaw
    assert robot.state().age < 0.5


def test_a_dropped_connection_is_left_to_the_heartbeat_watchdog(backend, home):
    """After every connection dropped mid-move the driver sends no stopj (that program would replace the moving one,
    and the watchdog armed in it, with a gentler stop): it silences its heartbeat, and the controller's watchdog
    stops the program, even though reading the state at once reconnects the streams. The next motion beats again."""
    with simulator_with(initial_q=list(HOME)) as simulator, \
            ur3dq.robot.connect(simulator.host, backend=backend) as robot:
        ready(robot)
        with WhenMoving(simulator.host, home, lambda: inject(simulator.host, "drop-connections")):
            error, _ = timed_failure(robot, home + LONG_MOVE)
        assert isinstance(error, ConnectionLostError)
        robot.state()   # the streams reconnect; the heartbeat must stay silent while the program may run
        assert wait_for(lambda: not simulator_state(simulator.host)["program_running"], timeout=2)
        log = simulator.output()
        assert "RTDE watchdog on input_int_register_20 expired: stop program" in log, log[-2000:]
        assert "program ur3dq_stop" not in log, log[-2000:]
        assert_at_rest_short_of(robot, home + LONG_MOVE)
        robot.movej(home)   # the heartbeat beats again for the next program


def test_frozen_stream_during_motion(sim_robot, home):
    host, robot = sim_robot
    target = home + LONG_MOVE
    with WhenMoving(host, home, lambda: inject(host, "freeze", seconds=2.0)) as timer:
        error, _ = timed_failure(robot, target)
        caught = time.monotonic()
    assert isinstance(error, ConnectionLostError) and caught - timer.fired_at < 2.0
    time.sleep(2.0)  # the freeze ends
    assert_at_rest_short_of(robot, target)


def test_slider_lowered_mid_motion_times_out(sim_robot, home):
    host, robot = sim_robot
    target = home + np.array([1.0, 0, 0, 0, 0, 0])
    duration = motion.movej_duration(home, target, 1.4, 1.05)
    with WhenMoving(host, home, lambda: set_speed_slider(host, 0.05), lead=0.02) as timer:
        error, elapsed = timed_failure(robot, target, a=1.4, v=1.05)
        caught = time.monotonic()
    assert isinstance(error, MotionTimeoutError) and "speed slider" in str(error)
    # the driver's clock starts when it sends the program: after the call, and before the program runs; so the
    # timeout fired no earlier than the derived time after the call and soon after it from the program's start
    timeout = motion.motion_timeout(duration, 1.0)
    assert elapsed >= timeout and caught - timer.running_at <= timeout + 0.5


def test_timeout_allows_for_a_slow_slider(sim_robot, home):
    host, robot = sim_robot
    set_speed_slider(host, 0.5)
    assert wait_for(lambda: robot.state().target_speed_fraction == 0.5)
    target = home + np.array([0.5, 0, 0, 0, 0, 0])
    wall = robot.movej(target, a=1.4, v=1.05)
    assert wall >= 1.8 * motion.movej_duration(home, target, 1.4, 1.05)


@pytest.fixture
def sigint_raises():
    """SIGINT raises KeyboardInterrupt here, as in an interactive Python: a runner started in the background by a
    shell script inherits SIGINT ignored, and then a SIGINT does nothing."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.parametrize("lead", [0.05, 0.6, 1.5])
def test_keyboard_interrupt_stops_the_arm_and_leaves_at_a_poll(sim_robot, home, sigint_raises, lead):
    """A real SIGINT at three points of a move: the driver raises it at its next poll, never where it landed (inside
    a lock it would leave that lock taken: ur3dq.robot.interrupts), stops the arm, and moves again."""
    host, robot = sim_robot
    target = home + LONG_MOVE
    main = threading.main_thread().ident
    with WhenMoving(host, home, lambda: signal.pthread_kill(main, signal.SIGINT), lead=lead), \
            pytest.raises(KeyboardInterrupt) as interrupted:
        robot.movej(target)
    raised_by = innermost_frame(interrupted.tb).f_code
    assert (raised_by.co_filename, raised_by.co_name) == (interrupts.__file__, "_raise_pending"), raised_by
    assert_at_rest_short_of(robot, target)
    robot.movej(home)
    assert np.max(np.abs(robot.joints() - home)) < 1e-3


def innermost_frame(traceback):
    while traceback.tb_next is not None:
        traceback = traceback.tb_next
    return traceback.tb_frame


def test_not_running_robot_is_refused_then_powered_through_the_dashboard(sim_host, backend, home):
    with ur3dq.robot.connect(sim_host, backend=backend) as robot:
        assert robot.state().robot_mode_name == "POWER_OFF"
        with pytest.raises(RobotError, match="not RUNNING"):
            robot.movej(home + 0.1)
        robot.power_on()
        assert robot.state().robot_mode_name == "IDLE"
        robot.brake_release()
        assert robot.state().robot_mode_name == "RUNNING"
        robot.movej(home + 0.1)


def test_a_slow_link_is_no_motion_timeout():
    """Issue 10 item 7: with 2 s of latency on everything the controller sends (set before connecting), a movej
    whose plain timeout (~2.4 s) is shorter than its send-to-end-report time ends normally: the link's round
    trip, measured while connecting, extends every motion's timeout. (ur_rtde backend: urx gives a link a fixed
    0.5 s for its first packet.)"""
    from robot_test_support import HOME, simulator_with

    with simulator_with(initial_q=list(HOME)) as simulator:
        inject(simulator.host, "latency", seconds=2.0)
        with ur3dq.robot.connect(simulator.host, backend="rtde", heartbeat=False) as robot:
            assert robot.link_delay >= 2.0
            robot.power_on()
            robot.brake_release()
            target = HOME + np.array([0.3, 0, 0, 0, 0, 0])
            timeout = motion.motion_timeout(motion.movej_duration(HOME, target, 1.4, 1.0), 1.0)
            wall = robot.movej(target, a=1.4, v=1.0)
            assert wall > timeout   # the end was reported after the timeout a fast link would have had
            assert np.allclose(robot.joints(), target, atol=1e-4)
