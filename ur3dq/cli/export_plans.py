"""What `export-urscript` and `export-urp` write, planned and checked as `run-poses` plans and checks it: a file for
the pendant or the controller is a run that has not started yet, so it gets the same limits, the same warnings and
the same path check, and a program `check` and `run-poses` refuse is not written.

Speeds and accelerations above the model's limits are lowered to them, as run-poses lowers them, with the same
warning lines (ur3dq.cli.plan_warnings for a cell program; options.speed_and_acceleration for stored poses). The
path check is the offline one (from the first waypoint, in the --cell cell if given); a failed check is the
check's one-line error and exit code (4), its further problems on stderr above it.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import click
from rich.console import Console

from ur3dq.cli.app import Settings
from ur3dq.cli.path_report import check_program, check_replay, require_passed
from ur3dq.cli.plan_warnings import plan_warnings
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck.reports import PathCheckResult
from ur3dq.program.plan import Defaults, PlannedStep, motion_ranges, plan_program
from ur3dq.program.steps import Step
from ur3dq.replay import PlanStep


def checked_program_plan(settings: Settings, model: URModel, program: Sequence[Step], part: Sequence[Step],
                         defaults: Defaults, replay_joints: bool, max_travel: float | None,
                         cell_path: Path | None) -> tuple[list[PlannedStep], list[str]]:
    """(plan, warning lines) of the cell program's `part` (of the whole `program`) on `model` from an unknown start,
    as run-poses --dry-run plans it: the warnings are printed on stderr ("Warning: ..."); SafetyCheckError (exit 4)
    when the path check fails."""
    plan = plan_program(model, part, None, defaults, 1.0, replay_joints, max_travel, resolve_from=program)
    warnings = plan_warnings(plan, settings.units)
    for line in warnings:
        click.echo(f"Warning: {line}", err=True)
    result, _ = check_program(model, plan, cell_path, keep_samples=False)
    if result is not None:
        _require_passed(settings, result)
    return plan, warnings


def check_replay_export(settings: Settings, model: URModel, steps: Sequence[PlanStep], blend: float, loops: int,
                        cell_path: Path | None) -> None:
    """The offline path check of stored poses replayed with movej (`blend`, `loops` times), as run-poses checks
    them; SafetyCheckError (exit 4) when it fails."""
    result, _ = check_replay(model, steps, cell_path, None, blend, loops, keep_samples=False)
    _require_passed(settings, result)


def clamped_joint_defaults(model: URModel, defaults: Defaults) -> tuple[float, float]:
    """(speed rad/s, acceleration rad/s²) of the run's joint-move defaults lowered to `model`'s slowest joint, as
    plan_program lowers them for a waypoint that takes them: what a .urp's MoveJ container may carry."""
    (_, top_speed), (_, top_acceleration) = motion_ranges(model, "joint")
    return min(defaults.joint_speed, top_speed), min(defaults.joint_acceleration, top_acceleration)


def _require_passed(settings: Settings, result: PathCheckResult) -> None:
    """require_passed with the further problems on stderr: stdout may be the script itself (`-o -`)."""
    if not result.ok:
        require_passed(settings, result, Console(stderr=True, highlight=False))
