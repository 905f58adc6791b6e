"""URScript pose built-ins: composition, inverse, addition/subtraction, distances, interpolation, RPY (pure).

Poses are p[x, y, z, rx, ry, rz] in metres with a rotation vector in radians.
"""
import math

import numpy as np

from sim_ursim import kinematics
from sim_ursim.urscript.builtins.arguments import as_number, as_pose_array, to_list, to_pose
from sim_ursim.urscript.builtins.registry import builtin
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import number_list


@builtin
def pose_trans(ctx: ThreadContext, p_from, p_from_to):
    """Pose composition p_from · p_from_to (the second pose expressed in the first one's frame)."""
    first = kinematics.pose_to_matrix(as_pose_array(p_from, "p_from"))
    matrix = first @ kinematics.pose_to_matrix(as_pose_array(p_from_to, "p_from_to"))
    return to_pose(kinematics.matrix_to_pose(matrix))


@builtin
def pose_inv(ctx: ThreadContext, p_from):
    """Inverse transform of a pose."""
    return to_pose(kinematics.matrix_to_pose(np.linalg.inv(kinematics.pose_to_matrix(as_pose_array(p_from, "p_from")))))


@builtin
def pose_add(ctx: ThreadContext, p_1, p_2):
    """URScript pose addition: positions added, rotations composed p_1.R · p_2.R."""
    a, b = as_pose_array(p_1, "p_1"), as_pose_array(p_2, "p_2")
    rotation = kinematics.rotation_vector_to_matrix(a[3:]) @ kinematics.rotation_vector_to_matrix(b[3:])
    return to_pose(np.concatenate([a[:3] + b[:3], kinematics.matrix_to_rotation_vector(rotation)]))


@builtin
def pose_sub(ctx: ThreadContext, p_to, p_from):
    """URScript pose subtraction: positions subtracted, rotation p_from.R⁻¹ · p_to.R (undoes pose_add(p_from, x))."""
    a, b = as_pose_array(p_to, "p_to"), as_pose_array(p_from, "p_from")
    rotation = kinematics.rotation_vector_to_matrix(b[3:]).T @ kinematics.rotation_vector_to_matrix(a[3:])
    return to_pose(np.concatenate([a[:3] - b[:3], kinematics.matrix_to_rotation_vector(rotation)]))


@builtin
def pose_dist(ctx: ThreadContext, p_from, p_to):
    """sqrt(Δposition² + Δangle²) between two poses (metres and radians mixed, as URScript defines it)."""
    a = kinematics.pose_to_matrix(as_pose_array(p_from, "p_from"))
    b = kinematics.pose_to_matrix(as_pose_array(p_to, "p_to"))
    return math.hypot(float(np.linalg.norm(a[:3, 3] - b[:3, 3])), kinematics.rotation_angle_between(a, b))


@builtin
def point_dist(ctx: ThreadContext, p_from, p_to):
    """Distance between the positions of two poses [m]."""
    return float(np.linalg.norm(as_pose_array(p_from, "p_from")[:3] - as_pose_array(p_to, "p_to")[:3]))


@builtin
def interpolate_pose(ctx: ThreadContext, p_from, p_to, alpha):
    """Pose a fraction alpha (0..1) along the line from p_from to p_to, orientation at a constant angular rate."""
    start = kinematics.pose_to_matrix(as_pose_array(p_from, "p_from"))
    end = kinematics.pose_to_matrix(as_pose_array(p_to, "p_to"))
    matrix = kinematics.interpolate_pose(start, end, as_number(alpha, "alpha"))
    return to_pose(kinematics.matrix_to_pose(matrix))


@builtin
def rotvec2rpy(ctx: ThreadContext, rotation_vector):
    """Rotation vector -> [roll, pitch, yaw] (R = Rz(yaw) · Ry(pitch) · Rx(roll))."""
    r = kinematics.rotation_vector_to_matrix(number_list(rotation_vector, 3, "rotation_vector"))
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    if abs(math.cos(pitch)) < 1e-12:  # gimbal lock: put the whole rotation about z into yaw
        return [0.0, pitch, math.atan2(-r[0, 1], r[1, 1])]
    return [math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])]


@builtin
def rpy2rotvec(ctx: ThreadContext, rpy_vector):
    """[roll, pitch, yaw] (R = Rz(yaw) · Ry(pitch) · Rx(roll)) -> rotation vector."""
    roll, pitch, yaw = number_list(rpy_vector, 3, "rpy_vector")
    rz = kinematics.rotation_vector_to_matrix([0.0, 0.0, yaw])
    ry = kinematics.rotation_vector_to_matrix([0.0, pitch, 0.0])
    rx = kinematics.rotation_vector_to_matrix([roll, 0.0, 0.0])
    return to_list(kinematics.matrix_to_rotation_vector(rz @ ry @ rx))
