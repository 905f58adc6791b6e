"""Capsule model of the UR links, batched DH frames, and the distance kernels of the path check.

The link capsules (segment + radius, each in one DH frame) come from UR's published geometry:
* the lateral offsets of the arm's planes, from UR's own ROS description (UniversalRobots/
  Universal_Robots_ROS2_Description, config/<model>/physical_parameters.yaml, `offsets`: "measured from model"):
  the upper arm runs at `shoulder_offset` along the shoulder axis from the base axis, the forearm at
  `elbow_offset` (the forearm plane's own offset there; ROS-Industrial's older ur_description gave the same
  plane as shoulder_offset + a negative elbow_offset, e.g. UR10 0.220941 − 0.1719 = 0.049042 in both), and the
  wrist 1 axis ends at d4 (the DH model folds these into d4);
* the radii: half the joint-housing / tube diameters of UR's dimension drawings (base ∅128/149/190 mm for the
  3/5/10 sizes), rounded up, then kept below the planes' spacing so that neighbouring links' capsules do not touch
  in any configuration the real arm can take. They are envelopes, not meshes: the check is conservative by a few
  millimetres to a centimetre around the tubes.

Bodies (index = the joint that moves them last): 0 base, 1 shoulder, 2 upper arm, 3 forearm (with the elbow
housing), 4 wrist 1, 5 wrist 2, 6 wrist 3, 7 tool. Self-collision is checked for the pairs in SELF_PAIRS: adjacent
bodies are excluded, and so are the wrist's own bodies among each other (4–6, 5–tool, forearm–wrist 2): their
housings touch by construction.

Frames are 4×4 matrices of all samples at once from the kinematics' compiled DH chain (TCP not included: the tool
is given in the flange frame); a calibrated arm's bodies are placed by its catalogue table (body_model).
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ur3dq.array_types import FloatArray, IntArray
from ur3dq.kinematics import MODEL_NAMES, robot_model, ur_ik
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck.cell import ToolShape

BODY_NAMES = ("base", "shoulder", "upper arm", "forearm", "wrist 1", "wrist 2", "wrist 3", "tool")
TOOL = 7

# model: (shoulder_offset, elbow_offset = the forearm plane's offset, radii of base, shoulder, upper arm, forearm,
# wrist), metres; the offsets exactly as UR's description gives them (module docstring).
_LINK_GEOMETRY = {
    "ur3": (0.1198, 0.0275, (0.064, 0.045, 0.045, 0.038, 0.032)),
    "ur3e": (0.120, 0.027, (0.064, 0.045, 0.045, 0.038, 0.032)),
    "ur5": (0.13585, 0.0165, (0.075, 0.060, 0.055, 0.045, 0.040)),
    "ur5e": (0.138, 0.007, (0.075, 0.060, 0.055, 0.045, 0.040)),
    "ur10": (0.220941, 0.049042, (0.095, 0.075, 0.070, 0.055, 0.045)),
    "ur10e": (0.1762, 0.0393, (0.095, 0.075, 0.070, 0.055, 0.045)),
    "ur16e": (0.176, 0.040, (0.095, 0.075, 0.070, 0.055, 0.045)),
}

SELF_PAIRS = tuple((a, b) for a in (0, 1) for b in (3, 4, 5, 6, TOOL)) + \
    ((2, 4), (2, 5), (2, 6), (2, TOOL), (3, 6), (3, TOOL))


@dataclasses.dataclass(frozen=True)
class Capsules:
    """The link capsules of an arm, as arrays.

    C capsules: body (C,) index into BODY_NAMES, frame (C,) DH frame 0..6 they are fixed in, a/b (C, 3) end
    points in that frame, radius (C,)."""

    body: IntArray
    frame: IntArray
    a: FloatArray
    b: FloatArray
    radius: FloatArray


@functools.cache
def _catalogue_model(name: str) -> URModel:
    """The catalogue model ``name`` (built once)."""
    return robot_model(name)


def body_model(model: URModel) -> URModel:
    """The model whose DH frames place the link bodies: ``model`` itself, or for a calibrated arm of the catalogue its
    catalogue table. A factory calibration writes the parallel axes with hundreds of metres of cancelling d offsets,
    so its frame origins lie nowhere near the links, while it moves the links themselves by millimetres, well inside
    the capsules' envelopes. The joints (and the TCP path) are the calibrated model's."""
    if model.dh.is_nominal_structure() or model.name not in MODEL_NAMES:
        return model
    return _catalogue_model(model.name)


def link_capsules(model: URModel, tool: ToolShape | None = None) -> Capsules:
    """The capsules of `model` (a URModel, calibrated or not: placed by body_model) plus the ToolShape `tool`."""
    if model.name not in _LINK_GEOMETRY:
        raise ValueError(f"model: no link capsules for {model.name!r} (known: {', '.join(_LINK_GEOMETRY)})")
    model = body_model(model)
    shoulder, forearm, (r_base, r_shoulder, r_upper, r_forearm, r_wrist) = _LINK_GEOMETRY[model.name]
    a2, a3 = model.dh.a[1], model.dh.a[2]
    d1, d4, d5, d6 = model.dh.d[0], model.dh.d[3], model.dh.d[4], model.dh.d[5]
    rows = [  # body, frame, a, b, radius
        (0, 0, (0, 0, 0), (0, 0, d1), r_base),
        (1, 1, (0, 0, 0), (0, 0, shoulder), r_shoulder),
        (2, 2, (-a2, 0, shoulder), (0, 0, shoulder), r_upper),
        (3, 3, (-a3, 0, shoulder), (-a3, 0, forearm), r_forearm),      # elbow housing, along the elbow axis
        (3, 3, (-a3, 0, forearm), (0, 0, forearm), r_forearm),
        (4, 3, (0, 0, forearm), (0, 0, d4), r_wrist),                  # along the wrist 1 axis
        (5, 4, (0, 0, 0), (0, 0, d5), r_wrist),                        # along the wrist 2 axis
        (6, 5, (0, 0, 0), (0, 0, d6), r_wrist),                        # along the wrist 3 axis, to the flange
    ]
    if tool is not None:
        rows.append((TOOL, 6, tuple(tool.a), tuple(tool.b), tool.radius))
    return Capsules(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                    np.array([r[2] for r in rows], dtype=float), np.array([r[3] for r in rows], dtype=float),
                    np.array([r[4] for r in rows], dtype=float))


def dh_frames(model: URModel, q: FloatArray) -> FloatArray:
    """(N, 7, 4, 4) DH frames 0..6 (6 = flange, no TCP) of the link bodies (body_model) in the base frame for joints
    q (N, 6): the kinematics' compiled DH chain (ur3dq.kinematics.ur_ik.dh_frames)."""
    return ur_ik.dh_frames(body_model(model), q)


def capsule_points(frames: FloatArray, capsules: Capsules) -> tuple[FloatArray, FloatArray]:
    """(A, B): (N, C, 3) capsule end points in the base frame for frames (N, 7, 4, 4)."""
    chosen = frames[:, capsules.frame]                       # (N, C, 4, 4)
    rotation, origin = chosen[..., :3, :3], chosen[..., :3, 3]

    def placed(p: FloatArray) -> FloatArray:
        # R·p + o as three column products: cheaper than einsum on these tiny matrices
        return rotation[..., 0] * p[:, 0, None] + rotation[..., 1] * p[:, 1, None] + rotation[..., 2] * p[:, 2, None] \
            + origin

    return placed(capsules.a), placed(capsules.b)


def segment_segment_distance(p0: FloatArray, p1: FloatArray, q0: FloatArray, q1: FloatArray) -> FloatArray:
    """Distance between segments p0→p1 and q0→q1 (arrays (..., 3), broadcast), exact (Ericson, §5.1.9)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    f = np.einsum("...i,...i->...", d2, r)
    c = np.einsum("...i,...i->...", d1, r)
    b = np.einsum("...i,...i->...", d1, d2)
    tiny = 1e-18
    denominator = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denominator > tiny, np.clip((b * f - c * e) / denominator, 0.0, 1.0), 0.0)
        t = np.where(e > tiny, (b * s + f) / e, 0.0)
        # t outside [0, 1]: clamp it and recompute s for that end of the second segment.
        s = np.where(t < 0.0, np.where(a > tiny, np.clip(-c / a, 0.0, 1.0), 0.0), s)
        s = np.where(t > 1.0, np.where(a > tiny, np.clip((b - c) / a, 0.0, 1.0), 0.0), s)
        # The second segment a point: the first segment's point nearest it.
        s = np.where(e <= tiny, np.where(a > tiny, np.clip(-c / a, 0.0, 1.0), 0.0), s)
    t = np.clip(t, 0.0, 1.0)
    gap = (p0 + d1 * s[..., None]) - (q0 + d2 * t[..., None])
    distance: FloatArray = np.sqrt(np.einsum("...i,...i->...", gap, gap))
    return distance


def segment_box_bound(p0: FloatArray, p1: FloatArray, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """A cheap lower bound of segment-to-box distances.

    A lower bound of the distance from segments p0→p1 to boxes [lo, hi] (broadcast (..., 3)): the gap between
    the box and the segment's own bounding box (0 where they overlap). Cheap; exact when the gap is along an axis."""
    gap = np.maximum(np.maximum(lo - np.maximum(p0, p1), np.minimum(p0, p1) - hi), 0.0)
    bound: FloatArray = np.sqrt(np.einsum("...i,...i->...", gap, gap))
    return bound


def segment_box_distance(p0: FloatArray, p1: FloatArray, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """Signed distance from segments p0→p1 (..., 3) to axis-aligned boxes [lo, hi] (broadcast (..., 3)).

    Outside: the exact distance (the squared distance along the segment is a convex piecewise quadratic with its
    pieces split where a coordinate crosses a face plane: each piece's minimum is taken in closed form). A segment
    entering the box gets −(depth of its deepest candidate point inside), a lower bound of the true depth.
    """
    p0, p1, lo, hi = np.broadcast_arrays(p0, p1, lo, hi)
    d = p1 - p0
    with np.errstate(divide="ignore", invalid="ignore"):
        crossings = np.concatenate(((lo - p0) / d, (hi - p0) / d), axis=-1)
    crossings = np.clip(np.nan_to_num(crossings, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0)
    shape = p0.shape[:-1]
    ends = np.concatenate((np.zeros(shape + (1,)), crossings, np.ones(shape + (1,))), axis=-1)
    ends.sort(axis=-1)
    start, stop = ends[..., :-1], ends[..., 1:]                         # (..., 7) pieces
    middle = 0.5 * (start + stop)
    point = p0[..., None, :] + d[..., None, :] * middle[..., None]      # (..., 7, 3)
    bound = np.where(point < lo[..., None, :], lo[..., None, :], np.where(point > hi[..., None, :],
                                                                          hi[..., None, :], np.nan))
    active = ~np.isnan(bound)
    slope = np.where(active, d[..., None, :], 0.0)
    offset = np.where(active, p0[..., None, :] - np.nan_to_num(bound), 0.0)
    curvature = np.sum(slope * slope, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        best = np.where(curvature > 0, -np.sum(slope * offset, axis=-1) / curvature, middle)
    best = np.clip(best, start, stop)
    value = slope * best[..., None] + offset
    outside = np.sqrt(np.min(np.sum(value * value, axis=-1), axis=-1))
    # Inside depth at the candidate points (piece middles and ends): how far the deepest one is from every face.
    candidates = np.concatenate((point, p0[..., None, :] + d[..., None, :] * ends[..., None]), axis=-2)
    depth = np.min(np.minimum(candidates - lo[..., None, :], hi[..., None, :] - candidates), axis=-1)
    signed: FloatArray = np.where(outside > 0.0, outside, -np.maximum(np.max(depth, axis=-1), 0.0))
    return signed
