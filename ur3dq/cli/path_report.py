"""The whole-path check of a replay as the CLI shows it: the adapter from replay.PlanStep lists to the path check's
input (`path_plan_from_replay`), the check before anything moves (`require_clear_path`) and the margins table.
Shared by `ur3dq check`, `run-poses` and `plot`.
"""
from __future__ import annotations

import math
import sys

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ur3dq.cli.app import Settings
from ur3dq.cli.display import NARROW_WIDTH, Column, fitted_table
from ur3dq.errors import SafetyCheckError
from ur3dq.pathcheck import PathPlan, PathSegment, check_path, load_cell
from ur3dq.program.path import path_plan_of

DEFAULT_JOINT_SPEED = 1.05     # rad/s (movej's default)
DEFAULT_LINEAR_SPEED = 0.25    # m/s (movel's default)
DEFAULT_JOINT_ACCELERATION = 1.4
DEFAULT_LINEAR_ACCELERATION = 1.2
# (margin key, header, scale, narrow header, narrow drop order: the speed room first, the collisions last)
MARGIN_COLUMNS = (("wrist", "|sin θ5|", 1.0, "wrist", 5), ("elbow", "|sin θ3|", 1.0, "elbow", 4),
                  ("shoulder", "shoulder mm", 1000.0, "shldr", 3),
                  ("joint_limit", "limit °", math.degrees(1.0), "limit", 2),
                  ("joint_speed", "speed room", 1.0, "speed", 1),
                  ("self_collision", "self mm", 1000.0, "self", 7), ("cell", "cell mm", 1000.0, "cell", 6))


def path_plan_from_replay(steps, start_joints, move: str, speed: float, acceleration: float,
                          blend: float) -> PathPlan:
    """The PathPlan of a replay plan.

    The PathPlan of replay `steps` (ur3dq.replay.PlanStep) from `start_joints`; without a start (dry run, no
    robot) the plan starts at the first pose, whose configuration is then checked as a move of length 0."""
    start = steps[0].joints if start_joints is None else start_joints
    count = len(steps)
    blends = [blend] * (count - 1) + [0.0]
    return PathPlan(start, PathSegment.joint_targets([step.pose.name for step in steps], [move] * count,
                                                     [step.joints for step in steps], [speed] * count,
                                                     [acceleration] * count, blends, [None] * count))


def check_replay(model, steps, cell_path, start_joints=None, blend: float = 0.0, loops: int = 1,
                 keep_samples: bool = True) -> tuple:
    """The path check of a movej replay.

    (PathCheckResult, Cell or None) of a movej replay of `steps`; `loops` > 1 adds the move from the last pose
    back to the first; `keep_samples` as check_path's (a drawing needs them, a margins table does not)."""
    plan = path_plan_from_replay(steps, start_joints, "joint", DEFAULT_JOINT_SPEED, DEFAULT_JOINT_ACCELERATION,
                                 blend)
    segments = list(plan.segments)
    if loops > 1:
        segments.append(PathSegment(f"{steps[0].pose.name} (next loop)", "joint", target_joints=steps[0].joints))
    cell = load_cell(cell_path) if cell_path else None
    return check_path(model, PathPlan(plan.start_joints, segments), cell, keep_samples=keep_samples), cell


def require_clear_path(settings: Settings, model, steps, start_joints, blend: float, cell_path,
                       loops: int = 1) -> None:
    """Check a replay's whole path before anything moves; raise if it fails.

    The path check of a movej replay before anything moves (run-poses): prints each move's smallest margins
    (on stderr with --json), then SafetyCheckError (exit 4, one line) naming the step, where and what failed."""
    result, _ = check_replay(model, steps, cell_path, start_joints, blend, loops, keep_samples=False)
    report_path_check(settings, result, cell_path)


def check_program(model, plan, cell_path, start_joints=None, keep_samples: bool = True) -> tuple:
    """The path check of a planned cell program.

    (PathCheckResult or None when no step moves the arm, Cell or None) of a cell program
    (ur3dq.program.plan.PlannedStep list): every joint, linear and process move with its own speed, blend and
    taught TCP; `keep_samples` as check_replay's."""
    cell = load_cell(cell_path) if cell_path else None
    path = path_plan_of(plan, start_joints)
    return (None if path is None else check_path(model, path, cell, keep_samples=keep_samples)), cell


def require_clear_program_path(settings: Settings, model, plan, start_joints, cell_path) -> None:
    """The check of require_clear_path for a cell program (see check_program)."""
    result, _ = check_program(model, plan, cell_path, start_joints, keep_samples=False)
    if result is not None:
        report_path_check(settings, result, cell_path)


def report_path_check(settings: Settings, result, cell_path) -> None:
    """Print the margins table (stderr with --json); SafetyCheckError with the check's summary if it failed."""
    console = Console(stderr=True, highlight=False, width=None if sys.stderr.isatty() else 160) \
        if settings.json else settings.out
    table = margins_table(result, "Path check: smallest margins per move", console.width)
    cell = f"cell: {escape(str(cell_path))}" if cell_path else None
    table.caption = "; ".join(filter(None, [str(table.caption or ""), cell]))
    table.caption_justify = "left"
    console.print(table)   # a long cell path wraps in the caption, not in the title
    if not result.ok:
        raise SafetyCheckError(f"path check: {result.summary()}")


def margins_table(result, title: str, width: int | None = None) -> Table:
    """A table of each checked move's smallest margins.

    Each checked move's smallest margins: how far the worst sample is above the check's limit (negative = failed;
    speed room = the part of the joints' maximum speed left). Narrower than NARROW_WIDTH columns the headers are
    short and the sample count is left out, then margins in MARGIN_COLUMNS' drop order while the table would not
    fit (the caption names them; `check --json` has them all); the step name is never cut."""
    narrow = width is not None and width < NARROW_WIDTH
    columns = [Column("step", no_wrap=True), Column("move", no_wrap=True),
               Column("samples", justify="right", drop_order=0)]
    columns += [Column(header, narrow_header=short, justify="right", no_wrap=True, drop_order=order)
                for _, header, _, short, order in MARGIN_COLUMNS]
    rows = []
    shown = _rows_worth_showing(result)
    for step in (result.steps[i] for i in shown):
        cells = []
        for key, _, scale, _, _ in MARGIN_COLUMNS:
            value = step.margins.get(key)
            cells.append("—" if value is None else (f"[red]{value * scale:.3g}[/]" if value < 0
                                                    else f"{value * scale:.3g}"))
        rows.append([escape(step.name), step.move, str(step.samples), *cells])
    if narrow:  # the sample count first: it says how fine the check was, not how safe the path is
        columns, rows = columns[:2] + columns[3:], [row[:2] + row[3:] for row in rows]
    table = fitted_table(title, columns, rows, width)
    notes = ["shldr, self, cell in mm; limit in °" if narrow else None, str(table.caption or ""),
             None if len(shown) == len(result.steps) else
             f"{len(shown)} of {len(result.steps)} moves shown: those with a problem or a check's smallest margin"]
    table.caption = "; ".join(filter(None, notes)) or None
    table.caption_justify = "left"
    return table


MAX_MARGIN_ROWS = 200   # a table of 10⁵ moves is unreadable (and takes rich a minute): the moves that matter


def _rows_worth_showing(result) -> list[int]:
    """Indices of the moves the margins table shows: all of them up to MAX_MARGIN_ROWS, else the moves with a
    problem and, for each check, the move with its smallest margin (in program order)."""
    if len(result.steps) <= MAX_MARGIN_ROWS:
        return list(range(len(result.steps)))
    chosen = set(result.steps.positions_named({problem.step for problem in result.problems})) \
        if result.problems else set()
    chosen.update(position for _, position in result.steps.smallest_margins().values())
    return sorted(chosen)[:MAX_MARGIN_ROWS]
