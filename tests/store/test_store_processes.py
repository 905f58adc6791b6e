"""The store across processes: kill -9 mid-write loses nothing committed; concurrent writers both keep their poses."""
import dataclasses
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from pyquaternion import Quaternion

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import StoreError
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

WRITER = Path(__file__).with_name("store_writer.py")


def random_pose(name, seed):
    """A valid pose with joints, reproducible from `seed`."""
    rng = np.random.default_rng(seed)
    pose = DualQuaternion.from_rotation_translation(Quaternion(rng.normal(size=4)).normalised, rng.uniform(-1, 1, 3))
    return Pose.from_dual_quaternion(name, pose, "ur3", joints=rng.uniform(-3, 3, 6))


def start_writer(store_path, prefix, count):
    """A process adding `count` poses `prefix-N` to the store, printing each name once committed."""
    return subprocess.Popen([sys.executable, str(WRITER), str(store_path), prefix, str(count)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def temporary_files(directory):
    """The writers' temporary files in `directory` (present only while a write is under way, or after a crash)."""
    return [entry.name for entry in os.scandir(directory) if entry.name.endswith(".tmp")]


def test_kill_9_mid_write_keeps_every_committed_pose(tmp_path):
    store_path = tmp_path / "poses.json"
    # ~2 MB of notes make each write last long enough to be caught in the act
    PoseStore(store_path).add_many(dataclasses.replace(random_pose(f"old-{n}", n), note="x" * 40_000)
                                   for n in range(1, 51))
    committed = {f"old-{n}" for n in range(1, 51)}
    caught_mid_write = 0
    for round_number in range(3):
        writer = start_writer(store_path, f"r{round_number}", 10_000)
        names = [writer.stdout.readline().strip()]  # the writer is up and has committed one pose
        deadline = time.monotonic() + 30
        while not temporary_files(tmp_path):  # a write is under way: kill it there
            assert time.monotonic() < deadline and writer.poll() is None, "no write was ever seen under way"
            time.sleep(0.0005)
        writer.kill()
        writer.wait()
        names += [line.strip() for line in writer.stdout]  # every pose announced before the kill
        writer.stdout.close()
        writer.stderr.close()
        assert writer.returncode == -9
        caught_mid_write += bool(temporary_files(tmp_path))
        committed.update(names)
        stored = {pose.name for pose in PoseStore(store_path).load()}
        assert committed <= stored, f"round {round_number}: lost {sorted(committed - stored)}"
        # at most the one write in flight when the kill landed may have completed unannounced
        assert len(stored - committed) <= 1
        committed = stored
        for leftover in temporary_files(tmp_path):  # harmless debris of the killed write; clear it for the next
            os.remove(tmp_path / leftover)
    assert caught_mid_write >= 1, "no kill landed during a write; the test proved nothing"


def test_two_writers_at_once_keep_all_hundred_poses(tmp_path):
    store_path = tmp_path / "poses.json"
    writers = [start_writer(store_path, prefix, 50) for prefix in ("left", "right")]
    outputs = [writer.communicate(timeout=120) for writer in writers]
    assert [writer.returncode for writer in writers] == [0, 0], [err for _, err in outputs]
    names = [pose.name for pose in PoseStore(store_path).load()]
    assert len(names) == 100
    assert sorted(names) == sorted([f"left-{n}" for n in range(1, 51)] + [f"right-{n}" for n in range(1, 51)])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["poses.json", "poses.json.lock"]


def test_a_lock_held_by_another_process_is_an_error_naming_it_and_nothing_is_written(tmp_path, monkeypatch):
    store_path = tmp_path / "poses.json"
    PoseStore(store_path).add(random_pose("a", 1))
    before = store_path.read_bytes()
    holder = subprocess.Popen([sys.executable, "-c", "import filelock, sys; lock = filelock.FileLock(sys.argv[1]); "
                               "lock.acquire(); print('held', flush=True); sys.stdin.read()", f"{store_path}.lock"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        monkeypatch.setattr("ur3dq.store.LOCK_TIMEOUT_S", 0.3)
        with pytest.raises(StoreError, match=r"another process has held the store's lock for 0 s .*poses\.json\.lock"):
            PoseStore(store_path).add(random_pose("b", 2))
    finally:
        holder.communicate("", timeout=30)
    assert store_path.read_bytes() == before
    PoseStore(store_path).add(random_pose("b", 2))   # the lock released, the write goes through
    assert [pose.name for pose in PoseStore(store_path).load()] == ["a", "b"]
