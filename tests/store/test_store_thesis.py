"""Import and export of the thesis' 8-coefficient text lines `q.w q.x q.y q.z 0 p.x p.y p.z`."""
from pathlib import Path

import numpy as np
import pytest
from pyquaternion import Quaternion

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import StoreError
from ur3dq.pose import Pose
from ur3dq.store import PoseStore, format_thesis_lines, parse_thesis_lines

# The thesis' home pose printout (§4.5): rotation (0, 0, 1, 0) up to sign, TCP at (0, -0.194, 0.694).
THESIS_HOME_LINE = "0 0 1 0 0 0 -0.194 0.694"


def test_parse_skips_blanks_and_comments_and_keeps_line_numbers():
    entries = parse_thesis_lines(f"# recorded poses\n\n{THESIS_HOME_LINE}  # home\n1 0 0 0 0 0.1 0.2 0.3\n", "f.txt")
    assert [line for line, _ in entries] == [3, 4]
    np.testing.assert_allclose(entries[0][1].translation, [0, -0.194, 0.694], atol=1e-12)
    np.testing.assert_allclose(entries[1][1].translation, [0.1, 0.2, 0.3], atol=1e-12)


@pytest.mark.parametrize("line", ["1 0 0 0 0 0 0", "1 0 0 0 0 0 0 x", "2 0 0 0 0 0 0 0", "1 0 0 0 0 nan 0 0"])
def test_bad_line_names_file_and_line(line):
    with pytest.raises(StoreError, match=r"^f\.txt:2: not a thesis pose line"):
        parse_thesis_lines(f"{THESIS_HOME_LINE}\n{line}\n", "f.txt")


def test_format_then_parse_round_trips():
    rng = np.random.default_rng(3)
    poses = [DualQuaternion.from_rotation_translation(Quaternion(rng.normal(size=4)).normalised,
                                                      rng.uniform(-1, 1, 3)) for _ in range(20)]
    text = format_thesis_lines(poses)
    assert len(text.splitlines()) == 20
    for pose, (_, back) in zip(poses, parse_thesis_lines(text, "mem")):
        assert back.is_close(pose, 1e-9, 1e-9)


def test_import_then_export_through_the_store(tmp_path):
    source = tmp_path / "recorded.txt"
    source.write_text(f"{THESIS_HOME_LINE}\n1 0 0 0 0 0.1 0.2 0.3\n")
    store = PoseStore(tmp_path / "poses.json")
    imported = store.import_thesis_lines(source, "ur3")
    assert [p.name for p in imported] == ["recorded-1", "recorded-2"]
    assert all(p.joints is None and p.robot_model == "ur3" for p in imported)
    assert "recorded.txt line 1" in imported[0].note
    again = store.import_thesis_lines(source, "ur3")   # a second import is numbered on, not refused
    assert [p.name for p in again] == ["recorded-3", "recorded-4"]

    target = tmp_path / "out.txt"
    assert store.export_thesis_lines(target, ["recorded-2", "recorded-1"]) == 2
    back = parse_thesis_lines(target.read_text(), "out.txt")
    assert back[0][1].is_close(imported[1].dq) and back[1][1].is_close(imported[0].dq)


def test_import_of_a_bad_file_adds_nothing(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    store.add(Pose.from_dual_quaternion("keep", DualQuaternion.identity(), "ur3"))
    before = (tmp_path / "poses.json").read_bytes()
    bad = tmp_path / "bad.txt"
    bad.write_text(f"{THESIS_HOME_LINE}\nnot numbers\n")
    with pytest.raises(StoreError, match=r"bad\.txt:2:"):
        store.import_thesis_lines(bad, "ur3")
    empty = tmp_path / "empty.txt"
    empty.write_text("# nothing\n")
    with pytest.raises(StoreError, match="no pose lines"):
        store.import_thesis_lines(empty, "ur3")
    assert (tmp_path / "poses.json").read_bytes() == before


def test_the_shipped_examples_load_and_agree():
    examples = Path(__file__).resolve().parents[2] / "poses"
    poses = PoseStore(examples / "example-poses.json").load()
    lines = parse_thesis_lines((examples / "thesis-poses.txt").read_text(), "thesis-poses.txt")
    assert len(poses) == len(lines) >= 3
    for pose, (_, line_pose) in zip(poses, lines):
        assert pose.joints is not None and line_pose.is_close(pose.dq, 1e-12, 1e-12)
