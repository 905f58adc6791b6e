"""Replay planning: the joint target for each recorded pose, chosen before the arm moves (pure, no robot).

Each pose is solved with its own recorded TCP offset, so the flange goes where it was when the pose was recorded.
Among every FK-verified IK solution (and its ±2π variants inside the limits) the planner takes the one closest to
the pose's recorded joints when it has them, else to the previous target (the arm's joints for the first pose).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import JointLimitError, SafetyCheckError, UnreachablePoseError
from ur3dq.pose import Pose
from ur3dq.robot import motion

SOURCE_RECORDED = "recorded joints"
SOURCE_IK_RECORDED = "IK nearest recorded"
SOURCE_IK_PREVIOUS = "IK nearest previous"
SOURCE_IK_ZERO = "IK nearest zero"  # no robot joints known (dry run without a robot)


@dataclasses.dataclass(frozen=True)
class PlanStep:
    """One move of a replay: the pose, its joint target (rad), how it was chosen, and the move's figures."""

    pose: Pose
    joints: np.ndarray
    source: str
    solutions: int           # FK-verified IK solutions of the pose (0 when replaying recorded joints)
    travel: float | None     # largest joint travel from the previous target (rad); None when the start is unknown
    duration: float | None   # movej seconds at 100 % speed; None when the start is unknown
    fk_error_m: float        # model FK of the target vs the recorded pose
    fk_error_rad: float


def tcp_pose_for(pose: Pose, tcp_now: DualQuaternion) -> DualQuaternion:
    """Where the TCP `tcp_now` (flange frame) is when the flange sits where `pose` put it: σ·tcp_rec⁻¹·tcp_now."""
    return pose.dq * DualQuaternion.from_ur_pose(pose.tcp_offset).inverse() * tcp_now


def choose_joints(model, pose: Pose, previous, replay_recorded_joints: bool):
    """(joint target, source, number of IK solutions) for `pose` on `model` (a robot_model; its TCP is ignored)."""
    solver = model.with_tcp(pose.tcp_offset)
    if replay_recorded_joints:
        if pose.joints is None:
            raise ValueError(f"pose {pose.name!r} has no recorded joints (imported from thesis lines?); "
                             "replay it without --joints")
        if pose.robot_model != model.name:
            raise ValueError(f"pose {pose.name!r} was recorded on a {pose.robot_model}; its joints mean nothing "
                             f"on this {model.name}: replay it without --joints")
        q = np.asarray(pose.joints, dtype=float)
        try:
            solver.check_joints(q)
        except (JointLimitError, ValueError) as error:
            raise JointLimitError(f"pose {pose.name!r}: {error}") from None
        return q, SOURCE_RECORDED, 0
    if pose.joints is not None:
        reference, source = np.asarray(pose.joints, dtype=float), SOURCE_IK_RECORDED
    elif previous is not None:
        reference, source = np.asarray(previous, dtype=float), SOURCE_IK_PREVIOUS
    else:
        reference, source = np.zeros(6), SOURCE_IK_ZERO
    try:
        solutions = solver.ik_all(pose.dq)
        q = solver.ik(pose.dq, reference)
    except UnreachablePoseError as error:
        raise UnreachablePoseError(f"pose {pose.name!r} is unreachable on the {model.name}: {error}") from None
    return np.asarray(q, dtype=float), source, len(solutions)


def plan_replay(model, poses, start_joints=None, a=1.4, v=1.05, replay_recorded_joints=False,
                max_joint_travel=None) -> list[PlanStep]:
    """The replay plan of `poses` from `start_joints` (rad, or None if unknown) with movej a (rad/s²), v (rad/s).

    Raises (naming the pose) if one is unreachable, outside the limits, or (with `max_joint_travel`, rad) would
    swing a joint further than that in one move: nothing moves unless the whole plan is sound.
    """
    steps = []
    previous = None if start_joints is None else np.asarray(start_joints, dtype=float)
    for pose in poses:
        q, source, count = choose_joints(model, pose, previous, replay_recorded_joints)
        travel = None if previous is None else motion.leading_travel(previous, q)
        if max_joint_travel is not None and travel is not None and travel > max_joint_travel:
            raise SafetyCheckError(
                f"pose {pose.name!r}: a joint would travel {travel:.3f} rad in one move, more than --max-travel "
                f"{max_joint_travel:.3f} rad (record an intermediate pose, or raise --max-travel)")
        metres, radians = model.with_tcp(pose.tcp_offset).fk(q).distance(pose.dq)
        duration = None if previous is None else motion.movej_duration(previous, q, a, v)
        steps.append(PlanStep(pose, q, source, count, travel, duration, metres, radians))
        previous = q
    return steps


def loop_closing_travel(steps) -> float:
    """The largest joint travel (rad) from the plan's last target back to its first, the move between loops."""
    return motion.leading_travel(steps[-1].joints, steps[0].joints)
