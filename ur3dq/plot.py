"""A PNG of recorded poses: the TCP path through them and a stick figure of the arm at each (matplotlib, Agg).

The arm is drawn from the model's own DH frames, so the figure shows exactly the geometry the IK used. Base frame,
metres.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ur3dq.dualquat import DualQuaternion
from ur3dq.store import write_atomically


def arm_points(model, joints) -> np.ndarray:
    """The arm's stick figure at `joints`: the origins of its frames.

    (7, 3) points of the arm's stick figure in the base frame (metres): the origins of the model's own frames
    0..6 at `joints` (radians), the last one being the TCP."""
    return np.array([DualQuaternion.from_array(frame).translation for frame in model.frames(joints)])


def plot_poses(path, model, steps, title: str = "", path_check=None, cell=None) -> None:
    """Write a PNG of the planned TCP path and the arm at each pose.

    Write a PNG to `path`: the TCP path through the planned `steps` (PlanStep: .pose, .joints) and the arm at
    each, labelled with the pose names, on `model` (a robot_model); with `path_check` (a PathCheckResult) also the
    swept TCP path, the arm's capsules at the worst sample and the obstacles of `cell` (ur3dq.pathcheck.drawing)."""
    import matplotlib

    matplotlib.use("Agg")  # no display on a shop-floor PC or in CI
    from matplotlib import pyplot

    figure = pyplot.figure(figsize=(8, 7), dpi=100)
    try:
        axes = figure.add_subplot(projection="3d")
        tcp_points = np.array([step.pose.dq.translation for step in steps])
        colours = pyplot.get_cmap("viridis")(np.linspace(0.0, 0.9, len(steps)))
        drawn = [tcp_points, np.zeros((1, 3))]
        for step, colour in zip(steps, colours):
            points = arm_points(model.with_tcp(step.pose.tcp_offset), step.joints)
            drawn.append(points)
            axes.plot(points[:, 0], points[:, 1], points[:, 2], "-o", color=colour, markersize=3, linewidth=2,
                      alpha=0.8)
            axes.text(*points[-1], f" {step.pose.name}", fontsize=8)
        axes.plot(tcp_points[:, 0], tcp_points[:, 1], tcp_points[:, 2], "--", color="crimson", linewidth=1.5,
                  label="TCP path")
        axes.scatter(tcp_points[:, 0], tcp_points[:, 1], tcp_points[:, 2], color="crimson", s=20)
        if path_check is not None:
            from ur3dq.pathcheck.drawing import draw_path_check

            drawn.append(draw_path_check(axes, model, path_check, cell))
        _equal_aspect(axes, np.vstack(drawn))
        axes.set_xlabel("x (m)")
        axes.set_ylabel("y (m)")
        axes.set_zlabel("z (m)")
        axes.set_title(title or f"{len(steps)} poses on a {model.name} (base frame)")
        axes.legend(loc="upper left")
        # render in memory, then replace the file atomically: a failure leaves no 0-byte PNG, and the error
        # (StoreError) names the file
        buffer = io.BytesIO()
        figure.savefig(buffer, format="png")
        write_atomically(Path(path), buffer.getvalue())
    finally:
        pyplot.close(figure)


def _equal_aspect(axes, points: np.ndarray) -> None:
    """Give the 3-D axes one scale on x, y and z around `points`, so the arm is not distorted."""
    centre = (points.max(axis=0) + points.min(axis=0)) / 2.0
    half = max(float(np.max(points.max(axis=0) - points.min(axis=0))) / 2.0, 0.1)
    axes.set_xlim(centre[0] - half, centre[0] + half)
    axes.set_ylim(centre[1] - half, centre[1] + half)
    axes.set_zlim(centre[2] - half, centre[2] + half)
    axes.set_box_aspect((1, 1, 1))
