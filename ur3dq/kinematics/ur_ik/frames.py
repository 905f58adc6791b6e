"""The IK's view of a TCP pose (a goal) and the thesis' FK filter (eq. 4.45) on each form of forward kinematics.

A goal (``goal_of``) is one TCP pose in the forms the kernels compare with, GOAL_SIZE floats:
FLANGE (7) the flange pair (qw, qx, qy, qz, px, py, pz) = pose · tcp⁻¹, the IK's target; FLANGE_MATRIX (9) its
rotation, row-major (Newton's target); POSE (7) the TCP pair as given; POSE_MATRIX (9) its rotation.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.arm import FK_TOLERANCE_M, FK_TOLERANCE_RAD, TCP
from ur3dq.kinematics.fk import Pair, compose, pair_of, product, rotation_matrix
from ur3dq.kinematics.jit import kernel

FLANGE, FLANGE_MATRIX, POSE, POSE_MATRIX, GOAL_SIZE = 0, 7, 16, 23, 32
#: Squared limits of the FK filter: the quaternion chord |r ∓ r_goal|² = 4·sin²(φ/4), the rotation matrices'
#: Frobenius distance ‖R − R_goal‖² = 8·sin²(φ/2), and the position.
CHORD2 = 4.0 * math.sin(0.25 * FK_TOLERANCE_RAD) ** 2
FROBENIUS2 = 8.0 * math.sin(0.5 * FK_TOLERANCE_RAD) ** 2
DISTANCE2 = FK_TOLERANCE_M ** 2


@kernel
def goal_of(arm: np.ndarray, pose: np.ndarray, goal: np.ndarray) -> None:
    """The goal (GOAL_SIZE floats, module notes) of a TCP pose's 8 coefficients on ``arm``."""
    tcp = arm[TCP:TCP + 8]
    target = pair_of(pose)
    rotation = product((target[0], target[1], target[2], target[3]), (tcp[0], -tcp[1], -tcp[2], -tcp[3]))
    flange_matrix, offset = rotation_matrix(rotation), pair_of(tcp)
    pose_matrix = rotation_matrix((target[0], target[1], target[2], target[3]))
    for k in range(9):
        goal[FLANGE_MATRIX + k], goal[POSE_MATRIX + k] = flange_matrix[k], pose_matrix[k]
    for k in range(7):
        goal[POSE + k] = target[k]
    for k in range(4):
        goal[FLANGE + k] = rotation[k]
    for k in range(3):   # p_flange = p − R_flange·t_tcp
        goal[FLANGE + 4 + k] = target[4 + k] - (flange_matrix[3 * k] * offset[4] + flange_matrix[3 * k + 1] * offset[5]
                                                + flange_matrix[3 * k + 2] * offset[6])


@kernel
def flange_meets(arm: np.ndarray, flange: Pair, goal: np.ndarray) -> bool:
    """The FK filter for a flange pair of the closed form: the TCP (flange · tcp) within FK_TOLERANCE_M and
    FK_TOLERANCE_RAD of the goal's pose (chord against the nearer sign, σ ≡ −σ)."""
    tcp = compose(flange, pair_of(arm[TCP:TCP + 8]))
    dot = tcp[0] * goal[POSE] + tcp[1] * goal[POSE + 1] + tcp[2] * goal[POSE + 2] + tcp[3] * goal[POSE + 3]
    sign = 1.0 if dot >= 0.0 else -1.0
    chord2, distance2 = 0.0, 0.0
    for k in range(4):
        chord2 += (tcp[k] - sign * goal[POSE + k]) ** 2
    for k in range(4, 7):
        distance2 += (tcp[k] - goal[POSE + k]) ** 2
    return chord2 <= CHORD2 and distance2 <= DISTANCE2


@kernel
def chain_meets(arm: np.ndarray, flange: np.ndarray, goal: np.ndarray) -> bool:
    """The FK filter for a DH chain's flange frame (12: rotation columns, origin; chain_frames' frame 6): the TCP
    within FK_TOLERANCE_M of the goal's position and its rotation within FK_TOLERANCE_RAD (Frobenius distance)."""
    offset = pair_of(arm[TCP:TCP + 8])
    tool = rotation_matrix((offset[0], offset[1], offset[2], offset[3]))
    frobenius2, distance2 = 0.0, 0.0
    for row in range(3):   # R = [x y z] by columns: R[row, col] = flange[3·col + row]
        for col in range(3):
            entry = flange[row] * tool[col] + flange[3 + row] * tool[3 + col] + flange[6 + row] * tool[6 + col]
            frobenius2 += (entry - goal[POSE_MATRIX + 3 * row + col]) ** 2
        moved = flange[row] * offset[4] + flange[3 + row] * offset[5] + flange[6 + row] * offset[6]
        distance2 += (flange[9 + row] + moved - goal[POSE + 4 + row]) ** 2
    return frobenius2 <= FROBENIUS2 and distance2 <= DISTANCE2
