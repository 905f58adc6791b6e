"""`ur3dq check`: the whole-path check of the stored poses (ur3dq.pathcheck) before anything moves.

The adapter from today's replay plan (ur3dq.cli.plan) to the path check's input is `path_plan_from_replay`: one
segment per planned pose, the planned joints as targets, every move of the chosen type.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from ur3dq.cli.app import Settings, cli, display_options, emit_json, robot_session
from ur3dq.cli.plan import plan_replay
from ur3dq.cli.simstate import running_simulator_host
from ur3dq.errors import SafetyCheckError, StoreError
from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import MOVE_TYPES, Margins, PathPlan, PathSegment, check_path, load_cell

DEFAULT_JOINT_SPEED = 1.05     # rad/s (movej's default)
DEFAULT_LINEAR_SPEED = 0.25    # m/s (movel's default)
DEFAULT_JOINT_ACCELERATION = 1.4
DEFAULT_LINEAR_ACCELERATION = 1.2
MARGIN_COLUMNS = (("wrist", "|sin θ5|", 1.0), ("elbow", "|sin θ3|", 1.0), ("shoulder", "shoulder mm", 1000.0),
                  ("joint_limit", "limit °", math.degrees(1.0)), ("joint_speed", "speed room", 1.0),
                  ("self_collision", "self mm", 1000.0), ("cell", "cell mm", 1000.0))


def path_plan_from_replay(steps, start_joints, move: str, speed: float, acceleration: float,
                          blend: float) -> PathPlan:
    """The PathPlan of replay `steps` (ur3dq.cli.plan.PlanStep) from `start_joints`; without a start (dry run, no
    robot) the plan starts at the first pose, whose configuration is then checked as a move of length 0."""
    start = steps[0].joints if start_joints is None else start_joints
    return PathPlan(start, [PathSegment(step.pose.name, move, target_joints=step.joints, speed=speed,
                                        acceleration=acceleration, blend=blend if i + 1 < len(steps) else 0.0)
                            for i, step in enumerate(steps)])


def check_replay(model, steps, cell_path, start_joints=None, blend: float = 0.0, loops: int = 1) -> tuple:
    """(PathCheckResult, Cell or None) of a movej replay of `steps`; `loops` > 1 adds the move from the last pose
    back to the first."""
    plan = path_plan_from_replay(steps, start_joints, "joint", DEFAULT_JOINT_SPEED, DEFAULT_JOINT_ACCELERATION,
                                 blend)
    segments = list(plan.segments)
    if loops > 1:
        segments.append(PathSegment(f"{steps[0].pose.name} (next loop)", "joint", target_joints=steps[0].joints))
    cell = load_cell(cell_path) if cell_path else None
    return check_path(model, PathPlan(plan.start_joints, segments), cell), cell


def require_clear_path(settings: Settings, model, steps, start_joints, blend: float, cell_path,
                       loops: int = 1) -> None:
    """The path check of a movej replay before anything moves (run-poses): prints each move's smallest margins
    (on stderr with --json), then SafetyCheckError (exit 4, one line) naming the step, where and what failed."""
    result, _ = check_replay(model, steps, cell_path, start_joints, blend, loops)
    console = Console(stderr=True, highlight=False, width=None if sys.stderr.isatty() else 160) \
        if settings.json else settings.out
    console.print(margins_table(result, "Path check: smallest margins per move" +
                                (f" (cell {cell_path})" if cell_path else "")))
    if not result.ok:
        raise SafetyCheckError(f"path check: {result.summary()}")


def cell_option(command):
    """--cell FILE (env UR3DQ_CELL): the cell the path check keeps the arm clear of."""
    return click.option("--cell", "cell_path", envvar="UR3DQ_CELL", type=click.Path(dir_okay=False, path_type=Path),
                        help="Cell file (JSON: floor, keep-out boxes, keep-in box, margin, tool; env UR3DQ_CELL). "
                             "See docs/cell-file.md.")(command)


def margins_table(result, title: str) -> Table:
    """Each checked move's smallest margins: how far the worst sample is above the check's limit (negative = failed;
    speed room = the part of the joints' maximum speed left)."""
    table = Table(title=title)
    for header in ("step", "move", "samples", *(column[1] for column in MARGIN_COLUMNS)):
        table.add_column(header, justify="left" if header in ("step", "move") else "right", no_wrap=header == "step")
    for step in result.steps:
        cells = []
        for key, _, scale in MARGIN_COLUMNS:
            value = step.margins.get(key)
            cells.append("—" if value is None else (f"[red]{value * scale:.3g}[/]" if value < 0
                                                    else f"{value * scale:.3g}"))
        table.add_row(step.name, step.move, str(step.samples), *cells)
    return table


@cli.command("check")
@click.argument("names", nargs=-1)
@cell_option
@click.option("--move", type=click.Choice(MOVE_TYPES), default="joint", show_default=True,
              help="How the arm goes to each pose (joint = movej, linear = movel, process = movep).")
@click.option("--speed", type=float, default=None,
              help=f"rad/s for joint moves [{DEFAULT_JOINT_SPEED}], m/s for linear/process [{DEFAULT_LINEAR_SPEED}].")
@click.option("--blend", type=float, default=0.0, show_default=True, help="Blend radius between moves (m).")
@click.option("--margin", type=float, default=None, help="Clearance to the cell (m) [default: the cell file's].")
@click.option("--self-margin", type=float, default=0.0, show_default=True,
              help="Clearance between the arm's own links (m).")
@click.option("--wrist", type=float, default=Margins.wrist, show_default=True, help="Smallest |sin θ5| on a line.")
@click.option("--elbow", type=float, default=Margins.elbow, show_default=True, help="Smallest |sin θ3| on a line.")
@click.option("--shoulder", type=float, default=Margins.shoulder, show_default=True,
              help="Smallest wrist-centre distance from the base axis on a line (m).")
@click.option("--joints", "replay_joints", is_flag=True, help="Check the recorded joint angles instead of IK.")
@display_options
@click.pass_obj
def check(settings: Settings, names, cell_path, move, speed, blend, margin, self_margin, wrist, elbow, shoulder,
          replay_joints):
    """Check the whole path through the stored poses (all, or NAMES) before the arm moves.

    Every move is sampled as the controller runs it (≤ 1 mm of TCP, ≤ 0.5° of any joint between samples) and each
    sample is checked: reachable, no IK branch flip, singularity margins (lines only), joint limits and speeds,
    self-collision of the link capsules and the tool, and the cell's floor and boxes. With a robot (--host, or the
    embedded simulator running) the path starts at the arm's joints; without one, at the first pose.
    Exit code 4 when a check fails, with one line naming the step, where, what failed and a fix.

    \b
    Examples:
      ur3dq check --cell cell.json
      ur3dq check pick place --move linear --speed 0.1 --json
    """
    poses = settings.store.select(names)
    if not poses:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    cartesian = move != "joint"
    speed = speed if speed is not None else (DEFAULT_LINEAR_SPEED if cartesian else DEFAULT_JOINT_SPEED)
    acceleration = DEFAULT_LINEAR_ACCELERATION if cartesian else DEFAULT_JOINT_ACCELERATION
    for option, value in (("--speed", speed), ("--blend", blend)):
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
    steps = plan_replay(model, poses, start, replay_recorded_joints=replay_joints)
    result = check_path(model, path_plan_from_replay(steps, start, move, speed, acceleration, blend), cell, margins)
    err = Console(stderr=True, highlight=False, width=None if sys.stderr.isatty() else 160)
    title = f"Path check on {where}{f', cell {cell_path}' if cell_path else ''}: smallest margins per move"
    (err if settings.json else settings.out).print(margins_table(result, title))
    if settings.json:
        emit_json(result.to_dict())
    else:
        for problem in result.problems:
            settings.out.print(problem.line(), markup=False)
    if not result.ok:
        raise SafetyCheckError(result.summary())
    if not settings.json:
        settings.out.print(result.summary())
