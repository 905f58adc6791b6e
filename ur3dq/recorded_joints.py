"""Recorded joints that disagree with their recorded pose: a hand edit, or joints recorded with another TCP or arm.

Replayed with ``--joints`` such a pose takes the arm to its joints, elsewhere than the pose says; replayed by IK the
joints only choose the branch. The commands that read a store say so, one line per pose.

Example
-------
>>> from ur3dq.kinematics import robot_model
>>> from ur3dq.pose import Pose
>>> q = (0.0, -1.2, 1.0, -1.4, -1.57, 0.0)
>>> edited = (0.3, -1.2, 1.0, -1.4, -1.57, 0.0)
>>> pose = Pose.from_dual_quaternion("pick", robot_model("ur3").fk(q), "ur3", joints=edited)
>>> [(off.pose.name, round(off.radians, 3)) for off in joints_off_pose([pose])]
[('pick', 0.3)]
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ur3dq import dqarray
from ur3dq.kinematics.models import URModel, robot_model
from ur3dq.pose import Pose

#: A pose recorded on a calibrated arm differs from its joints' FK on the nominal model by the calibration (a few
#: millimetres, a fraction of a degree); past these the joints and the pose are two different places.
AGREEMENT_METRES = 0.02
AGREEMENT_RADIANS = math.radians(2.0)


@dataclass(frozen=True)
class JointsOffPose:
    """A pose whose recorded joints put its TCP ``metres`` and ``radians`` away from the recorded pose."""

    pose: Pose
    metres: float
    radians: float


def joints_off_pose(poses: Sequence[Pose], model: URModel | None = None) -> list[JointsOffPose]:
    """The poses whose recorded joints put the TCP (the pose's own TCP offset) further than AGREEMENT_METRES or
    AGREEMENT_RADIANS from the recorded pose, in store order.

    Parameters
    ----------
    poses
        Stored poses; those without joints, or of a robot model not known here, are not judged.
    model
        The arm to judge them on (a robot's calibrated model); None: each pose's own model, nominal.
    """
    groups: dict[tuple[str, tuple[float, ...]], list[int]] = {}
    for index, pose in enumerate(poses):
        if pose.joints is not None:
            groups.setdefault((pose.robot_model if model is None else "", pose.tcp_offset), []).append(index)
    found: dict[int, JointsOffPose] = {}
    for (name, tcp), indices in groups.items():
        try:
            arm = model if model is not None else robot_model(name)
        except ValueError:
            continue
        # the dual-quaternion chain's batch FK (numpy): the judgement needs no compiled kernel
        reached = arm.with_tcp(list(tcp)).chain.fk_batch(np.array([poses[i].joints for i in indices]))
        metres, radians = dqarray.pose_distance(reached, np.array([poses[i].dual_quaternion for i in indices]))
        for index, m, r in zip(indices, metres.tolist(), radians.tolist(), strict=True):
            if m > AGREEMENT_METRES or r > AGREEMENT_RADIANS:
                found[index] = JointsOffPose(poses[index], m, r)
    return [found[index] for index in sorted(found)]
