"""Factory-style calibration tables: the DH table a real controller reports for a slightly imperfect arm.

A real UR's Kinematics Info is not "nominal + millimetres". UR's factory calibration measures the arm's joint axes
and writes the standard-DH table of *those* lines. Joints 2, 3 and 4 of a UR are nominally parallel; measured, they
are a fraction of a milliradian apart, so the common normal between two of them lies hundreds of metres away along
the axes and the table carries huge, cancelling d2/d3/d4 offsets, θ offsets near ±π/2 and tiny α's (UR's own
calibration documentation shows a UR10e with d = [0.1805, 439.14, −446.03, 7.0603, 0.1198, 0.1157] m). A client's
IK must work with such tables; the simulator reports one when asked (``--calibration factory[:SEED]``).

How a table is made here: take the nominal arm's frames at q = 0, tilt and move its joint axes slightly (seeded:
up to 0.5 mrad and 0.5 mm, the "physical" arm), then derive the standard DH of those axis lines (common normals
between successive axes). The deltas returned are that table minus nominal, which is what the simulator adds to its
nominal rows; its Kinematics Info then reports the factory-style table.
"""
from __future__ import annotations

import math

import numpy as np

from .kinematics import dh_matrix, joint_frames

#: Largest perturbation of the physical arm: rad on α and θ, metres on a and d (a few times UR's tolerances).
ANGLE_SPREAD = 5e-4
LENGTH_SPREAD = 5e-4

#: The UR10e table printed in UR's calibration documentation (absolute values, rounded as published).
UR10E_DOCUMENTED = {
    "a": [2.1e-5, 0.0193, -0.5693, -4.6e-5, -6.4e-5, 0.0],
    "d": [0.1805, 439.14, -446.03, 7.0603, 0.1198, 0.1157],
    "alpha": [1.5701, 0.00139, 0.00694, 1.5700, -1.5704, 0.0],
    "theta": [-2.4e-7, 1.6023, -1.6861, 0.0837, -1.0e-7, 3.9e-8],
}


def _angle_about(axis, start, end) -> float:
    """The angle turning unit vector ``start`` onto ``end`` about unit ``axis`` (both ⟂ axis), in (−π, π]."""
    return math.atan2(float(np.dot(np.cross(start, end), axis)), float(np.dot(start, end)))


def _small_rotation(rng, spread: float) -> np.ndarray:
    """A rotation matrix by a uniform angle in [0, spread] rad about a random axis (Rodrigues)."""
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = rng.uniform(0.0, spread)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def dh_of_axes(frames) -> dict:
    """Standard DH {a, d, alpha, theta: 6 floats} of a 6R arm whose frames at q = 0 are ``frames`` (7 4×4 matrices,
    base first): joint i turns about the z axis of frame i−1; the flange (frame 6) must lie on joint 6's axis with
    z parallel to it (a6 = α6 = 0, as in every UR table). Each row runs along the common normal of two successive
    axes, so for nearly parallel axes its d is huge and the next one cancels it, as in a controller's table."""
    origin, x_axis, z_axis = frames[0][:3, 3], frames[0][:3, 0], frames[0][:3, 2]
    rows: dict[str, list[float]] = {"a": [], "d": [], "alpha": [], "theta": []}
    for i in range(1, 7):
        point, direction = frames[i][:3, 3], frames[i][:3, 2]
        if i < 6:   # the common normal of joint i's axis (origin, z) and joint i+1's (point, direction)
            normal = np.cross(z_axis, direction)
            normal /= np.linalg.norm(normal)
            gap, cosine = point - origin, float(np.dot(z_axis, direction))
            along, _ = np.linalg.solve([[1.0, -cosine], [cosine, -1.0]], [np.dot(gap, z_axis), np.dot(gap, direction)])
            new_origin = origin + along * z_axis + np.dot(gap, normal) * normal
            new_x = normal
        else:       # the flange frame as it is: rz(θ6)·tz(d6)
            along, new_origin, new_x = float(np.dot(point - origin, z_axis)), point, frames[i][:3, 0]
        rows["theta"].append(_angle_about(z_axis, x_axis, new_x))
        rows["d"].append(float(along))
        rows["a"].append(float(np.dot(new_origin - origin - along * z_axis, new_x)))
        rows["alpha"].append(_angle_about(new_x, z_axis, direction))
        origin, x_axis, z_axis = new_origin, new_x, direction
    return rows


def factory_calibration(nominal_dh, seed: int = 0) -> dict:
    """DH deltas {a, d, alpha, theta: 6 floats} that turn the nominal rows ``nominal_dh`` = (a, d, alpha, theta)
    into the factory-style table of a slightly imperfect arm (module notes); ``seed`` picks the arm.

    The arm: the nominal frames at q = 0, joint axes 2–6 each tilted by up to ANGLE_SPREAD about a random axis and
    moved by up to LENGTH_SPREAD; the flange sits on joint 6's axis at d6 ± LENGTH_SPREAD."""
    rng = np.random.default_rng(seed)
    nominal = [np.asarray(column, dtype=float) for column in nominal_dh]
    a, d, alpha, theta = nominal
    frames = [np.array(frame) for frame in joint_frames((a, d, alpha, theta), np.zeros(6))]
    for i in range(1, 6):
        frames[i][:3, :3] = _small_rotation(rng, ANGLE_SPREAD) @ frames[i][:3, :3]
        frames[i][:3, 3] += rng.uniform(-LENGTH_SPREAD, LENGTH_SPREAD, 3)
    frames[6] = frames[5] @ dh_matrix(0.0, nominal[1][5] + rng.uniform(-LENGTH_SPREAD, LENGTH_SPREAD),
                                      0.0, rng.uniform(-ANGLE_SPREAD, ANGLE_SPREAD))
    table = dh_of_axes(frames)
    return {key: np.asarray(table[key]) - column for key, column in zip(("a", "d", "alpha", "theta"), nominal)}
