"""What the page's 3D view draws, computed from the model: the arm as the path check's link capsules, the TCP
frame, the cell's floor, boxes and keep-in volume, and the recorded poses as small frames.

The capsules are ur3dq.pathcheck.geometry's, placed at the DH frames of the model the path check places them by
(body_model), so what the page shows is what the path check checks. The live arm is placed by the model's
dual-quaternion chain (numpy), not the compiled kernels: the page draws the arm before `ur3dq serve` has loaded the
kernels it plans with. The page only places cylinders between the end points it is sent: it has no kinematics of its
own. Matrices go to the page as 16 numbers in column-major order (three.js' `Matrix4.fromArray`).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import Box, Cell, ToolShape
from ur3dq.pathcheck.geometry import BODY_NAMES, Capsules, body_model, capsule_points, link_capsules
from ur3dq.program.resolve import resolve_targets
from ur3dq.program.steps import Step, Waypoint


def column_major(matrix: np.ndarray) -> list[float]:
    """A 4×4 matrix as the 16 numbers three.js reads (column-major), rounded to 0.1 µm."""
    return [round(float(value), 7) for value in np.asarray(matrix, dtype=float).T.reshape(16)]


class ArmShape:
    """The capsules of `model` (and the cell's tool, if any) and their placement at a joint vector."""

    def __init__(self, model: URModel, tool: ToolShape | None = None) -> None:
        self.model = model
        self.capsules: Capsules = link_capsules(model, tool)
        self._bodies = body_model(model).with_tcp(DualQuaternion.identity())   # its frame 6 is the flange

    def description(self) -> dict[str, Any]:
        """What the page needs once: each capsule's radius (m) and the body it belongs to."""
        return {"model": self.model.name, "radius": [round(float(r), 5) for r in self.capsules.radius],
                "body": [BODY_NAMES[int(b)] for b in self.capsules.body]}

    def placed(self, q: np.ndarray) -> dict[str, Any]:
        """The capsules' end points (C × [ax, ay, az, bx, by, bz], m, base frame) and the TCP frame at joints `q`."""
        q = np.asarray(q, dtype=float).reshape(6)
        frames = dqarray.to_matrix(self._bodies.frames(q))   # (7, 4, 4): DH frames 0..6
        a, b = capsule_points(frames[None], self.capsules)
        ends = np.round(np.concatenate([a[0], b[0]], axis=1), 6).tolist()
        return {"capsules": ends, "tcp": column_major(dqarray.to_matrix(self.model.frames(q)[-1]))}


def cell_description(cell: Cell | None) -> dict[str, Any]:
    """The cell file's floor height, keep-out boxes and keep-in box (metres, base frame), or an empty cell."""
    if cell is None:
        return {"floor": None, "boxes": [], "keep_in": None, "margin": None}

    def box(item: Box) -> dict[str, Any]:
        return {"name": item.name, "min": [float(v) for v in item.lo], "max": [float(v) for v in item.hi]}

    return {"floor": cell.floor_z, "boxes": [box(item) for item in cell.boxes],
            "keep_in": None if cell.keep_in is None else box(cell.keep_in), "margin": cell.margin}


def pose_frames(steps: list[Step]) -> list[dict[str, Any]]:
    """Every waypoint of the program as a small named frame: its TCP pose (recorded, or resolved through its
    base); a program whose relative waypoints do not resolve shows its recorded poses only."""
    try:
        targets = resolve_targets(steps)
    except ValueError:   # a relative waypoint whose base is gone: the recorded poses still show
        targets = resolve_targets([step for step in steps if isinstance(step, Waypoint)])
    return [{"name": name, "matrix": column_major(target.pose.to_matrix()),
             "relative": not isinstance(target.step, Waypoint)} for name, target in targets.items()]
