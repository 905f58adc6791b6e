"""Closing a connection releases ur_rtde's interfaces at once, never in a later garbage collection."""
import gc
import time

import pytest

import ur3dq.robot
from robot_target import needs_simulator

pytestmark = [needs_simulator, pytest.mark.exclusive]  # compares two collection times: not beside a busy worker


def _collection_time():
    started = time.monotonic()
    gc.collect()
    return time.monotonic() - started


def test_a_closed_connection_left_in_a_reference_cycle_costs_the_collector_nothing(sim_host):
    """ur_rtde's RTDEReceiveInterface destructor waits 0.5 s holding the GIL. If a closed Robot kept it, the
    collection that frees the Robot would freeze every thread for that long: during a later motion the heartbeat
    stops and the controller's watchdog stops a healthy motion (seen in tests/robot/test_robot_faults.py)."""
    gc.collect()
    baseline = min(_collection_time() for _ in range(3))
    robot = ur3dq.robot.connect(sim_host, backend="rtde", heartbeat=False)
    robot.close()
    cycle = [robot]
    cycle.append(cycle)  # from here only the collector can free the closed Robot
    del robot, cycle
    assert _collection_time() - baseline < 0.25
