"""Shared fixtures: a running simulator, or the official URSim / robot named by UR3DQ_TEST_HOST; the Hypothesis
profile of the run."""
import os
import threading
import time

import pytest
from hypothesis import settings

from robot_target import external_robot_host

# `make test` (and CI) draws the same examples every run, so a property either holds or fails, never by luck of the
# draw; UR3DQ_HYPOTHESIS=explore draws new ones each run, to look for counterexamples (a failure it finds becomes a
# fixed test case or a fix).
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("UR3DQ_HYPOTHESIS", "repeatable"))

#: Seconds a module's threads get to end after its last test: a server's threads see their stop within a poll.
THREAD_END_GRACE = 5.0


@pytest.fixture(scope="module", autouse=True)
def no_thread_outlives_its_module():
    """Fail a test module that leaves a thread running: one blocked for good costs little, but one spinning (urx's
    reader on a closed socket) took a core from every later test of its worker."""
    before = set(threading.enumerate())
    yield
    deadline = time.monotonic() + THREAD_END_GRACE
    while left := [thread for thread in threading.enumerate() if thread not in before and thread.is_alive()]:
        if time.monotonic() > deadline:
            pytest.fail(f"threads still running after the module's tests: {sorted(t.name for t in left)}")
        time.sleep(0.05)


@pytest.fixture
def sim():
    """A fresh sim_ursim (UR3, CB3 3.15) on a free loopback address, shut down after the test."""
    from sim_ursim.launch import running_simulator

    with running_simulator(model="ur3") as simulator:
        yield simulator


@pytest.fixture
def robot_host():
    """The host robot-facing tests talk to: UR3DQ_TEST_HOST if set, else a fresh simulator process.

    A separate process, because ur_rtde blocks without releasing the GIL and would starve an in-process simulator.
    """
    host = external_robot_host()
    if host is not None:
        yield host
        return
    from sim_ursim.launch import simulator_process

    with simulator_process(model="ur3") as simulator:
        yield simulator.host
