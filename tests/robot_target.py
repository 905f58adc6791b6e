"""Which controller robot-facing tests talk to: sim_ursim by default, or the one UR3DQ_TEST_HOST names.

The one place that reads UR3DQ_TEST_HOST; every test module and fixture asks here.
"""
import os

import pytest

ROBOT_HOST_ENV = "UR3DQ_TEST_HOST"


def external_robot_host():
    """The host of an official URSim or real robot to test against, or None for the embedded simulator."""
    return os.environ.get(ROBOT_HOST_ENV) or None


def simulator_only(why):
    """A skip mark for tests that need sim_ursim itself (`why`: what they inject or read through its control
    channel), skipped when UR3DQ_TEST_HOST names an external controller."""
    return pytest.mark.skipif(external_robot_host() is not None,
                              reason=f"{why} needs sim_ursim; {ROBOT_HOST_ENV} names an external controller")


needs_simulator = simulator_only("fault injection")
