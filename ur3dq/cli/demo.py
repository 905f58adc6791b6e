"""`ur3dq demo`: the whole job against a simulator it starts itself: record poses, replay them, then run a
pick-and-place cell program built on them (approach above the part, a linear descent, close the gripper, wait, a
linear retract, place, open)."""
from __future__ import annotations

import contextlib
import math
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np
from rich.console import Console
from rich.markup import escape

from ur3dq.cli.app import EXIT_NOT_REACHED, Settings, cli, emit_json, refuse_store_file
from ur3dq.cli.background_simulator import SimulatorError
from ur3dq.cli.display import angles_text, plan_table, pose_vector_text, print_table, progress_bar, reached_table
from ur3dq.cli.library_output import own_output
from ur3dq.cli.options import Quantity, display_options, or_default, speed_and_acceleration
from ur3dq.cli.program_workflow import plan_columns, plan_rows
from ur3dq.errors import RobotError
from ur3dq.program.runner import run
from ur3dq.program.steps import DigitalOut, Motion, RelativeWaypoint, Step, Wait, Waypoint
from ur3dq.replay import Reached, execute_plan, plan_replay, read_pose
from ur3dq.store import PoseStore
from ur3dq.units import ANGULAR_ACCELERATION, ANGULAR_SPEED, Units

if TYPE_CHECKING:   # the driver loads both client libraries: imported only when a robot command runs
    from ur3dq.robot import Robot

# Where the demo parks the arm and the places it records (rad): distinct, comfortably reachable, away from the
# wrist singularity (wrist 2 ≠ 0, π), and each within π of the last so no move is refused for its travel.
DEMO_PARK = (0.0, -math.pi / 2, 0.0, -math.pi / 2, 0.0, 0.0)
DEMO_SPEED = 1.5         # rad/s: brisk enough for a demo, slow enough to watch
DEMO_ACCELERATION = 3.0  # rad/s²
DEMO_PLACES = (
    (0.0, -1.2, 1.0, -1.4, -1.57, 0.0),
    (0.8, -1.0, 1.3, -1.9, -1.57, 0.5),
    (-0.7, -1.6, 1.6, -1.6, -1.57, -0.3),
    (0.3, -0.8, 0.7, -1.5, -1.2, 1.0),
)


@cli.command(short_help="The whole job on a simulator of its own.")
@click.option("--save", type=click.Path(dir_okay=False, path_type=Path),
              help="Keep the demo's pose store in this file (default: a temporary one, removed afterwards).")
@click.option("--speed", type=Quantity(ANGULAR_SPEED), default=None, metavar="V",
              help="movej speed, e.g. 60deg/s (bare: rad/s, °/s under --deg) [default: 1.5 rad/s].")
@click.option("--acceleration", type=Quantity(ANGULAR_ACCELERATION), default=None, metavar="A",
              help="movej acceleration, e.g. 150deg/s^2 [default: 3 rad/s²].")
@click.option("--tolerance-mm", type=float, default=0.5, show_default=True,
              help="A replayed pose counts as reached within this distance.")
@click.option("--tolerance-deg", type=float, default=0.1, show_default=True,
              help="... and within this rotation.")
@display_options
@click.pass_obj
def demo(settings: Settings, save: Path | None, speed: float | None, acceleration: float | None,
         tolerance_mm: float, tolerance_deg: float) -> None:
    """Run the whole job on a simulator: record poses, replay them, run a cell program.

    The whole job against a simulator it starts itself: power on, release the brakes, move the arm to a few
    places and record each into a pose store, park the arm, replay the store (IK nearest the recorded joints,
    as run-poses does), and show where the arm ended vs where each pose was recorded.

    Exits 0 only if every replayed pose was reached within tolerance (else 7).

    \b
    Examples:
      ur3dq demo
      ur3dq --model ur5e demo --save demo-poses.json
    """
    from sim_ursim.launch import simulator_process
    from ur3dq.robot import connect

    # with --json the story goes to stderr, so stdout carries only the JSON result
    story = Console(stderr=True, highlight=False) if settings.json else settings.out
    say = story.print
    model_name = settings.model or "ur3"
    with tempfile.TemporaryDirectory(prefix="ur3dq-demo-") as scratch, contextlib.ExitStack() as stack:
        store = PoseStore(save or Path(scratch) / "demo-poses.json")
        program_store = PoseStore(store.path.with_name(store.path.stem + "-program.json"))
        for written in (store.path, program_store.path):
            refuse_store_file(settings, written)
        say(f"[bold]1.[/bold] Starting the embedded simulator (sim_ursim, {model_name}) ...")
        try:
            simulator = stack.enter_context(simulator_process(model=model_name))
        except (RuntimeError, TimeoutError) as error:
            raise SimulatorError(f"the embedded simulator did not start: {error}") from None
        stack.enter_context(own_output())
        with connect(simulator.host, model=model_name) as robot:
            say(f"   serving on {simulator.host}; powering on and releasing the brakes")
            robot.power_on()
            robot.brake_release()
            a, v = speed_and_acceleration(robot.model, or_default(speed, DEMO_SPEED),
                                          or_default(acceleration, DEMO_ACCELERATION), Console(stderr=True),
                                          settings.units)
            say(f"[bold]2.[/bold] Moving the arm to {len(DEMO_PLACES)} places and recording each into "
                f"{escape(str(store.path))}")
            recorded = _record_places(robot, store, a, v, say, settings.units)
            say(f"[bold]3.[/bold] Parking the arm at {angles_text(DEMO_PARK, settings.units)}")
            robot.movej(np.array(DEMO_PARK), a=a, v=v)
            say("[bold]4.[/bold] Replaying the store as run-poses does (IK of each dual quaternion, FK-checked)")
            steps = plan_replay(robot.model, store.select(recorded), robot.joints(), a, v)
            say(plan_table(steps, settings.units, "Plan", settings.out.width))
            with progress_bar(Console(stderr=True)) as progress:
                results = execute_plan(robot, steps, a, v, 0.0, 1, progress)
            say("[bold]5.[/bold] A cell program from the same store: approach, linear descent, gripper output, "
                "wait, linear retract, place")
            say(escape(f"   written to {program_store.path} (run it again with `ur3dq --store {program_store.path} "
                       "run-poses`)"))
            run_pick_and_place(robot, store, program_store, recorded[0], recorded[1], story)
    _report(settings, results, say, tolerance_mm, tolerance_deg, save)


def _record_places(robot: Robot, store: PoseStore, a: float, v: float, say: Callable[..., None],
                   units: Units) -> list[str]:
    """Move to each of DEMO_PLACES and record it into `store`; the names recorded."""
    recorded = []
    for index, place in enumerate(DEMO_PLACES, start=1):
        robot.movej(np.array(place), a=a, v=v)
        stored = store.add(read_pose(robot, f"demo-{index}", note="recorded by ur3dq demo"), number_if_taken=True)
        recorded.append(stored.name)
        say(f"   recorded {stored.name} at TCP {pose_vector_text(stored.ur_pose, units)}")
    return recorded


def _report(settings: Settings, results: list[Reached], say: Callable[..., None], tolerance_mm: float,
            tolerance_deg: float, save: Path | None) -> None:
    """Show where the arm ended vs each recorded pose; exit EXIT_NOT_REACHED if any missed the tolerance."""
    missed = [r for r in results
              if r.error_m * 1000 > tolerance_mm or math.degrees(r.error_rad) > tolerance_deg]
    if settings.json:
        emit_json({"reached": [{"pose": r.step.pose.name, "error_m": r.error_m, "error_rad": r.error_rad}
                               for r in results], "missed": [r.step.pose.name for r in missed]})
    else:
        say(reached_table(results, "6. Where the arm ended vs where each pose was recorded", settings.out.width))
    if missed:
        click.echo(f"Error: {len(missed)} of {len(results)} poses missed the tolerance of {tolerance_mm} mm / "
                   f"{tolerance_deg}°: {', '.join(r.step.pose.name for r in missed)}", err=True)
        click.get_current_context().exit(EXIT_NOT_REACHED)
    if not settings.json:
        say(f"[green]Every pose reached within {tolerance_mm} mm / {tolerance_deg}°.[/green]"
            + (escape(f" The poses are in {save}.") if save else ""))


APPROACH_M = 0.05   # the approach and retract stand this far back from the part along the tool's z axis
GRIPPER_PIN = 0     # tool digital output 0 closes the gripper


def pick_and_place_steps(store: PoseStore, program_store: PoseStore, pick: str, place: str) -> list[Step]:
    """Write the demo's pick-and-place cell program and return its steps.

    Write the demo's cell program around the poses `pick` and `place` of `store` into `program_store` (a
    version-2 store, replacing what it held) and return its steps."""
    pick_pose, place_pose = store.get(pick), store.get(place)

    def edit(_: list[Step]) -> tuple[list[Step], list[Step]]:
        program: list[Step] = [
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


def run_pick_and_place(robot: Robot, store: PoseStore, program_store: PoseStore, pick: str, place: str,
                       console: Console) -> None:
    """Build and run the demo's pick-and-place program, showing each step on `console`.

    The program goes into `program_store`; each step is shown as the controller reports it, then the plan.
    RobotError if the arm does not end at `place`.
    """
    steps = pick_and_place_steps(store, program_store, pick, place)
    say = console_print = console.print

    def progress(position: int, step: Step) -> None:
        console_print(escape(f"   step {position}: {step.name} ({step.kind})"))

    plan, seconds = run(robot, steps, progress=progress)
    print_table(console, "Pick-and-place plan (one URScript program)", plan_columns(Units()),
                plan_rows(plan, 1, Units()))
    place_pose = plan[-2].pose   # the place waypoint's, before the gripper opens
    assert place_pose is not None, "the program's last waypoint is the place"
    error_m, _ = robot.tcp_pose().distance(place_pose)
    if error_m > 5e-4:
        raise RobotError(f"the pick-and-place ended {error_m * 1000:.2f} mm from {place!r}")
    say(f"   ran {len(plan)} steps in {seconds:.2f} s; the arm rests at {place!r} "
        f"({error_m * 1000:.3f} mm)")
