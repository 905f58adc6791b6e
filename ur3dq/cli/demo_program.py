"""The cell-program part of `ur3dq demo`: a pick-and-place built on the recorded demo poses and run as one URScript
program (approach above the part, a linear descent, close the gripper, wait, a linear retract, place, open)."""
from __future__ import annotations

from rich.console import Console
from rich.markup import escape

from ur3dq.cli.display import print_table
from ur3dq.cli.program_workflow import PLAN_COLUMNS, plan_rows
from ur3dq.errors import RobotError
from ur3dq.program.runner import run
from ur3dq.program.steps import DigitalOut, Motion, RelativeWaypoint, Wait, Waypoint

APPROACH_M = 0.05   # the approach and retract stand this far back from the part along the tool's z axis
GRIPPER_PIN = 0     # tool digital output 0 closes the gripper


def pick_and_place_steps(store, program_store, pick: str, place: str) -> list:
    """Write the demo's cell program around the poses `pick` and `place` of `store` into `program_store` (a
    version-2 store, replacing what it held) and return its steps."""
    pick_pose, place_pose = store.get(pick), store.get(place)

    def edit(_):
        program = [
            RelativeWaypoint("approach", pick, (0, 0, -APPROACH_M, 0, 0, 0), "tool", Motion("joint")),
            Waypoint(pick, pick_pose, Motion("linear", 0.05, 0.5)),
            DigitalOut("close-gripper", "tool", GRIPPER_PIN, True),
            Wait("settle", 0.5),
            RelativeWaypoint("retract", pick, (0, 0, -APPROACH_M, 0, 0, 0), "tool", Motion("linear", 0.1, 0.5)),
            Waypoint(place, place_pose, Motion("joint")),
            DigitalOut("open-gripper", "tool", GRIPPER_PIN, False),
        ]
        return program, program

    return program_store.update_program(edit)


def run_pick_and_place(robot, store, program_store, pick: str, place: str, say) -> None:
    """Build the program into `program_store`, run it showing each step as the controller reports it, then its
    plan; RobotError if the arm does not end at `place`."""
    steps = pick_and_place_steps(store, program_store, pick, place)
    console_print = say

    def progress(position, step):
        console_print(escape(f"   step {position}: {step.name} ({step.kind})"))

    plan, seconds = run(robot, steps, progress=progress)
    print_table(_Printer(say), "Pick-and-place plan (one URScript program)", PLAN_COLUMNS, plan_rows(plan, 1))
    error_m, _ = robot.tcp_pose().distance(plan[-2].pose)
    if error_m > 5e-4:
        raise RobotError(f"the pick-and-place ended {error_m * 1000:.2f} mm from {place!r}")
    say(f"   ran {len(plan)} steps in {seconds:.2f} s; the arm rests at {place!r} "
        f"({error_m * 1000:.3f} mm)")


class _Printer:
    """A console-like wrapper so print_table can print through the demo's `say` (at the terminal's width)."""

    def __init__(self, say):
        self.print = say
        self.width = Console().width
