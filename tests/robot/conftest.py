"""Fixtures of the driver tests: both backends, a simulated arm, a connected Robot at HOME.

The simulator runs in its own process (`simulator_process`): ur_rtde's RTDEReceiveInterface constructor blocks
without releasing the GIL, so it deadlocks against a simulator served by threads of the same interpreter.
Faults are injected through the simulator's control channel; the arm is powered through the driver (dashboard).
"""
import pytest

import ur3dq.robot
from robot_target import external_robot_host
from robot_test_support import BACKENDS, HOME, inject, ready, set_speed_slider, simulator_with


@pytest.fixture(scope="module", params=BACKENDS)
def backend(request):
    """Each driver backend in turn: the same behavioural tests run on both."""
    return request.param


@pytest.fixture(scope="module")
def arm_host(backend):
    """UR3DQ_TEST_HOST if set, else a simulator process (starting at HOME) shared by one module's tests of a backend."""
    host = external_robot_host()
    if host is not None:
        yield host
        return
    with simulator_with(initial_q=list(HOME)) as simulator:
        yield simulator.host


@pytest.fixture
def sim_host():
    """The host of a fresh simulator process of its own (sim_ursim only), starting at HOME."""
    with simulator_with(initial_q=list(HOME)) as simulator:
        yield simulator.host


@pytest.fixture(scope="module")
def module_robot(arm_host, backend):
    """One Robot connection per module and backend, kept open across its tests as a long-running program keeps it
    (connecting and closing cost about a second a test). Without the heartbeat: `sim_robot` connects to the same
    simulator while this one is open, and only one connection at a time can hold the heartbeat's RTDE inputs; the
    heartbeat is exercised by `sim_robot`, `own_sim_robot` and the CLI tests (tests/cli/test_cli_kill.py)."""
    with ur3dq.robot.connect(arm_host, backend=backend, heartbeat=False) as connected:
        yield connected


@pytest.fixture
def robot(module_robot):
    """The module's Robot, powered and at HOME."""
    return ready(module_robot)


@pytest.fixture
def own_sim_robot(sim_host, backend):
    """(simulator host, Robot at HOME) on a simulator of its own, for faults that leave it stopped."""
    with ur3dq.robot.connect(sim_host, backend=backend) as connected:
        yield sim_host, ready(connected)


@pytest.fixture
def sim_robot(arm_host, backend):
    """(simulator host, Robot at HOME) on the module's simulator; transport faults, freedrive and the speed slider
    are reset afterwards so the next test starts clean."""
    with ur3dq.robot.connect(arm_host, backend=backend) as connected:
        yield arm_host, ready(connected)
    inject(arm_host, "reset")
    inject(arm_host, "freedrive", on=False)
    set_speed_slider(arm_host, 1.0)


@pytest.fixture
def home():
    """The HOME joint configuration the `robot` and `sim_robot` fixtures start from (copy)."""
    return HOME.copy()
