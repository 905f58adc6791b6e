"""The two steps a PolyScope import brings: a comment (a note that does nothing, across which a waypoint keeps its
blend) and a kept script (URScript run as it is, marked in the program); both stored and read back."""
import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.plan import plan_program
from ur3dq.program.script import program_script
from ur3dq.program.steps import Comment, DigitalOut, KeptScript, Motion, Wait, Waypoint, describe
from ur3dq.store import PoseStore

MODEL = robot_model("ur3")
HOME = np.array([0.3, -1.2, 1.4, -1.8, -1.5708, 0.2])


def waypoint(name, dq, blend=0.02):
    q = HOME + dq
    return Waypoint(name, Pose.from_dual_quaternion(name, MODEL.fk(q), "ur3", joints=tuple(q)),
                    Motion("joint", blend=blend))


def test_a_waypoint_keeps_its_blend_across_comments_but_not_before_an_action():
    steps = [waypoint("a", 0), Comment("note", "then b"), Comment("Folder 2", "Folder 2"),
             waypoint("b", np.full(6, 0.1)), DigitalOut("grip", "tool", 0, True), waypoint("c", np.full(6, 0.2)),
             Comment("end", "the end")]
    blends = {p.name: p.blend for p in plan_program(MODEL, steps) if p.joints is not None}
    assert blends == {"a": 0.02, "b": 0.0, "c": 0.0}


def test_a_program_of_actions_alone_plans():
    plan = plan_program(MODEL, [Wait("pause", 1.0), Comment("why", "settle")])
    assert [p.joints for p in plan] == [None, None]


def test_the_script_writes_comments_as_comments_and_kept_lines_as_they_are_marked_as_kept():
    kept = KeptScript("If digital_in[0]", 'if (get_standard_digital_in(0)):\n  popup("hi")\nend',
                      "cell.urp: Robot Program/If digital_in[0]")
    text = program_script(plan_plain([Comment("note", 'say "hi"\u00e9'), kept]))
    assert '  # say "hi"?\n' in text
    assert ("  # URScript kept from cell.urp: Robot Program/If digital_in[0]: run as it is, not path-checked\n"
            "  if (get_standard_digital_in(0)):\n    popup(\"hi\")\n  end\n") in text
    assert describe(kept) == "URScript kept from cell.urp: Robot Program/If digital_in[0] (3 lines, not path-checked)"


def plan_plain(steps):
    return plan_program(MODEL, steps)


@pytest.mark.parametrize("build, message", [
    (lambda: Comment("c", "line\nbreak"), r"step 'c' \(comment\): text contains control characters"),
    (lambda: Comment("c", "x" * 1001), r"text must be text of at most 1000 characters"),
    (lambda: KeptScript("k", "  ", "a.urp: X"), r"step 'k' \(kept-script\): script must be non-empty"),
    (lambda: KeptScript("k", "x" * (1024 * 1024 + 1), "a.urp"), r"script is larger than 1024 KiB"),
    (lambda: KeptScript("k", "halt", "\ud800"), r"origin holds a lone UTF-16 surrogate"),
])
def test_bad_comment_and_kept_steps_are_refused_naming_the_step(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def test_both_are_stored_and_read_back(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    steps = [waypoint("a", 0), Comment("note", "a note: \"quoted\" é"),
             KeptScript("kept", "thread T():\n  sync()\nend\nrun T()", "cell.urp: Thread_1")]
    store.update_program(lambda old: (steps, None))
    assert store.load_program() == steps
    assert store.version() == 2
