"""Check a whole path before the arm moves: every move sampled as the controller runs it, every sample checked
for reach, IK branch flips, singularities, joint limits and speeds, self-collision and the cell's obstacles.

    from ur3dq.pathcheck import PathPlan, PathSegment, check_path, load_cell
    result = check_path(model, PathPlan(q_start, [PathSegment("pick", "linear", target_pose=σ, speed=0.1)]),
                        cell=load_cell("cell.json"))
    if not result.ok: print(result.summary())
"""
from ur3dq.pathcheck.cell import Box, Cell, ToolShape, cell_from_dict, load_cell
from ur3dq.pathcheck.checks import CHECKS, Margins, Problem
from ur3dq.pathcheck.path_check import check_path
from ur3dq.pathcheck.path_plan import MOVE_TYPES, PathPlan, PathSegment
from ur3dq.pathcheck.reports import PathCheckResult, StepReport

__all__ = ["CHECKS", "MOVE_TYPES", "Box", "Cell", "Margins", "PathCheckResult", "PathPlan", "PathSegment",
           "Problem", "StepReport", "ToolShape", "cell_from_dict", "check_path", "load_cell"]
