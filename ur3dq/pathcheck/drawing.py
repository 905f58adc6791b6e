"""The path check in a 3-D figure (for `ur3dq plot`): the swept TCP path, the arm's capsules at the worst sample and
the cell's obstacles, drawn on matplotlib 3-D axes the caller owns. Base frame, metres."""
from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import numpy as np

from ur3dq.array_types import FloatArray
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import geometry
from ur3dq.pathcheck.cell import Cell
from ur3dq.pathcheck.reports import PathCheckResult, StepReport

if TYPE_CHECKING:   # matplotlib is imported by the caller that draws, not by the path check
    from matplotlib.axes import Axes

#: Which margin decides the worst sample when nothing failed: the closest call to an obstacle, then to the arm.
_PREFERENCE = ("cell", "self_collision", "wrist", "elbow", "shoulder", "joint_limit")


def worst_sample(result: PathCheckResult) -> tuple[StepReport, int, str] | None:
    """Where the path is worst: the step, the sample and a label.

    (StepReport, sample index, label) where the path is worst: the first problem's place when a check failed,
    else the sample with the smallest clearance (cell, then self-collision, ...). None if no step was sampled.
    `result` keeps its samples (check_path's keep_samples)."""
    steps = [step for step in result.steps if step.samples]
    if not steps:
        return None
    if result.problems:
        problem = result.problems[0]
        for step in steps:
            if step.name == problem.step:
                assert step.fraction is not None   # a drawn result keeps its samples
                index = int(np.argmin(np.abs(step.fraction - problem.fraction)))
                return step, index, f"{problem.check} at {step.name} {problem.fraction:.0%}"
    for check in _PREFERENCE:
        candidates = [step for step in steps if check in step.margins]
        if candidates:
            step = min(candidates, key=lambda s: s.margins[check])
            index = step.worst[check]
            assert step.fraction is not None   # a drawn result keeps its samples
            return step, index, f"smallest {check} margin at {step.name} {step.fraction[index]:.0%}"
    return steps[0], 0, steps[0].name


def draw_path_check(axes: Axes, model: URModel, result: PathCheckResult, cell: Cell | None = None) -> FloatArray:
    """Draw the check on `axes` (3-D); returns the (n, 3) points drawn (for the caller's axis limits). `result`
    keeps its samples (check_path's keep_samples)."""
    drawn: list[FloatArray] = []
    tcp = [step.tcp for step in result.steps if step.samples and step.tcp is not None]
    swept = np.vstack(tcp) if result.steps else np.zeros((0, 3))
    if len(swept):
        axes.plot(swept[:, 0], swept[:, 1], swept[:, 2], ":", color="grey", linewidth=1, label="swept TCP path")
        drawn.append(swept)
    worst = worst_sample(result)
    if worst is not None:
        step, index, label = worst
        capsules = geometry.link_capsules(model, cell.tool if cell else None)
        assert step.joints is not None   # a drawn result keeps its samples
        a, b = geometry.capsule_points(geometry.dh_frames(model, step.joints[index:index + 1]), capsules)
        colour = "red" if result.problems else "darkorange"
        for k, (start, end) in enumerate(zip(a[0], b[0])):
            axes.plot(*np.transpose([start, end]), color=colour, linewidth=4, alpha=0.6,
                      label=f"arm ({label})" if k == 0 else None)
        drawn += [a[0], b[0]]
    if cell is not None:
        for box in cell.boxes:
            drawn.append(_wire_box(axes, box.lo, box.hi, "saddlebrown"))
        if cell.keep_in is not None:
            drawn.append(_wire_box(axes, cell.keep_in.lo, cell.keep_in.hi, "green"))
    return np.vstack(drawn) if drawn else np.zeros((0, 3))


def _wire_box(axes: Axes, lo: FloatArray, hi: FloatArray, colour: str) -> FloatArray:
    """Draw the 12 edges of the box [lo, hi] (each (3,)); returns its 8 corners (8, 3)."""
    corners = np.array(list(itertools.product(*zip(lo, hi))))
    for i, j in itertools.combinations(range(8), 2):
        if np.count_nonzero(corners[i] != corners[j]) == 1:   # the 12 edges: corners differing in one coordinate
            axes.plot(*np.transpose(corners[[i, j]]), color=colour, linewidth=1)
    return corners
