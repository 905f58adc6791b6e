"""RTDE stream figures of sim_ursim: rate and p99 interval seen by ur_rtde at 125 Hz (UR3, CB3) and 500 Hz (UR3e),
and the simulator's CPU use while streaming, each set against a peer measured in the same run.

Peers: the nominal controller rate (delivered / nominal), a raw-socket RTDE reader on the same stream (what arrives
on the wire, with arrival times, versus what ur_rtde keeps — ur_rtde drops the older of two buffered packages), and
the same simulator process idle with no RTDE client (CPU ratio).

The simulator runs as `python -m sim_ursim` in a child process, so its CPU time is its own and ur_rtde (which holds
the GIL while it blocks) can live in this process.  Run: .venv/bin/python benchmarks/bench_rtde_stream.py [seconds]

Cycle completeness under load (`--under-load [--record-example PATH] [--clients record.py,ur_rtde,raw]`): the
simulator runs beside two busy processes (`python -c "while 1: pass"`; on a 2-core machine more runnable processes
than cores) and every frame of a full-rate stream is checked: consecutive `timestamp`s must be exactly one control
period apart. Skipped cycles = the periods missing between frames (late frames are allowed, missing ones are not).
Clients: UR's RTDE Python client's `examples/record.py` (given its path; it writes every package it receives, in
order) and ur_rtde (`startFileRecording`). ur_rtde keeps only the newest state and its recorder samples that state
on its own clock, one row per period, so it repeats some frames and misses others whatever the stream carries: the
peer for both clients is the same measurement on a simulator without the busy processes, in the same run. On a
machine shared with other work, run the whole benchmark at a raised priority (`nice -n -10`, as root) so that the
two busy processes, not the other work, are the load (or at ordinary priority, the harder condition). The
"raw" client (a protocol-2 reader with a recipe like URCL's) also counts late frames — arrival minus the frame's
place on the timeline of its earliest frame, more than one period — and gives the simulator's CPU per simulated
second; its arrival times are its own, so a late frame may be the reader's lateness as well as the simulator's. Run:
.venv/bin/python benchmarks/bench_rtde_stream.py --under-load --record-example PATH/examples/record.py [seconds]
"""
import argparse
import contextlib
import csv
import os
import socket
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np
import rtde_receive

from sim_ursim.launch import SimulatorProcess, simulator_process
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


def p99_ms(values):
    return float(np.percentile(np.diff(values), 99) * 1000)


def measure(model, nominal, seconds):
    with simulator_process(model=model) as simulator:
        pid = simulator.process.pid
        time.sleep(1.0)  # let the process settle after start-up
        _, idle_cpu = cpu_share(pid, lambda: time.sleep(3.0))
        stamps, streaming_cpu = cpu_share(pid, lambda: ur_rtde_recording(simulator.host, seconds))
        _, arrivals = raw_frames(simulator.host, nominal, seconds)
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


def skipped_cycles(stamps, period):
    """(periods missing between consecutive timestamps, frames out of order or repeated, largest gap in periods)."""
    steps = np.rint(np.diff(np.asarray(stamps, dtype=float)) / period).astype(int)
    if steps.size == 0:
        return 0, 0, 0
    return int(np.sum(steps[steps > 1] - 1)), int(np.sum(steps < 1)), int(steps.max())


@contextlib.contextmanager
def busy_processes(count):
    """`count` processes spinning on a core each (the load beside the simulator), killed on exit."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(count)]
    try:
        yield spinners
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


def record_example_stamps(record_example, host, rate, seconds):
    """Timestamps of every frame UR's record.py example wrote for `seconds` at `rate` (its default recipe)."""
    handle, path = tempfile.mkstemp(suffix=".csv")
    os.close(handle)
    try:
        subprocess.run([sys.executable, os.path.basename(record_example), "--host", host, "--frequency", str(rate),
                        "--samples", str(int(rate * seconds)), "--output", path],
                       cwd=os.path.dirname(os.path.abspath(record_example)), stdout=subprocess.DEVNULL, check=True,
                       timeout=seconds * 3 + 30)
        with open(path) as recording:
            header = recording.readline().split()
            column = header.index("timestamp")
            return np.array([float(line.split()[column]) for line in recording if line.strip()])
    finally:
        os.remove(path)


def ur_rtde_stamps(host, rate, seconds):
    """Timestamps of every frame ur_rtde recorded for `seconds` at `rate` (not deduplicated)."""
    receiver = rtde_receive.RTDEReceiveInterface(host, float(rate))
    handle, path = tempfile.mkstemp(suffix=".csv")
    os.close(handle)
    try:
        receiver.startFileRecording(path, ["timestamp"])
        time.sleep(seconds)
        receiver.stopFileRecording()
        with open(path, newline="") as recording:
            return np.array([float(row["timestamp"]) for row in csv.DictReader(recording)])
    finally:
        receiver.disconnect()
        os.remove(path)


STREAM_RECIPE = ["timestamp", "actual_q", "actual_qd", "target_q", "target_qd", "target_qdd", "speed_scaling",
                 "runtime_state", "robot_mode", "safety_mode", "actual_TCP_pose"]  # what URCL's drivers read


def raw_frames(host: str, rate: float, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """(timestamps, arrival times on time.monotonic) of every data package a raw protocol-2 reader gets for
    `seconds` at `rate`, with a recipe like URCL's."""
    stamps, arrivals = [], []
    with socket.create_connection((host, 30004), timeout=5) as sock:
        for request in (protocol.pack_protocol_version_request(2),
                        protocol.pack_setup_outputs_request(STREAM_RECIPE, rate, 2), protocol.pack_start_request()):
            sock.sendall(request)
        sock.settimeout(seconds)  # a silent stream is a gap to measure, not an error
        buffer = bytearray()
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            buffer += sock.recv(65536)
            now = time.monotonic()
            while (package := protocol.split_package(buffer)) is not None:
                del buffer[:package[2]]
                if package[0] == protocol.PackageType.DATA_PACKAGE:
                    stamps.append(struct.unpack_from(">d", package[1], 1)[0])  # after the recipe id
                    arrivals.append(now)
    return np.array(stamps), np.array(arrivals)


def lateness_line(stamps: np.ndarray, arrivals: np.ndarray, rate: float) -> str:
    """Late frames: a frame's lateness is its arrival minus its cycle's place on the timeline of the earliest frame
    (arrival − timestamp, least over the run, taken as on time); also the widest gap between two arrivals."""
    period = 1.0 / rate
    offsets = arrivals - stamps
    lateness = offsets - offsets.min()
    gaps = np.diff(arrivals)
    return (f"late frames {np.sum(lateness > period)} (> 1 period), {np.sum(lateness > 0.1)} (> 100 ms), latest "
            f"{lateness.max() * 1000:.0f} ms; widest gap between arrivals {gaps.max() * 1000:.0f} ms, "
            f"{np.sum(gaps > 0.1)} gaps > 100 ms")


def raw_stream_report(simulator: SimulatorProcess, rate: float, seconds: float) -> str:
    """One report line of the raw reader: completeness, lateness, and the simulator's CPU per simulated second."""
    pid = simulator.process.pid
    cpu_before = process_cpu_seconds(pid)
    stamps, arrivals = raw_frames(simulator.host, rate, seconds)
    cpu = process_cpu_seconds(pid) - cpu_before
    simulated = stamps[-1] - stamps[0] + 1.0 / rate
    return (completeness_line("raw", stamps, rate) + "; " + lateness_line(stamps, arrivals, rate)
            + f"; simulator CPU {cpu / simulated:.3f} s per simulated s")


def completeness_line(name, stamps, rate):
    """One report line: frames, cycles they span, skipped cycles, repeats, widest gap (ur_rtde rows deduplicated)."""
    distinct = np.unique(stamps)
    skipped, disordered, widest = skipped_cycles(distinct if name == "ur_rtde" else stamps, 1.0 / rate)
    cycles = int(round((distinct[-1] - distinct[0]) * rate)) + 1 if distinct.size else 0
    return (f"{name:9s}: {stamps.size} rows, {distinct.size} distinct frames for {cycles} cycles; skipped cycles "
            f"{skipped}; out of order {disordered}; repeated rows {stamps.size - distinct.size}; widest gap {widest} "
            f"periods")


def under_load(seconds: float, record_example: str | None, spinners: int = 2,
               clients: tuple[str, ...] = ("record.py", "ur_rtde")) -> None:
    """Skipped cycles of full-rate streams (CB3 125 Hz, e-series 500 Hz) beside `spinners` busy processes for
    `seconds`, and the same without them (the peer, for a third of that, at least 10 s). Clients: "record.py"
    (needs `record_example`), "ur_rtde", "raw" (also late frames and the simulator's CPU per simulated second)."""
    print(f"cycle completeness over {seconds:.0f} s per client and rate ({os.cpu_count()} cores)")
    recorders = {"ur_rtde": ur_rtde_stamps,
                 "record.py": lambda host, rate, s: record_example_stamps(record_example, host, rate, s)}
    for model, rate in (("ur5", 125), ("ur5e", 500)):
        for load, duration in ((spinners, seconds), (0, max(10.0, seconds / 3))):
            with simulator_process(model=model) as simulator, busy_processes(load):
                time.sleep(1.0)
                for name in clients:
                    heading = f"  {model} @ {rate} Hz, {load} busy processes, load average {os.getloadavg()[0]:5.2f}, "
                    if name == "raw":
                        line = raw_stream_report(simulator, rate, duration)
                    else:
                        line = completeness_line(name, recorders[name](simulator.host, rate, duration), rate)
                    print(heading + line + f" (load after {os.getloadavg()[0]:.2f})", flush=True)


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
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("seconds", nargs="?", type=float, default=None)
    parser.add_argument("--under-load", action="store_true", help="count skipped cycles beside two busy processes")
    parser.add_argument("--record-example", help="path of UR's RTDE client examples/record.py")
    parser.add_argument("--clients", default=None,
                        help="comma-separated clients for --under-load: record.py, ur_rtde, raw (default: record.py "
                             "when --record-example is given, and ur_rtde)")
    arguments = parser.parse_args()
    if arguments.under_load:
        default = "record.py,ur_rtde" if arguments.record_example else "ur_rtde"
        under_load(arguments.seconds or 60.0, arguments.record_example,
                   clients=tuple((arguments.clients or default).split(",")))
    else:
        main(arguments.seconds or 10.0)
