"""Closing a connection releases ur_rtde's interfaces at once, never in a later garbage collection."""
import gc
import time

import pytest

import ur3dq.robot
from polling import wait_for
from robot_target import needs_simulator
from robot_test_support import inject
from ur3dq.errors import ConnectionLostError
from ur3dq.robot.rtde_backend import RTDEBackend

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


def test_a_stream_error_kept_by_its_caller_leaves_the_collector_nothing(sim_host):
    """A raised error keeps, in its traceback, the frames it passed through. When the state read
    (RTDEBackend.status) held ur_rtde's interface in a local, a ConnectionLostError that its caller kept in a
    reference cycle kept the interface too: close() was then not its last reference, and the collection that freed
    the error froze every thread for 0.5 s. In the suite that collection fell at the start of a later test's
    motion, whose heartbeat the controller's watchdog then missed (fresh-clone runs 25 and 61: the arm stopped
    0.009 rad into test_slider_lowered_mid_motion_times_out[rtde])."""
    gc.collect()
    baseline = min(_collection_time() for _ in range(3))
    backend = RTDEBackend(sim_host, None)
    inject(sim_host, "drop-connections")
    assert wait_for(lambda: not backend.connected)
    with pytest.raises(ConnectionLostError) as caught:
        backend.status()
    backend.close()
    cycle = [caught.value]
    cycle.append(cycle)   # the error, and its traceback's frames, now wait for the collector
    del caught, cycle
    assert _collection_time() - baseline < 0.25
