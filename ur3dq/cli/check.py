"""`ur3dq check`: the whole-path check of the stored poses (ur3dq.pathcheck) before anything moves; the adapter
from a replay plan to the check's input and the margins table are in path_report.py."""
from __future__ import annotations

import math
from pathlib import Path

import click

from ur3dq.cli.app import Settings, cli, emit_json, make_error_console, robot_session, solving_poses
from ur3dq.cli.background_simulator import running_simulator_host
from ur3dq.cli.display import recorded_joints_warnings
from ur3dq.cli.options import SMALL_LENGTH, Typed, TypedValue, cell_option, display_options
from ur3dq.cli.path_report import (
    DEFAULT_JOINT_ACCELERATION,
    DEFAULT_JOINT_SPEED,
    DEFAULT_LINEAR_ACCELERATION,
    DEFAULT_LINEAR_SPEED,
    margins_legend,
    margins_table,
    path_plan_from_replay,
    require_passed,
)
from ur3dq.cli.plan_warnings import plan_warnings
from ur3dq.errors import StoreError
from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import MOVE_TYPES, Margins, check_path, load_cell
from ur3dq.program.path import path_plan_of
from ur3dq.program.plan import plan_program
from ur3dq.replay import plan_replay
from ur3dq.store_format import PROGRAM_SCHEMA_VERSION
from ur3dq.units import ANGULAR_SPEED, LINEAR_SPEED


@cli.command("check", short_help="Check the whole path against the cell, no motion.")
@click.argument("names", nargs=-1)
@cell_option
@click.option("--move", type=click.Choice(MOVE_TYPES), default="joint", show_default=True,
              help="How the arm goes to each pose (joint = movej, linear = movel, process = movep).")
@click.option("--speed", type=Typed([ANGULAR_SPEED, LINEAR_SPEED]), default=None, metavar="V",
              help=f"Joint moves: e.g. 60deg/s [{DEFAULT_JOINT_SPEED} rad/s]; linear/process: e.g. 250mm/s "
                   f"[{DEFAULT_LINEAR_SPEED * 1000:g} mm/s].")
@click.option("--blend", type=SMALL_LENGTH, default=0.0, metavar="R",
              help="Blend radius between moves, e.g. 10mm [default: 0].")
@click.option("--margin", type=SMALL_LENGTH, default=None, metavar="D",
              help="Clearance kept from the cell, e.g. 20mm [default: the cell file's].")
@click.option("--self-margin", type=SMALL_LENGTH, default=0.0, metavar="D",
              help="Clearance between the arm's own links [default: 0 mm].")
@click.option("--wrist", type=float, default=Margins.wrist, show_default=True, help="Smallest |sin θ5| on a line.")
@click.option("--elbow", type=float, default=Margins.elbow, show_default=True, help="Smallest |sin θ3| on a line.")
@click.option("--shoulder", type=SMALL_LENGTH, default=Margins.shoulder, metavar="D",
              help=f"Smallest wrist-centre distance from the base axis on a line [default: "
                   f"{Margins.shoulder * 1000:g} mm].")
@click.option("--joints", "replay_joints", is_flag=True, help="Check the recorded joint angles instead of IK.")
@display_options
@click.pass_obj
def check(settings: Settings, names: tuple[str, ...], cell_path: Path | None, move: str,
          speed: TypedValue | None, blend: float, margin: float | None, self_margin: float, wrist: float,
          elbow: float, shoulder: float, replay_joints: bool) -> None:
    """Check the whole path through the stored poses (all, or NAMES) before the arm moves.

    Every move is sampled as the controller runs it (≤ 1 mm of TCP, ≤ 0.5° of any joint between samples) and each
    sample is checked: reachable, no IK branch flip, singularity margins (lines only), joint limits and speeds,
    self-collision of the link capsules and the tool, and the cell's floor and boxes. With a robot (--host, or the
    embedded simulator running) the path starts at the arm's joints; without one, at the first pose.
    A cell program (a version-2 store, no NAMES) is checked as run-poses runs it: each waypoint's own move type,
    speed, blend and TCP (--move, --speed and --blend then only apply to NAMES).
    Exit code 4 when a check fails, with one line naming the step, where, what failed and a fix.

    \b
    Examples:
      ur3dq check --cell cell.json
      ur3dq check pick place --move linear --speed 100mm/s --json
    """
    poses = settings.store.select(names)
    if not poses:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    cartesian = move != "joint"
    speed_si = speed.si(LINEAR_SPEED if cartesian else ANGULAR_SPEED) if speed is not None else (
        DEFAULT_LINEAR_SPEED if cartesian else DEFAULT_JOINT_SPEED)
    acceleration = DEFAULT_LINEAR_ACCELERATION if cartesian else DEFAULT_JOINT_ACCELERATION
    for option, value in (("--speed", speed_si), ("--blend", blend)):
        if not (math.isfinite(value) and (value > 0 or (option == "--blend" and value == 0))):
            raise ValueError(f"{option} must be a number {'≥' if option == '--blend' else '>'} 0, got {value!r}")
    margins = Margins(cell=margin, self_collision=self_margin, wrist=wrist, elbow=elbow, shoulder=shoulder)
    cell = load_cell(cell_path) if cell_path else None
    if settings.host or running_simulator_host():
        with robot_session(settings) as robot:
            model, start = robot.model, robot.joints()
            where = f"the {robot.model_name} at {robot.host}, from the arm's joints"
    else:
        model, start = robot_model(settings.model or poses[0].robot_model), None
        where = f"a nominal {model.name} (no robot: from the first pose)"
    # a cell program is checked with its own moves: as many steps as run-poses plans, relative waypoints included
    program = settings.store.load_program() if settings.store.version() == PROGRAM_SCHEMA_VERSION and not names \
        else None
    solving_poses(len(poses if program is None else program), model)
    for line in recorded_joints_warnings(poses, model):
        click.echo(line, err=True)
    if program is not None:
        plan = plan_program(model, program, start, replay_recorded_joints=replay_joints)
        for line in plan_warnings(plan, settings.units):
            click.echo(f"Warning: {line}", err=True)
        path = path_plan_of(plan, start)
        if path is None:
            raise StoreError(f"the cell program in {settings.store_path} has no waypoint: nothing moves")
    else:
        steps = plan_replay(model, poses, start, replay_recorded_joints=replay_joints)
        path = path_plan_from_replay(steps, start, move, speed_si, acceleration, blend)
    result = check_path(model, path, cell, margins, keep_samples=False)   # a table and lines: no drawing
    err = make_error_console()
    title = f"Path check on {where}{f', cell {cell_path}' if cell_path else ''}: the worst point of each move"
    console = err if settings.json else settings.out
    console.print(margins_table(result, title, console.width))
    console.print(margins_legend(result), markup=False)
    if settings.json:
        emit_json({**result.to_dict(), "limits": result.limits})
    require_passed(settings, result)   # each problem once, then the one-line error
    if not settings.json:
        settings.out.print(result.summary(settings.units))
