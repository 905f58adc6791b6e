"""A planned cell program as the whole-path check's input (ur3dq.pathcheck): one PathSegment per waypoint in
execution order, with its move type (movej / movel / movep), clamped speed and acceleration, blend radius and
taught TCP offset. Action steps (I/O, waits, messages) do not move the arm and are left out; a blend never spans
one, since the planner zeroes the blend of a waypoint an action follows.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from ur3dq.pathcheck import PathPlan, PathSegment

if TYPE_CHECKING:
    from ur3dq.program.plan import PlannedStep


def path_plan_of(plan: Sequence[PlannedStep], start_joints: npt.ArrayLike | None = None) -> PathPlan | None:
    """The PathPlan of a planned cell program.

    The PathPlan of `plan` (ur3dq.program.plan.PlannedStep list) from `start_joints` (6,) rad; without a start
    (a dry run with no robot) from the first waypoint's joints, whose configuration is then checked as a move of
    length 0 (PathPlan.start_known False). None when the plan has no waypoint (nothing moves)."""
    moves = [planned for planned in plan if planned.joints is not None]
    if not moves:
        return None
    start = np.asarray(moves[0].joints if start_joints is None else start_joints, dtype=float)
    fields = ([getattr(planned, name) for planned in moves]
              for name in ("name", "move", "joints", "speed", "acceleration", "blend", "tcp_offset"))
    return PathPlan(start, PathSegment.joint_targets(*fields), start_known=start_joints is not None)
