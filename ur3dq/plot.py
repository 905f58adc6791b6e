"""A PNG of a planned path: the TCP path through its poses and a stick figure of the arm at each (matplotlib, Agg).

The arm is drawn from the model's own DH frames, so the figure shows exactly the geometry the IK used. Base frame,
metres.
"""
from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ur3dq.dualquat import DualQuaternion
from ur3dq.store import write_atomically


def arm_points(model, joints) -> np.ndarray:
    """The arm's stick figure at `joints`: the origins of its frames.

    (7, 3) points of the arm's stick figure in the base frame (metres): the origins of the model's own frames
    0..6 at `joints` (radians), the last one being the TCP."""
    return np.array([DualQuaternion.from_array(frame).translation for frame in model.frames(joints)])


class ArmAt(NamedTuple):
    """One arm of the figure: its label, its joints (rad, shape (6,)) and the TCP offset it aims with (a UR pose
    vector, shape (6,), in the flange frame)."""

    name: str
    joints: np.ndarray
    tcp_offset: Sequence[float]


def plot_poses(path, model, arms: Sequence[ArmAt], title: str = "", path_check=None, cell=None) -> None:
    """Write a PNG of the planned TCP path and the arm at each pose.

    Write a PNG to `path`: the arm of `model` (a robot_model) at each of `arms`, labelled with its name, and the TCP
    path through them; with `path_check` (a PathCheckResult) also the swept TCP path, the arm's capsules at the
    worst sample and the obstacles of `cell` (ur3dq.pathcheck.drawing).

    Examples
    --------
    >>> import tempfile
    >>> from ur3dq.kinematics import robot_model
    >>> q = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     plot_poses(Path(folder, "arm.png"), robot_model("ur3"), [ArmAt("pick", q, (0.0,) * 6)])
    ...     Path(folder, "arm.png").read_bytes()[:4]
    b'\\x89PNG'
    """
    import matplotlib

    matplotlib.use("Agg")  # no display on a shop-floor PC or in CI
    from matplotlib import pyplot

    figure = pyplot.figure(figsize=(8, 7), dpi=100)
    try:
        axes = figure.add_subplot(projection="3d")
        figures = [arm_points(model.with_tcp(arm.tcp_offset), arm.joints) for arm in arms]
        tcp_points = np.array([points[-1] for points in figures])
        colours = pyplot.get_cmap("viridis")(np.linspace(0.0, 0.9, len(arms)))
        drawn = [tcp_points, np.zeros((1, 3)), *figures]
        for arm, points, colour in zip(arms, figures, colours):
            axes.plot(points[:, 0], points[:, 1], points[:, 2], "-o", color=colour, markersize=3, linewidth=2,
                      alpha=0.8)
            axes.text(*points[-1], f" {arm.name}", fontsize=8)
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
        axes.set_title(title or f"{len(arms)} poses on a {model.name} (base frame)")
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
