"""Which controller robot-facing tests talk to: sim_ursim by default, or the one UR3DQ_TEST_HOST names."""
import os

import pytest

ROBOT_HOST_ENV = "UR3DQ_TEST_HOST"


def external_robot_host():
    """The host of an official URSim or real robot to test against, or None for the embedded simulator."""
    return os.environ.get(ROBOT_HOST_ENV) or None


needs_simulator = pytest.mark.skipif(
    external_robot_host() is not None,
    reason=f"fault injection needs sim_ursim; {ROBOT_HOST_ENV} names an external controller",
)
