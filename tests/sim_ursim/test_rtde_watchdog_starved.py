"""The RTDE input watchdog of a simulator process starved of the CPU on purpose (SIGSTOP/SIGCONT), not by load.

A controller judges a client's silence in its own control cycles: a simulator held back for 60 ms at a time (every
check of its watchdog then comes after a stall of its own) still stops the program of a client that sends nothing,
and one held back for 0.8 s at a time does not stop the program of a client (ur_rtde's RTDEIOInterface) that kept
writing all along: the packages it sent meanwhile are read late, not missed.
"""
import contextlib
import re
import signal
import socket
import threading
import time
from datetime import datetime

from robot_target import simulator_only
from sim_ursim.control_channel import send_request
from sim_ursim.launch import simulator_process

pytestmark = simulator_only("pausing the simulator's process")

REGISTER = 20
EXPIRED = re.compile(r"^(\S+ \S+) WARNING sim_ursim\.rtde: RTDE watchdog on input_int_register_20 expired", re.M)


def start_watched_program(host, frequency):
    """A program that arms a `frequency` Hz stop watchdog on input_int_register_20 and then waits; returns once it
    runs."""
    script = (f'def watched():\n  rtde_set_watchdog("input_int_register_{REGISTER}", {frequency}, "stop")\n'
              "  sleep(60)\nend\n")
    with socket.create_connection((host, 30002), timeout=5) as connection:
        connection.sendall(script.encode())
    deadline = time.monotonic() + 5
    while not send_request(host, "status")["state"]["program_running"]:
        assert time.monotonic() < deadline, "the watched program never started"
        time.sleep(0.01)


def starve(process, stopped, running, seconds):
    """Hold `process` stopped for `stopped` s, then let it run `running` s, for `seconds`; it runs again after.
    Returns the wall time (time.time) at which the last hold ended."""
    deadline = time.monotonic() + seconds
    try:
        while time.monotonic() < deadline:
            process.send_signal(signal.SIGSTOP)
            time.sleep(stopped)
            process.send_signal(signal.SIGCONT)
            time.sleep(running)
    finally:
        process.send_signal(signal.SIGCONT)
    return time.time()


def expiries(simulator):
    """The wall times (time.time) the simulator logged the watchdog of input_int_register_20 expiring."""
    return [datetime.strptime(stamp, "%Y-%m-%d %H:%M:%S,%f").timestamp()
            for stamp in EXPIRED.findall(simulator.output())]


def test_a_silent_client_is_stopped_while_the_simulator_is_starved():
    with simulator_process(model="ur3") as simulator:
        start_watched_program(simulator.host, 10)
        starved_until = starve(simulator.process, stopped=0.06, running=0.015, seconds=1.5)
        fired = expiries(simulator)
        assert fired and fired[0] < starved_until, "the watchdog did not fire while the simulator was starved"
        assert not send_request(simulator.host, "status")["state"]["program_running"]


def test_a_client_that_kept_writing_is_not_blamed_for_the_simulators_pauses():
    import rtde_io

    with simulator_process(model="ur3") as simulator:
        writing = threading.Event()
        writing.set()
        io = rtde_io.RTDEIOInterface(simulator.host)

        def write():
            count = 0
            while writing.is_set():
                count += 1
                io.setInputIntRegister(REGISTER, count)
                time.sleep(0.01)

        writer = threading.Thread(target=write, daemon=True)
        writer.start()
        try:
            start_watched_program(simulator.host, 2)   # 0.5 s: shorter than each pause below
            starve(simulator.process, stopped=0.8, running=0.1, seconds=2.5)
            time.sleep(0.2)
            assert send_request(simulator.host, "status")["state"]["program_running"], simulator.output()[-3000:]
            assert not expiries(simulator)
            writing.clear()
            writer.join(2)
            deadline = time.monotonic() + 3   # the watchdog still watches: silence now stops the program
            while send_request(simulator.host, "status")["state"]["program_running"]:
                assert time.monotonic() < deadline, "the watchdog never fired once the client stopped writing"
                time.sleep(0.05)
        finally:
            writing.clear()
            with contextlib.suppress(Exception):
                io.disconnect()
