"""Checking a cell program without a robot: plan it on a model, then check the whole path it sweeps in a cell.

The one call is `ur3dq.check_program(program, model, cell)`; it chains what `ur3dq check` and `run-poses` do
(ur3dq.program.plan.plan_program, ur3dq.program.path.path_plan_of, ur3dq.pathcheck.check_path).
"""
from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from ur3dq.kinematics import robot_model
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import Cell, Margins, PathCheckResult, check_path, load_cell
from ur3dq.program.path import path_plan_of
from ur3dq.program.plan import Defaults, plan_program
from ur3dq.program.steps import Step


def check_program(program: Sequence[Step], model: URModel | str, cell: Cell | str | os.PathLike[str] | None = None,
                  margins: Margins | None = None, start_joints: Sequence[float] | np.ndarray | None = None,
                  defaults: Defaults | None = None, speed_scale: float = 1.0) -> PathCheckResult:
    """Plan `program` on `model` and check the whole path its moves sweep, as `run-poses` does before moving.

    Parameters
    ----------
    program : sequence of Step
        The cell program (ur3dq.program.steps: Waypoint, RelativeWaypoint, DigitalOut, Wait, ...), or
        `PoseStore(path).load_program()`.
    model : URModel or str
        The arm: a model (`ur3dq.robot_model("ur3")`, or a connected robot's `robot.model`) or a model name.
    cell : Cell, path or None
        The cell (ur3dq.pathcheck.Cell, or the path of a cell file, docs/cell-file.md); None checks the arm alone
        (reach, IK branch, singularities, joint limits and speeds, self-collision).
    margins : Margins, optional
        The checks' margins (defaults: Margins()).
    start_joints : (6,) rad, optional
        Where the arm starts; without it the path starts at the first waypoint.
    defaults, speed_scale
        The run's speeds for waypoints that leave theirs unset, and the scale of every speed (as run-poses'
        --speed, --acceleration, --blend, --speed-scale).

    Returns
    -------
    PathCheckResult
        `.ok`, `.problems` (each with the step, where and a fix), `.summary()`; a failed check never raises.

    Raises
    ------
    ValueError
        (SafetyCheckError, UnreachablePoseError) naming the step when a waypoint cannot be planned at all, or when
        the program has no waypoint.

    Examples
    --------
    >>> import ur3dq
    >>> from ur3dq.store import PoseStore
    >>> result = ur3dq.check_program(PoseStore("poses.json").load_program(), "ur3", "cell.json")  # doctest: +SKIP
    >>> print(result.summary() if not result.ok else "clear")                                     # doctest: +SKIP
    """
    arm = robot_model(model) if isinstance(model, str) else model
    start = None if start_joints is None else np.asarray(start_joints, dtype=float)
    plan = plan_program(arm, list(program), start, defaults or Defaults(), speed_scale)
    path = path_plan_of(plan, start)
    if path is None:
        raise ValueError("the program has no waypoint: nothing moves, nothing to check")
    if cell is not None and not isinstance(cell, Cell):
        cell = load_cell(cell)
    return check_path(arm, path, cell, margins, keep_samples=False)
