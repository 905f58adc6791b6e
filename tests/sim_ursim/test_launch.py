"""Launching simulators (sim_ursim.launch): free loopback addresses, a simulator per context, clean shutdown."""
import ipaddress
import random
import socket
import threading
import time

import numpy as np
import pytest

from sim_ursim.launch import (
    free_loopback_address,
    ports_bindable,
    random_loopback_address,
    running_simulator,
    wait_until_serving,
)
from sim_ursim.simulator import STANDARD_PORTS, Simulator


def settled_thread_count(expected, timeout=5.0):
    """The thread count once it has fallen to `expected` (or the timeout passed)."""
    deadline = time.monotonic() + timeout
    while threading.active_count() > expected and time.monotonic() < deadline:
        time.sleep(0.05)
    return threading.active_count()


def test_random_addresses_are_loopback_but_not_the_usual_one():
    rng = random.Random(7)
    for _ in range(200):
        address = ipaddress.ip_address(random_loopback_address(rng))
        assert address.is_loopback and str(address) != "127.0.0.1"
        assert 2 <= int(str(address).rsplit(".", 1)[1]) <= 254


def test_an_address_with_a_taken_port_is_not_free():
    host = free_loopback_address()
    blocker = socket.socket()
    blocker.bind((host, 30004))
    blocker.listen(1)
    try:
        assert not ports_bindable(host)
        assert free_loopback_address() != host
    finally:
        blocker.close()
    assert ports_bindable(host)


def test_running_simulator_serves_every_port_then_releases_them_and_its_threads():
    before = threading.active_count()
    with running_simulator(model="ur3e") as simulator:
        assert simulator.controller.version.major == 5
        assert simulator.controller.running
        with socket.create_connection((simulator.host, 30002), timeout=2):
            pass
        host = simulator.host
    assert not simulator.controller.running
    assert ports_bindable(host)
    assert settled_thread_count(before) == before


def test_two_simulators_run_side_by_side_on_distinct_addresses():
    with running_simulator() as first, running_simulator() as second:
        assert first.host != second.host
        first.controller.power_up()
        assert second.controller.state().robot_mode != first.controller.state().robot_mode


def test_simulator_refuses_an_address_already_in_use_and_leaves_nothing_running():
    host = free_loopback_address()
    blocker = socket.socket()
    blocker.bind((host, 30003))
    blocker.listen(1)
    before = threading.active_count()
    try:
        simulator = Simulator(host=host)
        with pytest.raises(OSError):
            simulator.start()
        assert not simulator.controller.running
        assert settled_thread_count(before) == before
        assert ports_bindable(host, [29999, 30001, 30002])
    finally:
        blocker.close()


def test_calibrated_simulator_uses_the_calibrated_dh():
    calibration = {"a": [0, 0.002, -0.001, 0, 0, 0], "d": [0.001, 0, 0, 0, 0, 0]}
    nominal, calibrated = Simulator(host="127.0.0.1"), Simulator(host="127.0.0.1", calibration=calibration)
    q = [0.3, -1.2, 1.1, -1.4, -1.5, 0.2]
    difference = np.abs(nominal.controller.fk(q)[:3] - calibrated.controller.fk(q)[:3])
    assert calibrated.controller.model.calibrated and 0.0005 < difference.max() < 0.005


def test_wait_until_serving_names_the_silent_ports():
    host = free_loopback_address()
    with pytest.raises(TimeoutError, match=r"not serving ports \[29999\]"):
        wait_until_serving(host, ports=[29999], timeout=0.2)
    assert set(STANDARD_PORTS) == {29999, 30001, 30002, 30003, 30004, 29998}
