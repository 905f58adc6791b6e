"""Schema version 2 (cell programs) on disk: round trips, the v1 → v2 upgrade with its backup, program errors that
name the step and leave the file unchanged, symlinked stores, orphan temporaries, implausible numbers."""
import json
import os

import pytest

from tests.store.test_store_file import make_pose
from ur3dq.errors import StoreError
from ur3dq.program.steps import DigitalOut, Message, Motion, RelativeWaypoint, Wait, WaitInput, Waypoint
from ur3dq.store import PoseStore, format_store, parse_document


def v1_store(tmp_path, names=("pick", "place")):
    path = tmp_path / "poses.json"
    path.write_text(format_store([make_pose(name, i) for i, name in enumerate(names)]))
    return PoseStore(path), path


def program(store):
    pick, place = store.load()
    return [
        RelativeWaypoint("approach", "pick", (0, 0, -0.05, 0, 0, 0), "tool", Motion("joint", 0.5)),
        Waypoint("pick", pick, Motion("linear", 0.1, 0.5, 0.0)),
        DigitalOut("grip", "tool", 1, True),
        Wait("settle", 0.25),
        WaitInput("part-present", "standard", 3, True, 2.0),
        Message("say", 'done [bold]"quoted"[/] \\ end'),
        Waypoint("place", place, Motion("process", 0.2, blend=0.01)),
    ]


def test_version_2_round_trip_is_exact(tmp_path):
    store, path = v1_store(tmp_path)
    steps = program(store)
    store.update_program(lambda _: (steps, None))
    version, loaded = parse_document(path.read_text(), str(path))
    assert version == 2 and loaded == steps
    assert store.load() == [steps[1].pose, steps[6].pose]


def test_first_v2_write_upgrades_with_a_byte_exact_backup_and_v1_writes_stay_v1(tmp_path):
    store, path = v1_store(tmp_path)
    original = path.read_bytes()
    store.add(make_pose("third", 9))   # a v1 feature: still version 1, no backup
    assert json.loads(path.read_text())["version"] == 1
    assert not (tmp_path / "poses.json.v1.bak").exists()
    before_upgrade = path.read_bytes()
    store.update_program(lambda steps: (steps + [Wait("pause", 1.0)], None))
    assert json.loads(path.read_text())["version"] == 2
    assert (tmp_path / "poses.json.v1.bak").read_bytes() == before_upgrade != original
    store.remove("pause")   # once version 2, the store stays version 2
    assert json.loads(path.read_text())["version"] == 2
    assert [p.name for p in store.load()] == ["pick", "place", "third"]


@pytest.mark.parametrize("edit, message", [
    (lambda steps: steps + [RelativeWaypoint("up", "nowhere", (0, 0, 0.1, 0, 0, 0))],
     r"step 'up' \(relative waypoint\): its base waypoint 'nowhere' is not in the program"),
    (lambda steps: steps + [RelativeWaypoint("a", "b"), RelativeWaypoint("b", "a")],
     r"step 'a' \(relative waypoint\): relative waypoints form a cycle: 'a' → 'b' → 'a'"),
    (lambda steps: steps + [RelativeWaypoint("up", "pick"), Wait("pause", 1.0)][:1] + [Wait("pick", 1.0)][:0]
     + [RelativeWaypoint("x", "y")], r"step 'x' \(relative waypoint\)"),
])
def test_a_bad_program_names_the_step_and_leaves_the_file_unchanged(tmp_path, edit, message):
    store, path = v1_store(tmp_path)
    before = path.read_bytes()
    with pytest.raises(ValueError, match=message):
        store.update_program(lambda steps: (edit(steps), None))
    assert path.read_bytes() == before


def test_removing_a_base_waypoint_is_refused_naming_the_relative_one(tmp_path):
    store, path = v1_store(tmp_path)
    store.update_program(lambda steps: (steps + [RelativeWaypoint("above", "pick")], None))
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r"step 'above' \(relative waypoint\): its base waypoint 'pick'"):
        store.remove("pick")
    assert path.read_bytes() == before
    store.rename("pick", "grasp")   # a rename carries the relative waypoint along
    assert store.load_program()[-1].base == "grasp"


@pytest.mark.parametrize("entry, message", [
    ({"type": "teleport", "name": "t"}, r":7: step #3 't': unknown step type 'teleport'"),
    ({"type": "digital-out", "name": "d", "output": "standard", "pin": 8, "on": True},
     r":7: step 'd' \(digital-out\): standard pin 8 is out of range \(0..7\)"),
    ({"type": "wait", "name": "w", "seconds": -1}, r":7: step 'w' \(wait\): seconds must be a finite number > 0"),
    ({"type": "relative", "name": "r", "base": "gone", "offset": [0, 0, 0, 0, 0, 0], "frame": "tool"},
     r":7: step 'r' \(relative waypoint\): its base waypoint 'gone' is not in the program"),
])
def test_hand_edited_v2_errors_name_file_line_and_step(tmp_path, entry, message):
    store, path = v1_store(tmp_path)
    store.update_program(lambda steps: (steps + [Wait("pause", 1.0)], None))
    lines = path.read_text().splitlines()
    lines[-3] = lines[-3].replace('{"type": "wait", "name": "pause", "seconds": 1.0}', json.dumps(entry))
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(StoreError, match=message):
        store.load_program()


@pytest.mark.parametrize("first_joint, message", [
    ("9" * 400, r"poses\.json:5: pose #1 'pick': joints holds a number too large for a float"),
    ("1e308", r"poses\.json:5: pose #1 'pick': joints .* not plausible \(\|joint\| > 100 rad\)"),
])
def test_huge_numbers_are_refused_with_file_and_line(tmp_path, first_joint, message):
    store, path = v1_store(tmp_path)
    text = path.read_text()
    joints = json.loads(text)["poses"][0]["joints"]
    path.write_text(text.replace(json.dumps(joints), "[" + first_joint + ", " + json.dumps(joints[1:])[1:], 1))
    with pytest.raises(StoreError, match=message):
        store.load()


def test_a_symlinked_store_is_written_through_the_link(tmp_path):
    real_store, real_path = v1_store(tmp_path)
    link = tmp_path / "link.json"
    link.symlink_to(real_path)
    PoseStore(link).add(make_pose("third", 9))
    assert link.is_symlink()
    assert [p.name for p in real_store.load()] == ["pick", "place", "third"]


def test_orphan_temporaries_of_killed_writers_are_removed_on_the_next_write(tmp_path):
    store, path = v1_store(tmp_path)
    orphans = [tmp_path / ".poses.json.abcd1234.tmp", tmp_path / ".poses.json.zz_9y8x7.tmp",
               tmp_path / ".poses.json.v1.bak.abcd1234.tmp", tmp_path / ".poses.json.v1.bak.2.abcd1234.tmp"]
    others = [tmp_path / ".other.json.abcd1234.tmp", tmp_path / ".poses.json.abcd12345.tmp",
              tmp_path / "poses.json.abcd1234.tmp", tmp_path / ".poses.json.v1.bak.x.abcd1234.tmp"]
    for file in orphans + others:
        file.write_text("partial")
    store.add(make_pose("third", 9))
    assert not any(file.exists() for file in orphans)
    assert all(file.exists() for file in others)
    assert sorted(os.listdir(tmp_path)) == sorted(["poses.json", "poses.json.lock"] + [f.name for f in others])
