"""The whole-path check of a replay as the CLI shows it: the adapter from replay.PlanStep lists to the path check's
input (`path_plan_from_replay`), the check before anything moves (`report_path_check`, `require_passed`), the
margins table and its legend, and the verdict line of run-poses' summary.
Shared by `ur3dq check`, `run-poses` and `plot`.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from ur3dq.cli.app import Settings, make_error_console
from ur3dq.cli.display import NARROW_WIDTH, Column, count_text, fitted_table
from ur3dq.errors import SafetyCheckError
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import Cell, PathPlan, PathSegment, check_path, load_cell
from ur3dq.pathcheck.reports import PathCheckResult
from ur3dq.program.path import path_plan_of
from ur3dq.program.plan import PlannedStep
from ur3dq.program.steps import KeptScript
from ur3dq.replay import PlanStep

DEFAULT_JOINT_SPEED = 1.05     # rad/s (movej's default)
DEFAULT_LINEAR_SPEED = 0.25    # m/s (movel's default)
DEFAULT_JOINT_ACCELERATION = 1.4
DEFAULT_LINEAR_ACCELERATION = 1.2


def _degrees_from_singular(sine: float) -> float:
    return math.degrees(math.asin(min(1.0, max(0.0, sine))))


# (margin key, header, narrow header, narrow drop order, the measured value from (margin, limit), its text):
# each column shows what the check measured, in the unit and the words of its problem message.
MARGIN_COLUMNS = (
    ("wrist", "wrist °", "wrist°", 5, lambda m, lim: _degrees_from_singular(m + lim), "{:.1f}"),
    ("elbow", "elbow °", "elbow°", 4, lambda m, lim: _degrees_from_singular(m + lim), "{:.1f}"),
    ("shoulder", "shoulder mm", "shldr", 3, lambda m, lim: 1000.0 * (m + lim), "{:.0f}"),
    ("joint_limit", "limit °", "limit°", 2, lambda m, lim: math.degrees(m + lim), "{:.0f}"),
    ("joint_speed", "speed %", "speed%", 1, lambda m, lim: 100.0 * (lim - m), "{:.0f}"),
    ("self_collision", "self mm", "self", 7, lambda m, lim: 1000.0 * (m + lim), "{:.1f}"),
    ("cell", "cell mm", "cell", 6, lambda m, lim: 1000.0 * (m + lim), "{:.1f}"),
)


def margins_legend(result: PathCheckResult) -> str:
    """What the margins table's columns are, with the limit each must keep (fits 80 columns a line)."""
    limits = result.limits
    return "\n".join([
        f"wrist, elbow: ° from singular (≥ {_degrees_from_singular(limits.get('wrist', 0.02)):.1f}°); "
        f"shoulder: mm to base axis (≥ {1000 * limits.get('shoulder', 0.03):.0f})",
        f"limit: ° to a joint limit; speed: % of top joint speed a line needs (≤ "
        f"{100 * limits.get('joint_speed', 1.0):.0f})",
        f"self: mm between the links (≥ {1000 * limits.get('self_collision', 0.0):.0f}); cell: mm to the "
        f"nearest obstacle (≥ {1000 * limits.get('cell', 0.0):.0f})"])


def path_plan_from_replay(steps: Sequence[PlanStep], start_joints: npt.ArrayLike | None, move: str, speed: float,
                          acceleration: float, blend: float) -> PathPlan:
    """The PathPlan of a replay plan.

    The PathPlan of replay `steps` (ur3dq.replay.PlanStep) from `start_joints`; without a start (dry run, no
    robot) the plan starts at the first pose, whose configuration is then checked as a move of length 0."""
    start = np.asarray(steps[0].joints if start_joints is None else start_joints, dtype=float)
    count = len(steps)
    blends = [blend] * (count - 1) + [0.0]
    return PathPlan(start, PathSegment.joint_targets([step.pose.name for step in steps], [move] * count,
                                                     [step.joints for step in steps], [speed] * count,
                                                     [acceleration] * count, blends, [None] * count),
                    start_known=start_joints is not None)


def check_replay(model: URModel, steps: Sequence[PlanStep], cell_path: str | Path | None,
                 start_joints: npt.ArrayLike | None = None, blend: float = 0.0, loops: int = 1,
                 keep_samples: bool = True) -> tuple[PathCheckResult, Cell | None]:
    """The path check of a movej replay.

    (PathCheckResult, Cell or None) of a movej replay of `steps`; `loops` > 1 adds the move from the last pose
    back to the first; `keep_samples` as check_path's (a drawing needs them, a margins table does not)."""
    plan = path_plan_from_replay(steps, start_joints, "joint", DEFAULT_JOINT_SPEED, DEFAULT_JOINT_ACCELERATION,
                                 blend)
    segments = list(plan.segments)
    if loops > 1:
        segments.append(PathSegment(f"{steps[0].pose.name} (next loop)", "joint", target_joints=steps[0].joints))
    cell = load_cell(cell_path) if cell_path else None
    whole = PathPlan(plan.start_joints, segments, plan.start_known)
    return check_path(model, whole, cell, keep_samples=keep_samples), cell


def check_program(model: URModel, plan: Sequence[PlannedStep], cell_path: str | Path | None,
                  start_joints: npt.ArrayLike | None = None,
                  keep_samples: bool = True) -> tuple[PathCheckResult | None, Cell | None]:
    """The path check of a planned cell program.

    (PathCheckResult or None when no step moves the arm, Cell or None) of a cell program
    (ur3dq.program.plan.PlannedStep list): every joint, linear and process move with its own speed, blend and
    taught TCP; `keep_samples` as check_replay's."""
    cell = load_cell(cell_path) if cell_path else None
    path = path_plan_of(plan, start_joints)
    return (None if path is None else check_path(model, path, cell, keep_samples=keep_samples)), cell


def kept_script_warnings(plan: Sequence[PlannedStep]) -> list[str]:
    """One line per kept-script step of a planned program: it runs as it is, outside the path check."""
    return [f"{planned.step.name!r}: URScript kept from a PolyScope program runs as it is: its motions are not "
            "checked, and the path check takes the next move from the waypoint before it"
            for planned in plan if isinstance(planned.step, KeptScript)]


def report_path_check(settings: Settings, result: PathCheckResult, cell_path: Path | None) -> None:
    """Print the margins table and its legend (stderr with --json), then the problems, each once; a failed check
    is a SafetyCheckError that points at them."""
    console = _report_console(settings)
    table = margins_table(result, "Path check: the worst point of each move", console.width)
    cell = f"cell: {escape(str(cell_path))}" if cell_path else None
    table.caption = "; ".join(filter(None, [str(table.caption or ""), cell]))
    table.caption_justify = "left"
    console.print(table)   # a long cell path wraps in the caption, not in the title
    console.print(margins_legend(result), markup=False)
    require_passed(settings, result)


def _report_console(settings: Settings) -> Console:
    """Where the check's report goes: stdout, or stderr under --json (stdout carries one JSON document)."""
    if settings.json:
        return make_error_console()
    return settings.out


def require_passed(settings: Settings, result: PathCheckResult, console: Console | None = None) -> None:
    """Nothing when the check passed; else a SafetyCheckError whose one line is the first problem (where, what,
    the fix), each further problem printed once above it (words never cut; on `console`, default stdout, stderr
    under --json), their numbers in the user's units."""
    if result.ok:
        return
    if not result.problems:
        raise result.refusal()
    console = console or _report_console(settings)
    for problem in result.problems[1:]:
        console.print(Text(problem.line(settings.units)), soft_wrap=False)
    more = len(result.problems) - 1
    text, measured = result.problems[0].wording()   # the error reads in the user's units (the command group's)
    raise SafetyCheckError.from_wording(
        f"path check: {text}" + (f" (+{count_text(more, 'more problem')}, listed above)" if more else ""), measured)


def check_verdict(result: PathCheckResult | None, cell_path: Path | None) -> str:
    """One line for the run question's summary: passed or not, and the nearest the path comes to an obstacle."""
    where = f"cell {cell_path}" if cell_path else "no cell file"
    if result is None:
        return f"Path check ({where}): nothing moves"
    if not result.ok:
        return f"Path check ({where}): FAILED, {count_text(len(result.problems), 'problem')}"
    smallest = result.steps.smallest_margins()
    key = "cell" if "cell" in smallest else "self_collision" if "self_collision" in smallest else None
    if key is None:
        return f"Path check ({where}): clear"
    margin, position = smallest[key]
    clearance = 1000.0 * (margin + result.limits.get(key, 0.0))
    what = "to the cell" if key == "cell" else "between links"
    return (f"Path check ({where}): clear; closest {clearance:.1f} mm {what} at "
            f"{result.steps[position].name!r}")


def margins_table(result: PathCheckResult, title: str, width: int | None = None) -> Table:
    """A table of each checked move's worst point per check.

    Each cell is what the check measured at the move's worst sample, in the unit and words of its problem
    message (margins_legend says what each column is and its limit; red: beyond the limit). Narrower than
    NARROW_WIDTH columns the headers are short and the sample count is left out, then columns in MARGIN_COLUMNS'
    drop order while the table would not fit (the caption names them; `check --json` has them all); the step
    name is never cut."""
    narrow = width is not None and width < NARROW_WIDTH
    columns = [Column("step", no_wrap=True), Column("move", no_wrap=True),
               Column("samples", justify="right", drop_order=0)]
    columns += [Column(header, narrow_header=short, justify="right", no_wrap=True, drop_order=order)
                for _, header, short, order, _, _ in MARGIN_COLUMNS]
    rows = []
    shown = _rows_worth_showing(result)
    for step in (result.steps[i] for i in shown):
        cells = []
        for key, _, _, _, measured, form in MARGIN_COLUMNS:
            margin = step.margins.get(key)
            if margin is None:
                cells.append("—")
                continue
            text = form.format(measured(margin, result.limits.get(key, 0.0)))
            cells.append(f"[red]{text}[/]" if margin < 0 else text)
        rows.append([escape(step.name), step.move, str(step.samples), *cells])
    if narrow:  # the sample count first: it says how fine the check was, not how safe the path is
        columns, rows = columns[:2] + columns[3:], [row[:2] + row[3:] for row in rows]
    table = fitted_table(title, columns, rows, width)
    notes = [str(table.caption or ""), None if len(shown) == len(result.steps) else
             f"{len(shown)} of {len(result.steps)} moves shown: those with a problem or a check's smallest margin"]
    table.caption = "; ".join(filter(None, notes)) or None
    table.caption_justify = "left"
    return table


MAX_MARGIN_ROWS = 200   # a table of 10⁵ moves is unreadable (and takes rich a minute): the moves that matter


def _rows_worth_showing(result: PathCheckResult) -> list[int]:
    """Indices of the moves the margins table shows: all of them up to MAX_MARGIN_ROWS, else the moves with a
    problem and, for each check, the move with its smallest margin (in program order)."""
    if len(result.steps) <= MAX_MARGIN_ROWS:
        return list(range(len(result.steps)))
    chosen = set(result.steps.positions_named({problem.step for problem in result.problems})) \
        if result.problems else set()
    chosen.update(position for _, position in result.steps.smallest_margins().values())
    return sorted(chosen)[:MAX_MARGIN_ROWS]
