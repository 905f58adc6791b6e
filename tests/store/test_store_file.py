"""The pose store on disk: round trips, edits, schema errors that name file:line, and never overwriting a bad file."""
import json
import math
import os
import stat
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyquaternion import Quaternion

from ur3dq import store_format
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import StoreError
from ur3dq.pose import Pose, parse_iso_time, utc_now_iso
from ur3dq.store import (
    SCHEMA_NAME,
    SCHEMA_VERSION,
    PoseStore,
    format_store,
    parse_store,
    pose_to_dict,
    write_atomically,
)


def make_pose(name, seed=0, joints=True, **fields):
    """A valid pose with a random rotation and translation (reproducible from `seed`)."""
    rng = np.random.default_rng(seed)
    rotation = Quaternion(rng.normal(size=4)).normalised
    pose = DualQuaternion.from_rotation_translation(rotation, rng.uniform(-0.5, 0.5, 3))
    return Pose.from_dual_quaternion(
        name, pose, "ur3", joints=tuple(rng.uniform(-3, 3, 6)) if joints else None, **fields
    )


def store_text_with(pose_dicts):
    """A store file's text holding the given raw pose objects (for hand-edited / broken content)."""
    return json.dumps({"schema": SCHEMA_NAME, "version": SCHEMA_VERSION, "poses": pose_dicts}, indent=1)


def test_missing_file_is_an_empty_store(tmp_path):
    assert PoseStore(tmp_path / "poses.json").load() == []


def test_added_poses_load_back_equal_and_in_order(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    poses = [make_pose("pick", 1, note="above the tray"), make_pose("place", 2, robot_serial="2019300123"),
             make_pose("imported", 3, joints=False)]
    for pose in poses:
        store.add(pose)
    assert store.load() == poses
    document = json.loads((tmp_path / "poses.json").read_text())
    assert document["schema"] == "ur3dq.poses" and document["version"] == 1
    assert [entry["name"] for entry in document["poses"]] == ["pick", "place", "imported"]
    assert document["poses"][2]["joints"] is None


def test_file_layout_is_one_pose_per_line(tmp_path):
    text = format_store([make_pose("a", 1), make_pose("b", 2)])
    lines = text.splitlines()
    assert sum('"name": "a"' in line for line in lines) == 1
    assert json.loads(text)["poses"][1]["name"] == "b"
    assert json.loads(format_store([]))["poses"] == []


@settings(max_examples=60, deadline=None)
@given(
    coefficients=st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4).filter(
        lambda q: np.linalg.norm(q) > 1e-3),
    translation=st.lists(st.floats(-5, 5, allow_nan=False), min_size=3, max_size=3),
    joints=st.one_of(st.none(), st.lists(st.floats(-6.3, 6.3, allow_nan=False), min_size=6, max_size=6)),
    note=st.text(max_size=40),
    name=st.text(min_size=1, max_size=30).filter(lambda n: n == n.strip() and n.isprintable()),
)
def test_format_then_parse_is_exact(coefficients, translation, joints, note, name):
    pose = Pose.from_dual_quaternion(
        name, DualQuaternion.from_rotation_translation(Quaternion(coefficients).normalised, translation), "ur5",
        joints=joints, note=note)
    assert parse_store(format_store([pose]), "mem") == [pose]


def test_times_ending_in_z_read_back_as_utc_on_every_supported_python():
    """utc_now_iso's `Z` suffix, which Python 3.10's datetime.fromisoformat refuses (every store write failed there)."""
    assert parse_iso_time("2026-11-22T01:02:03.456Z") == datetime(2026, 11, 22, 1, 2, 3, 456000, tzinfo=timezone.utc)
    assert parse_iso_time(utc_now_iso()).utcoffset() == timedelta(0)
    assert Pose.from_dual_quaternion("p", DualQuaternion.identity(), "ur3", time=utc_now_iso()).time.endswith("Z")
    with pytest.raises(ValueError):
        parse_iso_time("yesterday")


def test_duplicate_name_is_refused_or_numbered(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    store.add(make_pose("pose", 1))
    with pytest.raises(StoreError, match="'pose' already exists"):
        store.add(make_pose("pose", 2))
    assert store.add(make_pose("pose", 2), number_if_taken=True).name == "pose-1"
    assert store.add(make_pose("pose-1", 3), number_if_taken=True).name == "pose-2"
    assert [p.name for p in store.load()] == ["pose", "pose-1", "pose-2"]


def test_remove_and_rename(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    for index, name in enumerate(["a", "b", "c"]):
        store.add(make_pose(name, index))
    assert store.remove("b").name == "b"
    renamed = store.rename("c", "home")
    assert renamed.name == "home"
    assert [p.name for p in store.load()] == ["a", "home"]
    assert store.get("home").dual_quaternion == make_pose("c", 2).dual_quaternion
    with pytest.raises(StoreError, match="already exists"):
        store.rename("a", "home")
    with pytest.raises(StoreError, match="empty"):
        store.rename("a", "")


def test_unknown_name_lists_the_known_ones(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    store.add(make_pose("pick", 1))
    for action in (lambda: store.get("pik"), lambda: store.remove("pik"), lambda: store.rename("pik", "x"),
                   lambda: store.select(["pick", "pik"])):
        with pytest.raises(StoreError, match=r"no pose named 'pik' in .*poses.json \(it has 'pick'\)"):
            action()


def test_select_keeps_the_requested_order(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    for index, name in enumerate(["a", "b", "c"]):
        store.add(make_pose(name, index))
    assert [p.name for p in store.select(["c", "a"])] == ["c", "a"]
    assert [p.name for p in store.select(None)] == ["a", "b", "c"]


def test_add_many_is_all_or_nothing(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    store.add(make_pose("a", 1))
    with pytest.raises(StoreError, match="'a' already exists"):
        store.add_many([make_pose("b", 2), make_pose("a", 3)])
    assert [p.name for p in store.load()] == ["a"]


def test_missing_directory_is_a_clear_error(tmp_path):
    with pytest.raises(StoreError, match="does not exist"):
        PoseStore(tmp_path / "nowhere" / "poses.json").add(make_pose("a"))


def test_write_atomically_leaves_no_temporary_and_keeps_the_mode(tmp_path):
    target = tmp_path / "file.txt"
    target.write_text("old")
    os.chmod(target, 0o600)
    write_atomically(target, "new")
    assert target.read_text() == "new"
    assert stat.S_IMODE(target.stat().st_mode) == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]


# ---------------------------------------------------------------- broken files: clear error, never overwritten

BROKEN_STORES = {
    "truncated JSON": ('{\n  "schema": "ur3dq.poses",\n  "version": 1,\n  "poses": [\n    {"name": "a"',
                       r":5:\d+: not valid JSON: expecting ',' delimiter;"),
    "unterminated string": ('{"schema": "ur3dq.poses", "version": 2, "steps": [{"name": "a',
                            r":1:\d+: not valid JSON: unterminated string;"),
    "not an object": ("[1, 2]", r":1: not a pose store"),
    "wrong schema": ('{"schema": "other", "version": 1, "poses": []}',
                     r":1: not a pose store: \"schema\" is \"other\", expected \"schema\": \"ur3dq.poses\""),
    "no schema": ('{"version": 2, "steps": []}', r":1: not a pose store: it has no \"schema\" key, expected"),
    "null schema": ('{"schema": null, "version": 2, "steps": []}', r":1: not a pose store: \"schema\" is null,"),
    "newer version": ('{"schema": "ur3dq.poses", "version": 3, "steps": []}',
                      r":1: store version 3 is not supported .*newer"),
    "version true": ('{"schema": "ur3dq.poses", "version": true, "poses": []}',
                     r":1: store version True is not supported"),
    "100,000-deep nesting": ('{"schema": "ur3dq.poses", "version": 1, "poses": [\n' + "[" * 100_000 + "]" * 100_000
                             + "]}", r":2: not a pose store: JSON nested deeper than"),
    "poses not a list": ('{"schema": "ur3dq.poses", "version": 1, "poses": {}}', r":1: \"poses\" must be a list"),
}


@pytest.mark.parametrize("case", sorted(BROKEN_STORES))
def test_broken_store_names_file_and_line_and_is_never_overwritten(tmp_path, case):
    text, message = BROKEN_STORES[case]
    path = tmp_path / "poses.json"
    path.write_text(text)
    store = PoseStore(path)
    with pytest.raises(StoreError, match=str(path).replace(".", r"\.") + message) as raised:
        store.load()
    fix = "upgrade ur3dq to read it" if case == "newer version" else store_format.UNREADABLE_FIX
    assert str(raised.value).endswith(fix)   # the one line says what to do
    for write in (lambda: store.add(make_pose("b")), lambda: store.remove("a"), lambda: store.rename("a", "b")):
        with pytest.raises(StoreError):
            write()
    assert path.read_text() == text


def test_a_store_that_is_not_utf8_names_its_line_and_byte_and_is_never_overwritten(tmp_path):
    path = tmp_path / "poses.json"
    path.write_bytes(b'{\n  "schema": "ur3dq.poses",\n  "version": 1,\n  "poses": [\xff]}\n')
    expected = r"poses\.json:4: not UTF-8 text \(byte 0xff at offset 57\); save it as UTF-8$"
    with pytest.raises(StoreError, match=expected):
        PoseStore(path).load()
    with pytest.raises(StoreError):
        PoseStore(path).add(make_pose("b"))
    assert path.read_bytes().endswith(b"[\xff]}\n")


def broken_pose(field, value):
    """The JSON object of a valid pose 'p' with one field replaced (or removed when value is ...)."""
    entry = pose_to_dict(make_pose("p", 5))
    if value is ...:
        del entry[field]
    else:
        entry[field] = value
    return entry


BAD_POSES = {
    "NaN joint": (broken_pose("joints", [0, math.nan, 0, 0, 0, 0]), "joints contains NaN"),
    "five joints": (broken_pose("joints", [0, 0, 0, 0, 0]), "joints must be 6 numbers, got 5"),
    "text joints": (broken_pose("joints", "zero"), "joints must be 6 numbers"),
    "six digits": (broken_pose("joints", "123456"), "joints must be 6 numbers, got '123456'"),
    "an object of six numbered keys": (broken_pose("joints", {str(k): 0 for k in range(6)}),
                                       "joints must be 6 numbers"),
    "rows of one": (broken_pose("joints", [[0]] * 6), "joints must be 6 numbers"),
    # np.fromiter and np.array read both as numbers (1.5 and 1.0): a JSON number only
    "a number in quotes": (broken_pose("joints", [0, "1.5", 0, 0, 0, 0]),
                           'joints must be 6 numbers, got "1.5" among them'),
    "a literal true": (broken_pose("dual_quaternion", [True, 0, 0, 0, 0, 0, 0, 0]),
                       "dual_quaternion must be 8 numbers, got true among them"),
    "a literal false in the TCP": (broken_pose("tcp_offset", [0, 0, 0, 0, 0, False]),
                                   "tcp_offset must be 6 numbers, got false among them"),
    "a null coefficient": (broken_pose("ur_pose", [0, 0, None, 0, 0, 0]),
                           "ur_pose must be 6 numbers, got null among them"),
    "infinite coefficient": (broken_pose("dual_quaternion", [1, 0, 0, 0, 0, math.inf, 0, 0]),
                             "dual_quaternion contains NaN or infinity"),
    "non-unit rotation": (broken_pose("dual_quaternion", [2, 0, 0, 0, 0, 0, 0, 0]),
                          "dual_quaternion rotation part has norm 2, not 1"),
    "not rigid": (broken_pose("dual_quaternion", [1, 0, 0, 0, 0.5, 0, 0, 0]),
                  "dual_quaternion is not a rigid transform"),
    "pose vector disagrees": (broken_pose("ur_pose", [9, 9, 9, 0, 0, 0]), "ur_pose and dual_quaternion disagree"),
    "typo field": ({**pose_to_dict(make_pose("p", 5)), "jionts": []}, "unknown field 'jionts'"),
    "missing field": (broken_pose("time", ...), "missing field 'time'"),
    "local time": (broken_pose("time", "2026-11-22T01:02:03+01:00"), "time .* must be in UTC"),
    "bad time": (broken_pose("time", "yesterday"), "time .yesterday. is not ISO 8601"),
    "unknown model": (broken_pose("robot_model", "ur99"), "robot_model 'ur99' is not one of ur3, ur5"),
    # JSON's \\u escapes can spell what no UTF-8 file holds: refused when read, not when the next save fails
    "lone surrogate in note": (broken_pose("note", "tray \ud800"), "note holds a lone UTF-16 surrogate"),
    "lone surrogate in serial": (broken_pose("robot_serial", "\udc80"), "robot_serial holds a lone UTF-16 surrogate"),
}


@pytest.mark.parametrize("case", sorted(BAD_POSES))
def test_invalid_pose_names_the_pose_and_what_is_wrong(tmp_path, case):
    entry, message = BAD_POSES[case]
    path = tmp_path / "poses.json"
    path.write_text(store_text_with([pose_to_dict(make_pose("ok", 1)), entry]))
    before = path.read_bytes()
    with pytest.raises(StoreError, match=r"pose #2 'p': " + message):
        PoseStore(path).load()
    with pytest.raises(StoreError):
        PoseStore(path).add(make_pose("new"))
    assert path.read_bytes() == before


def test_a_pose_without_its_optional_tcp_offset_loads_with_a_zero_tcp(tmp_path):
    """tcp_offset is optional (docs/store-schema.md): a store from another tool may leave it out, for some poses
    or all of them, in ur3dq's own layout or any other (it failed to load, "tcp_offset: must be 6 numbers")."""
    tcp = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0]
    poses = [make_pose(name, i, tcp_offset=tcp) for i, name in enumerate(["a", "b", "c"])]
    own_layout = format_store(poses)
    for left_out in (["b"], ["a", "b", "c"]):
        entries = [pose_to_dict(pose) for pose in poses]
        lines = own_layout.splitlines()
        for entry in entries:
            if entry["name"] in left_out:
                del entry["tcp_offset"]
                at = next(k for k, line in enumerate(lines) if f'"name": "{entry["name"]}"' in line)
                lines[at] = lines[at].replace('"tcp_offset": [0.0, 0.0, 0.1, 0.0, 0.0, 0.0], ', "")
        for text in (store_text_with(entries), "\n".join(lines) + "\n"):
            path = tmp_path / "poses.json"
            path.write_text(text)
            assert [pose.tcp_offset for pose in PoseStore(path).load()] == [
                (0.0,) * 6 if pose.name in left_out else tuple(tcp) for pose in poses], text
        assert store_format.pose_from_dict(entries[1], "pose 'b'").tcp_offset == (0.0,) * 6


def test_error_line_points_at_the_pose_in_the_store_layout(tmp_path):
    path = tmp_path / "poses.json"
    poses = [make_pose(name, i) for i, name in enumerate(["a", "b", "c"])]
    text = format_store(poses).replace('"joints": [', '"joints": [NaN, ', 1)  # corrupt pose 'a' on its line
    path.write_text(text)
    line = next(n for n, content in enumerate(text.splitlines(), 1) if '"name": "a"' in content)
    with pytest.raises(StoreError, match=rf"poses\.json:{line}: pose #1 'a': joints must be 6 numbers, got 7"):
        PoseStore(path).load()


@pytest.mark.parametrize("count", [7, 8, 9, 12, 13, 19])
def test_a_big_store_loads_whole_and_names_the_line_of_a_fault_past_the_first_chunk(tmp_path, count, monkeypatch):
    """ur3dq's own layout is parsed PARSED_LINES lines at a time and checked CHUNK entries at a time (both made
    small here: 3 and 8, so that a few poses cross their ends): every pose comes back in order on either side of
    those ends, and a fault in the last pose names its line."""
    monkeypatch.setattr(store_format, "CHUNK", 8)
    monkeypatch.setattr(store_format, "PARSED_LINES", 3)
    path = tmp_path / "poses.json"
    poses = [make_pose(f"p{i}", i % 7) for i in range(count)]
    text = format_store(poses)
    path.write_text(text)
    assert [pose.name for pose in PoseStore(path).load()] == [pose.name for pose in poses]
    lines = text.splitlines()
    lines[-3] = lines[-3].replace('"joints": [', '"joints": [1e3, ', 1)   # the last pose's line
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(StoreError, match=rf"poses\.json:{len(lines) - 2}: pose #{count} 'p{count - 1}': joints"):
        PoseStore(path).load()


@pytest.mark.parametrize("edit", ["two entries on one line", "an entry over two lines"])
def test_a_hand_edit_of_the_layout_still_loads_every_pose(tmp_path, edit):
    """A file that is no longer one entry per line (a hand edit) is read as a whole document: the same poses."""
    path = tmp_path / "poses.json"
    poses = [make_pose(f"p{i}", i) for i in range(6)]
    text = format_store(poses)
    if edit == "two entries on one line":
        text = text.replace('"},\n    {"name": "p3"', '"}, {"name": "p3"', 1)
    else:
        text = text.replace('"name": "p2", ', '"name": "p2",\n', 1)
    assert text != format_store(poses)
    path.write_text(text)
    assert [pose.name for pose in PoseStore(path).load()] == [f"p{i}" for i in range(6)]


def test_duplicate_names_in_a_file_are_refused(tmp_path):
    path = tmp_path / "poses.json"
    path.write_text(store_text_with([pose_to_dict(make_pose("a", 1)), pose_to_dict(make_pose("a", 2))]))
    with pytest.raises(StoreError, match="pose name 'a' appears twice"):
        PoseStore(path).load()
