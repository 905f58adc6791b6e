"""`ur3dq move-to NAME`: move the arm to one recorded pose — planned, its whole path checked, asked, watched."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click
from rich.console import Console
from rich.markup import escape

from ur3dq.cli.app import Settings, cli, confirm, emit_json, robot_session, solving_poses
from ur3dq.cli.options import cell_option, display_options
from ur3dq.cli.path_report import check_program, check_verdict, require_passed
from ur3dq.cli.run_session import where_text
from ur3dq.cli.tcp_check import aimed_pose, steps_for_the_current_tcp, tcp_option
from ur3dq.errors import NotReachedError, StoreError
from ur3dq.program.plan import Defaults, PlannedStep, plan_program
from ur3dq.program.runner import run_plan
from ur3dq.program.steps import is_waypoint
from ur3dq.units import ANGLE, LENGTH, SPEED, Units, angular_kind, show

if TYPE_CHECKING:
    from ur3dq.robot import Robot

REACHED_M = 1e-3     # a move to a pose that ends further than this from where it aimed the TCP did not reach it
REACHED_RAD = 1e-2


@cli.command("move-to", short_help="Move the arm to one recorded pose (checked, asked).")
@click.argument("name")
@click.option("--yes", "-y", is_flag=True, help="Move without asking.")
@click.option("--speed-scale", type=click.FloatRange(0.0, 1.0, min_open=True), default=1.0, show_default=True,
              metavar="F", help="Scale the move's speed by F (0 < F ≤ 1).")
@tcp_option
@cell_option
@display_options
@click.pass_obj
def move_to(settings: Settings, name: str, yes: bool, speed_scale: float, tcp_choice: str | None,
            cell_path: Path | None) -> None:
    """Move the arm to the recorded pose NAME (a waypoint or relative waypoint of the store).

    The target is planned from where the arm is (the IK solution nearest the pose's recorded joints), by the
    waypoint's own move type and speed (a joint move at URScript's default speed for a plain pose); the whole
    path is checked from the arm's joints (in --cell if given) before the question, which defaults to No. If the
    controller's TCP offset changed since the pose was taught, that is said and --tcp recorded or --tcp current
    is required. Ctrl-C stops the arm. A move that ends more than 1 mm or 0.01 rad from where it aimed the TCP
    exits 7.

    \b
    Examples:
      ur3dq move-to pick
      ur3dq move-to approach --speed-scale 0.25 --cell cell.json
    """
    steps = settings.store.load_program()
    step = next((candidate for candidate in steps if candidate.name == name), None)
    if step is None:
        raise StoreError(f"no pose named {name!r} in {settings.store_path}: `ur3dq poses list` shows them")
    if not is_waypoint(step):
        raise click.UsageError(f"step {name!r} is a {step.kind}, not a pose: move-to takes a waypoint")
    solving_poses(1)
    with robot_session(settings) as robot:
        err = Console(stderr=True, highlight=False)
        steps = steps_for_the_current_tcp(steps, [name], robot.model.tcp, tcp_choice, False, err)
        step = steps[[candidate.name for candidate in steps].index(name)]
        plan = plan_program(robot.model, [step], robot.joints(), Defaults(), speed_scale,
                            max_joint_travel=robot.max_joint_travel, resolve_from=steps)
        err.print(escape(move_summary(plan[0], settings)), soft_wrap=True)
        result, _ = check_program(robot.model, plan, cell_path, robot.joints(), keep_samples=False)
        err.print(escape(check_verdict(result, cell_path)), soft_wrap=True)
        if result is not None:
            require_passed(settings, result)
        confirm(f"Move the arm to {name!r}?", yes, default=False)
        seconds = _run(settings, robot, plan, steps.index(step) + 1)
        taught = plan[0].pose
        assert taught is not None, "a planned waypoint has its pose"
        target = aimed_pose(taught, plan[0].tcp_offset, robot.model.tcp)
        metres, radians = robot.tcp_pose().distance(target)
    off_m = target.distance(taught)[0]
    if settings.json:
        emit_json({"moved_to": name, "seconds": seconds, "error_m": metres, "error_rad": radians,
                   "target_from_recorded_m": off_m})
    else:
        aimed = "it" if off_m < 1e-4 else f"where it was aimed (the flange where it was taught: the TCP aimed " \
            f"{show(off_m, LENGTH, _mm(settings), 1)} from the pose)"
        click.echo(f"At {name!r}: the TCP is {show(metres, LENGTH, _mm(settings), 3)} and "
                   f"{show(radians, ANGLE, settings.units, 4)} from {aimed} ({seconds:.2f} s).")
    if metres > REACHED_M or radians > REACHED_RAD:
        raise NotReachedError(f"the move to {name!r} ended {show(metres, LENGTH, _mm(settings), 3)} and "
                              f"{show(radians, ANGLE, settings.units, 4)} from where it aimed the TCP (more than "
                              f"{show(REACHED_M, LENGTH, _mm(settings), 0)} or "
                              f"{show(REACHED_RAD, ANGLE, settings.units, 3)}): check the "
                              "TCP offset and the arm (`ur3dq status`)")


def _run(settings: Settings, robot: Robot, plan: list[PlannedStep], position: int) -> float:
    """Run the planned move (the program's step `position`); one that ends early says where the arm came to rest
    (as run-poses does) before its error leaves."""
    try:
        return run_plan(robot, plan, position)
    except BaseException as error:
        stop = getattr(error, "program_stop", None)
        if stop is not None:
            err = Console(stderr=True, highlight=False)
            err.print(escape(f"Stopped during the move to {plan[0].step.name!r}."), soft_wrap=True)
            err.print(where_text(stop, settings.deg), soft_wrap=True)
        raise


def move_summary(planned: PlannedStep, settings: Settings) -> str:
    """One line saying how the arm will go: the move type, speed, the largest joint travel and the time."""
    assert planned.speed is not None and planned.move is not None   # a waypoint's PlannedStep has both
    speed = show(planned.speed, SPEED[angular_kind(planned.move)], settings.units)
    travel = "" if planned.travel is None else \
        f", the largest joint turning {show(planned.travel, ANGLE, settings.units, 3)}"
    time = "" if planned.duration is None else f", about {planned.duration:.1f} s at 100 %"
    return f"Move to {planned.step.name!r}: a {planned.move} move at {speed}{travel}{time}, from where the arm is."


def _mm(settings: Settings) -> Units:
    """The user's units with lengths in mm: a reached distance is read in mm."""
    return Units(angle=settings.units.angle, length="mm")
