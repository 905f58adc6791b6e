"""The path the controller takes for each move, sampled densely (pure numpy over all samples of a move).

Joint moves (movej): every joint on the same normalised profile, so the path is the straight line q0 → q1 in joint
space whatever the timing; it is sampled uniformly in that fraction.

Linear and process moves (movel, movep): the TCP position moves on the straight line p0 → p1 and the orientation
turns at a constant rate about one fixed axis, the shortest rotation between the end orientations — as sim_ursim's
LinearMove (kinematics.interpolate_pose: R(s) = R0 · exp(s · log(R0ᵀ R1)), the rotation-vector interpolation UR
documents for movel). In dual quaternions this is the *decoupled* interpolation
    σ(s) = r(s) + ε ½ p(s) r(s),   r(s) = r0 ⊗ (r0* ⊗ r1)^s  (SLERP),   p(s) = p0 + s (p1 − p0),
not ScLERP σ0 ⊗ (σ0* ⊗ σ1)^s, which would move the TCP on a screw (a helix, not a line) whenever it also turns.
Both share r(s); they differ in the translation only when the orientation changes.
The path parameter s is the controller's: it runs over the larger of the path length (m) and the turn (rad).

Joints along a Cartesian move come from the analytic IK of every sample at once (ur_ik.ik_all_batch), following
the IK branch of the move's start configuration (what an IK seeded with the previous cycle's joints does away
from singularities); where that branch stops existing, the branch nearest its last value is taken, and the joint
step check then reports the flip. Joints are unwrapped along the path (no ±2π jumps), starting at the start
joints. A move whose joints step more than the joint resolution between samples is resampled finer (once, up to
MAX_REFINEMENT times denser).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from ur3dq import dqarray
from ur3dq.array_types import FloatArray
from ur3dq.kinematics import ur_ik
from ur3dq.kinematics.models import URModel

MAX_REFINEMENT = 16
MAX_SAMPLES_PER_MOVE = 200_000


class TooManySamples(ValueError):
    """A move whose resolutions ask more than MAX_SAMPLES_PER_MOVE samples (a move of many turns, or a very fine
    resolution): it is not sampled, so the check stays bounded in time and memory."""

    def __init__(self, needed: float) -> None:
        super().__init__(f"{needed:.3g} samples needed")
        self.needed = needed


def _sample_count(*needed: float) -> int:
    """The samples a move needs (≥ 1); TooManySamples past MAX_SAMPLES_PER_MOVE."""
    count = max(1.0, *needed)
    if not count <= MAX_SAMPLES_PER_MOVE:
        raise TooManySamples(count)
    return math.ceil(count)


@dataclasses.dataclass(frozen=True)
class SampledMove:
    """The samples of one move.

    fraction (n,) in [0, 1]; joints (n, 6) rad (only the reachable prefix); poses (n, 8) TCP poses of those
    joints; unreachable_at: the fraction where the IK found no solution (None if the whole move is reachable)
    and the TCP pose (8,) asked for there."""

    fraction: FloatArray
    joints: FloatArray
    poses: FloatArray
    unreachable_at: float | None = None
    unreachable_pose: FloatArray | None = None


def sample_joint_move(model: URModel, q0: npt.ArrayLike, q1: npt.ArrayLike, tcp_resolution: float,
                      joint_resolution: float) -> SampledMove:
    """Sample a joint move q0 → q1.

    Samples of the synchronised joint interpolation q0 → q1: ≤ joint_resolution (rad) per joint and ≤
    tcp_resolution (m) of TCP chord between neighbours (TooManySamples if that asks more than MAX_SAMPLES_PER_MOVE
    at the joint resolution; the TCP refinement stops there)."""
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    count = _sample_count(float(np.max(np.abs(q1 - q0))) / joint_resolution)
    fraction, joints, poses = _joint_samples(model, q0, q1, count)
    chord = _largest_chord(poses)
    if chord > tcp_resolution:
        count = min(MAX_SAMPLES_PER_MOVE, count * math.ceil(chord / tcp_resolution))
        fraction, joints, poses = _joint_samples(model, q0, q1, count)
    return SampledMove(fraction, joints, poses)


def _joint_samples(model: URModel, q0: FloatArray, q1: FloatArray, count: int
                   ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(fraction (count + 1,), joints (count + 1, 6), TCP poses (count + 1, 8)) evenly along q0 → q1."""
    fraction = np.linspace(0.0, 1.0, count + 1)
    joints = q0 + (q1 - q0) * fraction[:, None]
    joints[-1] = q1   # q0 + (q1 − q0)·1 may miss q1 by a rounding step; the move ends on its target
    return fraction, joints, np.ascontiguousarray(model.fk_batch(joints))


def _largest_chord(poses: FloatArray) -> float:
    """The longest TCP step (m) between neighbouring poses (n, 8)."""
    if len(poses) < 2:
        return 0.0
    positions = dqarray.translation_unchecked(poses)
    return float(np.max(np.linalg.norm(np.diff(positions, axis=0), axis=1)))


def line_poses(pose0: FloatArray, pose1: FloatArray, fraction: FloatArray) -> FloatArray:
    """(n, 8) TCP poses at `fraction` (n,) along the controller's linear path pose0 → pose1 (see the module doc)."""
    r0, r1 = pose0[:4], pose1[:4]
    p0, p1 = dqarray.translation_unchecked(pose0), dqarray.translation_unchecked(pose1)
    turn = dqarray.quaternion_to_rotation_vector(dqarray.quaternion_multiply(dqarray.quaternion_conjugate(r0), r1))
    rotation = dqarray.quaternion_multiply(r0, dqarray.rotation_vector_to_quaternion(fraction[:, None] * turn))
    position = p0 + (p1 - p0) * fraction[:, None]
    pure = np.concatenate((np.zeros((len(fraction), 1)), position), axis=1)
    return np.concatenate((rotation, 0.5 * dqarray.quaternion_multiply(pure, rotation)), axis=1)


def line_length(pose0: FloatArray, pose1: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(metres, radians) of the linear move pose0 → pose1; the controller's path 'distance' is their maximum."""
    return dqarray.pose_distance(pose0, pose1)


def sample_linear_move(model: URModel, q0: npt.ArrayLike, pose1: FloatArray, tcp_resolution: float,
                       joint_resolution: float) -> SampledMove:
    """Samples of the linear move from the joints q0 to the TCP pose pose1 (8,), IK with branch continuity
    (TooManySamples if the resolutions ask more than MAX_SAMPLES_PER_MOVE)."""
    q0 = np.asarray(q0, dtype=float)
    pose0 = model.fk(q0).to_array()
    metres, radians = (float(x) for x in line_length(pose0, pose1))
    count = _sample_count(metres / tcp_resolution, radians / joint_resolution)
    move = _solve_line(model, q0, pose0, pose1, count)
    steps = np.abs(np.diff(move.joints, axis=0))
    if len(steps) and float(steps.max()) > joint_resolution:
        factor = min(MAX_REFINEMENT, math.ceil(float(steps.max()) / joint_resolution))
        move = _solve_line(model, q0, pose0, pose1, min(MAX_SAMPLES_PER_MOVE, count * factor))
    return move


def _solve_line(model: URModel, q0: FloatArray, pose0: FloatArray, pose1: FloatArray, count: int) -> SampledMove:
    """The move pose0 → pose1 from joints q0 at count + 1 even fractions, cut where the IK finds no solution."""
    fraction = np.linspace(0.0, 1.0, count + 1)
    poses = line_poses(pose0, pose1, fraction)
    joints, reachable = follow_branch(model, poses, q0)
    if reachable < len(fraction):
        return SampledMove(fraction[:reachable], joints, poses[:reachable], float(fraction[reachable]),
                           poses[reachable])
    return SampledMove(fraction, joints, poses)


def follow_branch(model: URModel, poses: FloatArray, q0: FloatArray) -> tuple[FloatArray, int]:
    """IK of poses along the branch of a start configuration.

    (joints (m, 6), m): IK of `poses` (n, 8) along the branch of q0 (poses[0] is q0's own pose), unwrapped from
    q0; m ≤ n is the number of leading samples that have any solution at all."""
    solutions = ur_ik.ik_all_batch(model, poses, q_ref=q0)                    # (n, 8, 6), NaN where absent
    reachable = ~np.all(np.isnan(solutions[:, :, 0]), axis=1)
    m = len(poses) if reachable.all() else int(np.argmin(reachable))
    solutions = solutions[:m]
    if m == 0:
        return np.empty((0, 6)), 0
    start_cost = _wrapped_cost(solutions[0], q0)
    branch = int(np.argmin(start_cost))
    primary = solutions[:, branch]
    valid = ~np.isnan(primary[:, 0])
    # Where the start's branch is absent (merged at a singularity), aim for its last value (forward fill).
    last_valid = np.maximum.accumulate(np.where(valid, np.arange(m), -1))
    reference = np.where((last_valid >= 0)[:, None], primary[np.maximum(last_valid, 0)], ur_ik.wrap_angle(q0))
    chosen = np.where(valid[:, None], primary, np.nan)
    if not valid.all():
        cost = np.sum(ur_ik.wrap_angle(solutions - reference[:, None, :]) ** 2, axis=2)
        best = np.argmin(np.where(np.isnan(cost), np.inf, cost), axis=1)
        chosen = np.where(valid[:, None], primary, solutions[np.arange(m), best])
    unwrapped = np.unwrap(np.vstack((q0, chosen)), axis=0)[1:]
    return unwrapped, m


def _wrapped_cost(candidates: FloatArray, q: FloatArray) -> FloatArray:
    """Squared wrapped joint distance of each candidate (..., 6) from q (6,); +inf for a NaN (absent) one."""
    cost = np.sum(ur_ik.wrap_angle(candidates - q) ** 2, axis=-1)
    return np.where(np.isnan(cost), np.inf, cost)
