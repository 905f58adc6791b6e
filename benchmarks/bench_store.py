"""Big pose stores: listing and planning 10,000 poses within 1 s of CPU, 100,000 within 10 s (1 s per 10,000).

Each command runs as a real `ur3dq` process (best of N by CPU time, user + system, children's rusage) and its
peak RSS is read from the kernel; the peer call measured in the same run is a bare
`python -c "json.load(open(store))"`: the floor any JSON store pays, so the ratio says what ur3dq adds on top.

Run: env -u UR3DQ_HOST .venv/bin/python benchmarks/bench_store.py [--poses 10000 100000] [--repeat 3]
(no robot or running `ur3dq sim` may be configured: the plan is measured offline, on the nominal model)
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ur3dq.dqarray import to_ur_pose
from ur3dq.kinematics import robot_model
from ur3dq.store_format import SCHEMA_NAME, SCHEMA_VERSION

SECONDS_PER_10K_POSES = 1.0   # the goal: CPU seconds per 10,000 poses (at least 1 s)


# The random walk stays in a working posture (elbow bent, wrist down and out) so that the whole path passes the
# path check that `run-poses` runs before anything moves: the plan then measures planning and checking, not a
# refusal at the first self-collision.
WALK_LOWER = np.array([-np.pi + 0.3, -2.0, 0.8, -2.0, -2.0, -np.pi + 0.3])
WALK_UPPER = np.array([np.pi - 0.3, -1.0, 1.6, -1.0, -1.2, np.pi - 0.3])


def write_big_store(path: Path, count: int) -> None:
    """`count` poses of a UR3 along a random walk of its joints (steps ≤ 0.2 rad, kept between WALK_LOWER and
    WALK_UPPER, so a plan passes the travel check and the path check), each pose from the model's batch FK."""
    model = robot_model("ur3")
    rng = np.random.default_rng(7)
    steps = rng.uniform(-0.2, 0.2, (count, 6))
    joints = np.empty((count, 6))
    q = np.array([0.0, -1.5, 1.2, -1.5, -1.57, 0.0])
    for index in range(count):
        q = q + steps[index]
        q = np.where((q < WALK_LOWER) | (q > WALK_UPPER), q - 2 * steps[index], q)
        joints[index] = q
    poses = model.fk_batch(joints)
    vectors = to_ur_pose(poses)
    with path.open("w", encoding="utf-8") as stream:
        stream.write(f'{{\n  "schema": "{SCHEMA_NAME}",\n  "version": {SCHEMA_VERSION},\n  "poses": [\n')
        for index in range(count):
            entry = {"name": f"pose-{index + 1}", "time": "2026-11-22T01:19:40.556Z", "robot_model": "ur3",
                     "robot_serial": None, "joints": joints[index].tolist(), "dual_quaternion": poses[index].tolist(),
                     "ur_pose": vectors[index].tolist(), "tcp_offset": [0.0] * 6, "note": "bench"}
            stream.write("    " + json.dumps(entry) + (",\n" if index + 1 < count else "\n"))
        stream.write("  ]\n}\n")


def measure(argv, repeat: int) -> tuple[float, float, float]:
    """(best CPU s, its wall s, peak RSS MB) of running `argv` `repeat` times, each in a fresh process."""
    best = None
    for _ in range(repeat):
        start = time.perf_counter()
        process = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - start
        stderr = process.stderr.read().decode()
        process.stderr.close()
        if os.waitstatus_to_exitcode(status) != 0:
            sys.exit(f"{' '.join(argv[:6])} ... failed: {stderr.strip()}")
        cpu = usage.ru_utime + usage.ru_stime
        sample = (cpu, wall, usage.ru_maxrss / 1024.0)
        best = sample if best is None or sample[0] < best[0] else best
    return best


def goal_seconds(poses: int) -> float:
    """The CPU budget of one command on a store of `poses` poses."""
    return max(1.0, poses / 10_000 * SECONDS_PER_10K_POSES)


def measure_store(poses: int, repeat: int) -> bool:
    """Print the figures of every command on a store of `poses` poses; True when each met its goal."""
    goal = goal_seconds(poses)
    met = True
    with tempfile.TemporaryDirectory() as directory:
        store = Path(directory) / "big.json"
        write_big_store(store, poses)
        print(f"store: {poses} poses, {store.stat().st_size / 1e6:.1f} MB")
        ur3dq = [sys.executable, "-m", "ur3dq.cli", "--store", str(store)]
        peer = measure([sys.executable, "-c", f"import json; json.load(open({str(store)!r}))"], repeat)
        print(f"{'peer: json.load of the file':44s} cpu {peer[0]:6.2f} s  wall {peer[1]:6.2f} s  "
              f"rss {peer[2]:6.0f} MB")
        # two plans, each with the whole-path check run-poses runs before anything moves: plain `run-poses
        # --dry-run` of a version-1 store (the replay planner of ur3dq/replay.py) and, with --from, the
        # cell-program planner
        for label, command in (("ur3dq poses list", ["poses", "list"]),
                               ("ur3dq poses list --json", ["poses", "list", "--json"]),
                               ("ur3dq run-poses --dry-run", ["run-poses", "--dry-run"]),
                               ("ur3dq run-poses --dry-run --from pose-1", ["run-poses", "--dry-run", "--from",
                                                                             "pose-1"])):
            cpu, wall, rss = measure(ur3dq + command, repeat)
            ok = cpu <= goal
            met &= ok
            print(f"{label:44s} cpu {cpu:6.2f} s  wall {wall:6.2f} s  rss {rss:6.0f} MB  "
                  f"ratio to peer {cpu / peer[0]:5.1f}×  goal ≤ {goal:g} s: {'met' if ok else 'NOT met'}")
    return met


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    results = [measure_store(poses, args.repeat) for poses in args.poses]
    sys.exit(0 if all(results) else 1)


if __name__ == "__main__":
    main()
