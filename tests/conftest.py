"""Shared fixtures: a running simulator, or the official URSim / robot named by UR3DQ_TEST_HOST; the Hypothesis
profile of the run."""
import os

import pytest
from hypothesis import settings

from robot_target import external_robot_host

# `make test` (and CI) draws the same examples every run, so a property either holds or fails, never by luck of the
# draw; UR3DQ_HYPOTHESIS=explore draws new ones each run, to look for counterexamples (a failure it finds becomes a
# fixed test case or a fix).
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("UR3DQ_HYPOTHESIS", "repeatable"))


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
