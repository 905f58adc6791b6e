"""What the page's 3D view draws, computed from the model: the arm as the path check's link capsules, the TCP
frame, the cell's floor, boxes and keep-in volume, and the recorded poses as small frames.

The capsules are ur3dq.pathcheck.geometry's, placed by its DH frames of the (calibrated) model, so what the page
shows is what the path check checks. The page only places cylinders between the end points it is sent: it has no
kinematics of its own. Matrices go to the page as 16 numbers in column-major order (three.js' `Matrix4.fromArray`).
"""
from __future__ import annotations

import numpy as np

from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import Box, Cell, ToolShape
from ur3dq.pathcheck.geometry import BODY_NAMES, Capsules, capsule_points, dh_frames, link_capsules
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

    def description(self) -> dict:
        """What the page needs once: each capsule's radius (m) and the body it belongs to."""
        return {"model": self.model.name, "radius": [round(float(r), 5) for r in self.capsules.radius],
                "body": [BODY_NAMES[int(b)] for b in self.capsules.body]}

    def placed(self, q: np.ndarray) -> dict:
        """The capsules' end points (C × [ax, ay, az, bx, by, bz], m, base frame) and the TCP frame at joints `q`."""
        q = np.asarray(q, dtype=float).reshape(1, 6)
        a, b = capsule_points(dh_frames(self.model, q), self.capsules)
        ends = np.round(np.concatenate([a[0], b[0]], axis=1), 6).tolist()
        return {"capsules": ends, "tcp": column_major(self.model.fk(q[0]).to_matrix())}


def cell_description(cell: Cell | None) -> dict:
    """The cell file's floor height, keep-out boxes and keep-in box (metres, base frame), or an empty cell."""
    if cell is None:
        return {"floor": None, "boxes": [], "keep_in": None, "margin": None}

    def box(item: Box) -> dict:
        return {"name": item.name, "min": [float(v) for v in item.lo], "max": [float(v) for v in item.hi]}

    return {"floor": cell.floor_z, "boxes": [box(item) for item in cell.boxes],
            "keep_in": None if cell.keep_in is None else box(cell.keep_in), "margin": cell.margin}


def pose_frames(steps: list[Step]) -> list[dict]:
    """Every waypoint of the program as a small named frame: its TCP pose (recorded, or resolved through its
    base); a program whose relative waypoints do not resolve shows its recorded poses only."""
    try:
        targets = resolve_targets(steps)
    except ValueError:   # a relative waypoint whose base is gone: the recorded poses still show
        targets = resolve_targets([step for step in steps if isinstance(step, Waypoint)])
    return [{"name": name, "matrix": column_major(target.pose.to_matrix()),
             "relative": not isinstance(target.step, Waypoint)} for name, target in targets.items()]
