"""The cell-program model (pure): step validation naming the step, relative waypoint resolution, planning, and the
one URScript program with its step reports and escaped user text."""
import gc

import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.plan import plan_program
from ur3dq.program.resolve import offset_pose, resolve_targets, select_range
from ur3dq.program.script import STEP_REGISTER, program_script
from ur3dq.program.steps import DigitalOut, Message, Motion, RelativeWaypoint, Wait, WaitInput, Waypoint

MODEL = robot_model("ur3")
Q_PICK = np.array([0.3, -1.2, 1.4, -1.8, -1.5708, 0.2])


LINEAR = Motion("linear", 0.1)


def pick_waypoint(joints=Q_PICK, motion=LINEAR):
    pose = Pose.from_dual_quaternion("pick", MODEL.fk(joints), "ur3", joints=tuple(joints))
    return Waypoint("pick", pose, motion)


@pytest.mark.parametrize("build, message", [
    (lambda: DigitalOut("grip", "standard", 8, True), r"step 'grip' \(digital-out\): standard pin 8 is out of range"),
    (lambda: DigitalOut("grip", "tool", 2, True), r"tool pin 2 is out of range \(0..1\)"),
    (lambda: Wait("pause", -1), r"step 'pause' \(wait\): seconds must be a finite number > 0"),
    (lambda: WaitInput("part", "standard", 0, True, float("nan")), r"step 'part' \(wait-input\): timeout"),
    (lambda: Message("say", "a\nb"), r"step 'say' \(message\): text contains control characters"),
    (lambda: pick_waypoint(motion=Motion("teleport")), r"motion: move 'teleport' is not one of joint, linear, process"),
    (lambda: pick_waypoint(motion=Motion("joint", blend=1e9)), r"blend must be a radius 0..1 m"),
    (lambda: pick_waypoint(motion=Motion("joint", speed=0)), r"speed must be a finite number > 0"),
    (lambda: RelativeWaypoint("up", "pick", note="\ud800"), r"step 'up' \(relative waypoint\): note holds a lone"),
    # float() reads both as numbers: a relative waypoint's offset holds JSON numbers only, as a pose's fields do
    (lambda: RelativeWaypoint("up", "pick", (0, 0, "0.1", 0, 0, 0)), r"offset must be 6 numbers, got '0.1' among them"),
    (lambda: RelativeWaypoint("up", "pick", (0, 0, True, 0, 0, 0)), r"offset must be 6 numbers, got True among them"),
])
def test_bad_steps_are_refused_naming_the_step(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def test_relative_waypoint_lands_at_its_tool_frame_offset_and_follows_its_base():
    pick = pick_waypoint()
    approach = RelativeWaypoint("approach", "pick", (0, 0, -0.05, 0, 0, 0), "tool")
    target = resolve_targets([approach, pick])["approach"].pose
    # the point 5 cm behind the TCP along its own z axis
    expected = pick.pose.dq.transform_point([0, 0, -0.05])
    assert np.linalg.norm(target.translation - expected) < 1e-7
    moved = pick_waypoint(Q_PICK + [0.2, 0.1, -0.1, 0, 0.1, 0])   # the base re-taught
    retaught = resolve_targets([approach, moved])["approach"].pose
    assert np.linalg.norm(retaught.translation - moved.pose.dq.transform_point([0, 0, -0.05])) < 1e-7
    base_frame = offset_pose(pick.pose.dq, (0, 0, 0.1, 0, 0, 0), "base")
    assert np.allclose(base_frame.translation, pick.pose.dq.translation + [0, 0, 0.1])


def test_cycles_and_missing_bases_name_the_step():
    with pytest.raises(ValueError, match=r"step 'a' \(relative waypoint\): relative waypoints form a cycle"):
        resolve_targets([RelativeWaypoint("a", "b"), RelativeWaypoint("b", "a")])
    with pytest.raises(ValueError, match=r"step 'a' \(relative waypoint\): its base waypoint 'gone'"):
        resolve_targets([RelativeWaypoint("a", "gone")])
    with pytest.raises(ValueError, match=r"its base 'w' is a wait step"):
        resolve_targets([Wait("w", 1), RelativeWaypoint("a", "w")])


def test_loading_planning_and_checking_a_program_leave_no_reference_cycle(tmp_path):
    """A big program's steps are freed by reference counting alone: its load, plan and path check build no
    reference cycle (a recursive closure in resolve_targets would keep every step alive until the cyclic collector
    ran)."""
    from ur3dq.cli.path_report import check_program
    from ur3dq.store import PoseStore

    store = PoseStore(tmp_path / "program.json")
    chain = [pick_waypoint(), RelativeWaypoint("above", "pick", (0, 0, -0.05, 0, 0, 0), "tool"),
             RelativeWaypoint("higher", "above", (0, 0, 0.02, 0, 0, 0), "base"), Wait("pause", 0.5),
             DigitalOut("grip", "standard", 0, True)]
    store.update_program(lambda steps: (chain, None))

    def load_plan_and_check() -> None:
        steps = store.load_program()
        plan = plan_program(MODEL, select_range(steps, "above", None), resolve_from=steps)
        result, _ = check_program(MODEL, plan, None, keep_samples=False)
        assert result.ok and len(plan) == 4

    # a first round fills the libraries' one-time caches (numba makes a few cyclic ctypes types on a kernel's
    # first call in a process), so the test does not depend on which tests ran before it
    load_plan_and_check()
    was = gc.isenabled()
    gc.collect()
    gc.disable()
    try:
        load_plan_and_check()
        assert gc.collect() == 0
    finally:
        (gc.enable if was else gc.disable)()


def test_plan_and_script_of_a_pick_and_place():
    steps = [RelativeWaypoint("approach", "pick", (0, 0, -0.05, 0, 0, 0), motion=Motion("joint", blend=0.02)),
             pick_waypoint(motion=Motion("linear", 0.05, blend=0.02)),
             DigitalOut("grip", "tool", 0, True), Wait("settle", 0.5),
             WaitInput("part", "standard", 3, True, 2.0),
             Message("say", 'picked "x" \\ [bold]end'),
             RelativeWaypoint("retract", "pick", (0, 0, -0.05, 0, 0, 0), motion=Motion("linear", 5.0))]
    plan = plan_program(MODEL, steps, start_joints=Q_PICK + 0.1)
    approach, pick, *_, retract = plan
    assert np.allclose(MODEL.fk(pick.joints).translation, steps[1].pose.dq.translation, atol=1e-9)
    assert approach.blend == 0.02 and pick.blend == 0.0      # an action follows pick: it must stop there
    assert retract.speed == 1.0 and retract.clamped          # 5 m/s clamped to the TCP limit
    script = program_script(plan, header=["a 'name' with \n newline"])
    lines = script.splitlines()
    assert lines[0].startswith("# a 'name' with ? newline")
    assert lines.count(f"  write_output_integer_register({STEP_REGISTER}, 3)") == 1
    assert f"  write_output_integer_register({STEP_REGISTER}, 8)" in lines   # done marker N + 1
    assert any(line.strip().startswith("movel([") and "v=0.05" in line for line in lines)
    assert '  textmsg("picked ?x? ? [bold]end")' in lines
    assert "  set_tool_digital_out(0, True)" in lines and "  sleep(0.5)" in lines
    assert "      halt" in lines and "while get_standard_digital_in(3) != True:" in script


def test_select_range_for_resume():
    steps = [Wait(f"w{i}", 1) for i in range(5)]
    assert [s.name for s in select_range(steps, "w1", "w3")] == ["w1", "w2", "w3"]
    with pytest.raises(ValueError, match="--to 'w0' comes before --from 'w2'"):
        select_range(steps, "w2", "w0")
    with pytest.raises(ValueError, match="--from 'nope': no step"):
        select_range(steps, "nope")


def test_step_watch_reports_progress_end_and_a_failed_wait_naming_the_step():
    from ur3dq.errors import ProgramError
    from ur3dq.program.runner import StepWatch, expected_seconds
    from ur3dq.robot.primary import TextMessage

    steps = [pick_waypoint(), Wait("settle", 0.5), WaitInput("part", "tool", 1, False, 3.0)]
    plan = plan_program(MODEL, steps, start_joints=Q_PICK + 0.1)
    seen = []
    watch = StepWatch(plan, first_position=4, progress=lambda position, step: seen.append((position, step.name)))
    for text in ("ur3dq_step:4", "ur3dq_step:4", "unrelated", "ur3dq_step:5", "ur3dq_step:6"):
        watch.note(TextMessage(text))
    assert seen == [(4, "pick"), (5, "settle"), (6, "part")] and not watch.done
    watch.note(TextMessage("ur3dq_step:7"))
    assert watch.done
    with pytest.raises(ProgramError, match=r"step 'part' \(wait-input\): input tool DI1 did not turn off within 3 s"):
        watch.note(TextMessage("ur3dq_fail:6"))
    assert expected_seconds(plan) >= plan[0].duration + 0.5 + 3.0


class _ArmAtRest:
    """A robot at rest whose state shows no output on (as a stale or a late stream may)."""

    def state(self):
        from types import SimpleNamespace

        return SimpleNamespace(joint_speeds=np.zeros(6), joints=Q_PICK, tcp_pose=np.zeros(6), age=0.01)

    def io_state(self):
        from types import SimpleNamespace

        return SimpleNamespace(outputs_on=lambda: [])


@pytest.mark.parametrize("ended", [True, False], ids=["its end seen", "its end not seen"])
def test_a_stop_without_the_programs_end_names_every_output_it_may_have_left_on(ended):
    """A frozen, late or dropped stream: the program may have run past the last step it reported (and switched the
    gripper on) while the state still shows the output off."""
    from ur3dq.program.runner import StepWatch, program_stop
    from ur3dq.robot.primary import KeyMessage, TextMessage

    steps = [pick_waypoint(), DigitalOut("grip", "tool", 0, True), Wait("settle", 0.5),
             DigitalOut("release", "tool", 0, False)]
    watch = StepWatch(plan_program(MODEL, steps, start_joints=Q_PICK + 0.1))
    watch.program_name = "ur3dq_program_1"
    watch.note(TextMessage("ur3dq_step:1"))
    if ended:
        watch.note(KeyMessage(0, 0, "PROGRAM_XXX_STOPPED", "ur3dq_program_1"))
    stop = program_stop(_ArmAtRest(), watch)
    assert (stop.position, stop.step_name) == (1, "pick")
    assert stop.outputs_text() == ("" if ended else "tool output 0 may still be on")
