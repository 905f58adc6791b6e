"""Pose validation and the naming helpers."""
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyquaternion import Quaternion

from ur3dq.dualquat import DualQuaternion
from ur3dq.pose import (
    Pose,
    check_pose_text_fields,
    name_problem,
    next_free_name,
    numbering_prefix,
    text_fields_all_valid,
    utc_now_iso,
)

A_POSE = DualQuaternion.from_rotation_translation(Quaternion(axis=[0, 0, 1], angle=0.5), [0.1, -0.2, 0.3])


def test_from_dual_quaternion_derives_the_ur_pose_vector():
    pose = Pose.from_dual_quaternion("a", A_POSE, "ur3")
    np.testing.assert_allclose(pose.ur_pose, [0.1, -0.2, 0.3, 0, 0, 0.5], atol=1e-12)
    assert pose.dq.is_close(A_POSE)
    assert pose.joints is None and pose.tcp_offset == (0.0,) * 6 and pose.note == ""


def test_the_negated_dual_quaternion_is_the_same_pose():
    negated = DualQuaternion.from_array(-A_POSE.to_array())
    pose = Pose(name="a", time=utc_now_iso(), robot_model="ur3", dual_quaternion=tuple(negated.to_array()),
                ur_pose=tuple(A_POSE.to_ur_pose()))
    assert pose.dq.is_close(A_POSE)


def test_utc_now_iso_is_iso_8601_utc_with_z():
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", utc_now_iso())


@pytest.mark.parametrize("name, problem", [
    ("pick", None), ("pick up 1 ñ", None), ("", "empty"), (" pick", "blanks"), ("a\nb", "control"),
    ("x" * 101, "longer than 100"), (7, "must be text"),
])
def test_name_problem(name, problem):
    found = name_problem(name)
    assert (found is None) if problem is None else (problem in found)


def test_bad_name_is_refused_on_construction():
    with pytest.raises(ValueError, match="control characters"):
        Pose.from_dual_quaternion("a\x00", A_POSE, "ur3")


def test_bad_joints_name_the_pose():
    with pytest.raises(ValueError, match=r"pose 'a': joints contains NaN"):
        Pose.from_dual_quaternion("a", A_POSE, "ur3", joints=[0, 0, float("nan"), 0, 0, 0])


@pytest.mark.parametrize("joints", [["0.1"] * 6, [0.1] * 5 + [True], np.ones(6, dtype=bool)])
def test_text_and_bools_are_not_joint_angles(joints):
    # float() and numpy read "0.1" and True as numbers; a script passing them has a bug to hear about.
    with pytest.raises(ValueError, match=r"pose 'a': joints must be 6 numbers, got"):
        Pose.from_dual_quaternion("a", A_POSE, "ur3", joints=joints)


def test_renamed_keeps_everything_else():
    pose = Pose.from_dual_quaternion("a", A_POSE, "ur3", joints=[0.1] * 6, note="n")
    other = pose.renamed("b")
    assert other.name == "b" and other.joints == pose.joints and other.note == "n" and other.time == pose.time


@pytest.mark.parametrize("prefix, taken, expected", [
    ("pose", [], "pose-1"), ("pose", ["pose", "pose-1", "pose-7", "posey-9", "pose-x"], "pose-8"),
    ("a-b", ["a-b-2"], "a-b-3"),
])
def test_next_free_name(prefix, taken, expected):
    assert next_free_name(prefix, taken) == expected


@pytest.mark.parametrize("name, prefix", [("pose-12", "pose"), ("pose", "pose"), ("-3", "-3"), ("a-b", "a-b")])
def test_numbering_prefix(name, prefix):
    assert numbering_prefix(name) == prefix


_GOOD = (st.sampled_from(["a", "pick 1", "x" * 100, "ok-name"]),                        # name
         st.sampled_from(["2026-11-22T01:02:03.456Z", "2026-11-22T01:02:03+00:00"]),     # time
         st.sampled_from(["ur3", "ur5e"]),                                               # robot_model
         st.sampled_from([None, "2019-0001"]),                                           # robot_serial
         st.sampled_from(["", "a note"]))                                                # note
_BAD = (st.sampled_from([" lead", "trail ", "", "x" * 101, "tab\there", "bell\x07", "\ud800", "\u200bzero", 3]),
        st.sampled_from(["2026-11-22T01:02:03+01:00", "2026-11-22T01:02:03", "2026-13-22T01:02:03Z", "now", 5]),
        st.sampled_from(["UR3", "ur4", 3, None]),
        st.sampled_from([7, "\ud800", "bell\x07"]),
        st.sampled_from([None, 7, "\ud800"]))


def _passes(fields) -> bool:
    try:
        check_pose_text_fields(*fields)
    except ValueError:
        return False
    return True


@pytest.mark.parametrize("field", range(5))
@given(data=st.data())
@settings(max_examples=100, deadline=None)
def test_the_bulk_text_check_passes_only_poses_each_check_passes(field, data):
    poses = [[data.draw(good) for good in _GOOD] for _ in range(data.draw(st.integers(1, 4)))]
    if data.draw(st.integers(0, 3)):   # mostly one field of one pose at fault, else all sound
        poses[data.draw(st.integers(0, len(poses) - 1))][field] = data.draw(_BAD[field])
    assert text_fields_all_valid(*(list(column) for column in zip(*poses))) == all(map(_passes, poses))


def test_the_bulk_text_check_leaves_non_ascii_text_to_the_pose_by_pose_check():
    for name, serial, note in (("pós", None, ""), ("a", "série", ""), ("a", None, "nötë")):
        assert _passes((name, utc_now_iso(), "ur3", serial, note))
        assert not text_fields_all_valid([name], [utc_now_iso()], ["ur3"], [serial], [note])


def test_the_bulk_text_check_passes_a_recorded_store():
    names = [f"pose-{i}" for i in range(1000)]
    assert text_fields_all_valid(names, [utc_now_iso()] * 1000, ["ur3"] * 1000, [None, "2019-0001"] * 500,
                                 ["", "a note"] * 500)
