"""RTDE stream figures of sim_ursim: rate and p99 interval seen by ur_rtde at 125 Hz (UR3, CB3) and 500 Hz (UR3e),
and the simulator's CPU use while streaming, each set against a peer measured in the same run.

Peers: the nominal controller rate (delivered / nominal), a raw-socket RTDE reader on the same stream (what arrives
on the wire, with arrival times, versus what ur_rtde keeps — ur_rtde drops the older of two buffered packages), and
the same simulator process idle with no RTDE client (CPU ratio).

The simulator runs as `python -m sim_ursim` in a child process, so its CPU time is its own and ur_rtde (which holds
the GIL while it blocks) can live in this process.  Run: .venv/bin/python benchmarks/bench_rtde_stream.py [seconds]
"""
import csv
import os
import socket
import sys
import tempfile
import time

import numpy as np
import rtde_receive

from sim_ursim.launch import simulator_process
from sim_ursim.rtde import protocol

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def process_cpu_seconds(pid):
    """User + system CPU seconds a process (all its threads) has used so far, from /proc/<pid>/stat."""
    with open(f"/proc/{pid}/stat") as handle:
        fields = handle.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def cpu_share(pid, action):
    """(result of action(), CPU share of one core the process used meanwhile)."""
    cpu_before, wall_before = process_cpu_seconds(pid), time.monotonic()
    result = action()
    return result, (process_cpu_seconds(pid) - cpu_before) / (time.monotonic() - wall_before)


def ur_rtde_recording(host, seconds):
    """Distinct data timestamps of every package ur_rtde kept during `seconds` (its default recipe and rate)."""
    receiver = rtde_receive.RTDEReceiveInterface(host)
    handle, path = tempfile.mkstemp(suffix=".csv")
    os.close(handle)
    try:
        receiver.startFileRecording(path, ["timestamp"])
        time.sleep(seconds)
        receiver.stopFileRecording()
        with open(path, newline="") as recording:
            stamps = sorted({float(row["timestamp"]) for row in csv.DictReader(recording)})
    finally:
        receiver.disconnect()
        os.remove(path)
    return np.array(stamps)


def raw_arrivals(host, rate, seconds):
    """Arrival times (monotonic) of every data package a raw protocol-2 reader gets for `seconds`."""
    arrivals = []
    with socket.create_connection((host, 30004), timeout=5) as sock:
        for request in (protocol.pack_protocol_version_request(2),
                        protocol.pack_setup_outputs_request(["timestamp", "actual_q", "actual_TCP_pose"], rate, 2),
                        protocol.pack_start_request()):
            sock.sendall(request)
        buffer = bytearray()
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            buffer += sock.recv(65536)
            now = time.monotonic()
            while (package := protocol.split_package(buffer)) is not None:
                del buffer[:package[2]]
                if package[0] == protocol.PackageType.DATA_PACKAGE:
                    arrivals.append(now)
    return np.array(arrivals)


def p99_ms(values):
    return float(np.percentile(np.diff(values), 99) * 1000)


def measure(model, nominal, seconds):
    with simulator_process(model=model) as simulator:
        pid = simulator.process.pid
        time.sleep(1.0)  # let the process settle after start-up
        _, idle_cpu = cpu_share(pid, lambda: time.sleep(3.0))
        stamps, streaming_cpu = cpu_share(pid, lambda: ur_rtde_recording(simulator.host, seconds))
        arrivals = raw_arrivals(simulator.host, nominal, seconds)
    kept_rate = len(stamps) / seconds
    wire_rate = len(arrivals) / seconds
    return {
        "model": model, "nominal": nominal,
        "ur_rtde_rate": kept_rate, "ur_rtde_ratio": kept_rate / nominal,
        "ur_rtde_pace": 1 / float(np.median(np.diff(stamps))), "ur_rtde_p99_ms": p99_ms(stamps),
        "ur_rtde_max_gap_ms": float(np.diff(stamps).max() * 1000),
        "raw_rate": wire_rate, "raw_ratio": wire_rate / nominal, "raw_p99_ms": p99_ms(arrivals),
        "idle_cpu": idle_cpu, "streaming_cpu": streaming_cpu,
    }


def main(seconds=10.0):
    print(f"RTDE stream over {seconds:.0f} s per rate; simulator = `python -m sim_ursim` child process")
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    for model, nominal in (("ur3", 125), ("ur3e", 500)):
        r = measure(model, nominal, seconds)
        print(f"\n{model} @ {nominal} Hz nominal")
        print(f"  ur_rtde kept     {r['ur_rtde_rate']:7.1f} Hz  = {r['ur_rtde_ratio']:.3f} x nominal; pace "
              f"(1/median interval) {r['ur_rtde_pace']:.1f} Hz; p99 interval {r['ur_rtde_p99_ms']:.2f} ms; "
              f"max gap {r['ur_rtde_max_gap_ms']:.1f} ms")
        print(f"  raw reader got   {r['raw_rate']:7.1f} Hz  = {r['raw_ratio']:.3f} x nominal; p99 arrival interval "
              f"{r['raw_p99_ms']:.2f} ms  (peer: what the wire carried)")
        print(f"  simulator CPU    {r['streaming_cpu'] * 100:5.1f} % of a core streaming to ur_rtde vs "
              f"{r['idle_cpu'] * 100:5.1f} % idle without clients "
              f"(ratio {r['streaming_cpu'] / max(r['idle_cpu'], 1e-9):.2f})")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 10.0)
