"""Driver overhead against urx, and protective-stop reaction time, measured in one run against sim_ursim.

Per-move overhead = wall time of a blocking movej − its trapezoidal duration (the time the arm must move), median
and p95 over N moves, for
  - ur3dq (rtde backend and urx backend) on the default CB3 3.15 simulator, and on an emulated 3.4 controller;
  - urx 0.11's own `movej(wait=True)` on the emulated 3.4 controller (the newest version where urx can wait).
Goal: ur3dq's overhead ≤ 2 control cycles (16 ms on CB3). Also: time from the controller's protective stop to
ProtectiveStopError reaching the caller of a blocking movej.

Run: .venv/bin/python benchmarks/bench_driver.py [--moves 20] [--stops 3]
"""
import argparse
import statistics
import threading
import time

import numpy as np
from urx.urrobot import URRobot

import ur3dq.robot
from sim_ursim.control_channel import send_request
from sim_ursim.launch import simulator_process
from ur3dq.errors import ProtectiveStopError
from ur3dq.robot import motion

CB3_CYCLE = 0.008
A, V = 1.4, 1.05
HOME = np.array([0.0, -1.5707963267948966, 1.2, -1.2, -1.5707963267948966, 0.0])
OFFSET = np.array([0.25, -0.2, 0.15, 0.1, 0.2, -0.3])


def percentile(values, fraction):
    """The `fraction` quantile of `values` (linear interpolation)."""
    return float(np.quantile(np.asarray(values), fraction))


def alternating_targets(count):
    """`count` joint targets alternating between HOME+OFFSET and HOME (each move the same trapezoid)."""
    return [HOME + OFFSET if index % 2 == 0 else HOME for index in range(count)]


def ur3dq_overheads(host, backend, count):
    """Per-move overheads (s) of ur3dq's blocking movej."""
    overheads = []
    with ur3dq.robot.connect(host, backend=backend) as robot:
        robot.movej(HOME, a=A, v=V)
        for target in alternating_targets(count):
            start_q = robot.joints()
            started = time.perf_counter()
            robot.movej(target, a=A, v=V)
            wall = time.perf_counter() - started
            overheads.append(wall - motion.movej_duration(start_q, target, A, V))
    return overheads


def urx_overheads(host, count):
    """Per-move overheads (s) of urx 0.11's movej(wait=True) (needs a controller urx understands, ≤ 3.4)."""
    robot = URRobot(host)
    overheads = []
    try:
        robot.movej(list(HOME), acc=A, vel=V, wait=True)
        for target in alternating_targets(count):
            start_q = np.array(robot.getj())
            started = time.perf_counter()
            robot.movej(list(target), acc=A, vel=V, wait=True)
            wall = time.perf_counter() - started
            overheads.append(wall - motion.movej_duration(start_q, target, A, V))
    finally:
        robot.close()
    return overheads


def protective_stop_latency(backend):
    """Seconds from requesting a protective stop (simulator control channel) to ProtectiveStopError in the caller
    of a blocking movej: an upper bound, since it includes the request's own transport."""
    with simulator_process(model="ur3", initial_q=list(HOME)) as sim:
        with ur3dq.robot.connect(sim.host, backend=backend) as robot:
            power_up(robot)
            robot.movej(HOME, a=A, v=V)
            requested_at = []

            def stop_later():
                time.sleep(0.4)
                requested_at.append(time.perf_counter())
                send_request(sim.host, "protective-stop", reason="benchmark")

            trigger = threading.Thread(target=stop_later)
            trigger.start()
            try:
                robot.movej(HOME + np.array([2.0, 0, 0, 0, 0, 0]), a=A, v=V)
            except ProtectiveStopError:
                caught = time.perf_counter()
            else:
                raise AssertionError("the protective stop did not interrupt the movej")
            finally:
                trigger.join()
            return caught - requested_at[0]


def describe(label, overheads):
    """One result line: median and p95 in ms and in CB3 control cycles."""
    median, p95 = statistics.median(overheads), percentile(overheads, 0.95)
    return (f"{label:<44} median {median * 1000:7.1f} ms ({median / CB3_CYCLE:4.1f} cycles)   "
            f"p95 {p95 * 1000:7.1f} ms ({p95 / CB3_CYCLE:4.1f} cycles)")


def power_up(robot):
    """Power the arm and release its brakes through the driver's dashboard connection."""
    if robot.state().robot_mode != 7:
        robot.power_on()
        robot.brake_release()


def powered_simulator(**options):
    """A simulator process (UR3 at HOME) whose arm is powered up and warmed up (its URScript parser built)."""
    simulator = simulator_process(model="ur3", initial_q=list(HOME), **options)
    host = simulator.__enter__().host
    with ur3dq.robot.connect(host) as robot:
        power_up(robot)
        robot.movej(HOME + OFFSET, a=A, v=V)
        robot.movej(HOME, a=A, v=V)
    return simulator, host


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--moves", type=int, default=20)
    parser.add_argument("--stops", type=int, default=3)
    args = parser.parse_args()
    print(f"movej a={A} rad/s², v={V} rad/s, {args.moves} moves of {motion.leading_travel(HOME, HOME + OFFSET):.2f} "
          f"rad ({motion.movej_duration(HOME, HOME + OFFSET, A, V) * 1000:.0f} ms each); CB3 cycle 8 ms")
    results = {}
    simulator, host = powered_simulator()
    try:
        for backend in ("rtde", "urx"):
            results[f"ur3dq {backend} backend, CB3 3.15"] = ur3dq_overheads(host, backend, args.moves)
    finally:
        simulator.__exit__(None, None, None)
    simulator, host = powered_simulator(version="3.4")
    try:
        results["ur3dq rtde backend, CB3 3.4"] = ur3dq_overheads(host, "rtde", args.moves)
        results["urx 0.11 movej(wait=True), CB3 3.4"] = urx_overheads(host, args.moves)
    finally:
        simulator.__exit__(None, None, None)
    for label, overheads in results.items():
        print(describe(label, overheads))
    ours = statistics.median(results["ur3dq rtde backend, CB3 3.4"])
    theirs = statistics.median(results["urx 0.11 movej(wait=True), CB3 3.4"])
    print(f"ratio urx / ur3dq(rtde) median overhead on 3.4: {theirs / ours:.1f}" if ours > 0 else
          "ur3dq overhead ≤ 0")
    for backend in ("rtde", "urx"):
        latencies = [protective_stop_latency(backend) for _ in range(args.stops)]
        print(f"protective stop → ProtectiveStopError, {backend} backend: median "
              f"{statistics.median(latencies) * 1000:.1f} ms, max {max(latencies) * 1000:.1f} ms "
              f"over {len(latencies)} stops")


if __name__ == "__main__":
    main()
