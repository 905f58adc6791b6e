"""Compiled forward kinematics of a :class:`~ur3dq.kinematics.chain.SerialChain`'s product form, with its joint axes.

The arrays are the chain's :meth:`~ur3dq.kinematics.chain.SerialChain.product_form`; poses are 8-tuples of floats
(rw rx ry rz dw dx dy dz). The joint motion, the dual-quaternion product and the read-out of a frame's z axis and
origin are the library's own leaf functions (:func:`~ur3dq.kinematics.chain.joint_motion`,
:func:`~ur3dq.dualquat.multiply_coefficients`, :func:`~ur3dq.dualquat.z_axis_coefficients`,
:func:`~ur3dq.dualquat.translation_coefficients`), compiled here: the reference (SerialChain) and this kernel share
every equation.

Example
-------
>>> import numpy as np
>>> from ur3dq.kinematics import robot_model
>>> chain = robot_model("ur3").chain
>>> constants, revolute, offsets = chain.product_form()
>>> directions, points = np.empty((6, 3)), np.empty((6, 3))
>>> end = chain_axes(constants, revolute, offsets, np.zeros(6), directions, points)
>>> bool(np.allclose(end, chain.fk(np.zeros(6)).to_array()))
True
"""
from __future__ import annotations

import numpy as np

from ur3dq.dualquat import multiply_coefficients, translation_coefficients, z_axis_coefficients
from ur3dq.kinematics.chain import joint_motion
from ur3dq.kinematics.jit import kernel

multiply = kernel(multiply_coefficients)
move_joint = kernel(joint_motion)
translation_of = kernel(translation_coefficients)
z_axis_of = kernel(z_axis_coefficients)


@kernel
def row_of(array: np.ndarray, i: int) -> tuple[float, ...]:
    """Row ``i`` of an (m, 8) array as an 8-tuple."""
    return (array[i, 0], array[i, 1], array[i, 2], array[i, 3], array[i, 4], array[i, 5], array[i, 6], array[i, 7])


@kernel
def chain_axes(constants: np.ndarray, revolute: np.ndarray, offsets: np.ndarray, q: np.ndarray,
               directions: np.ndarray, points: np.ndarray) -> tuple[float, ...]:
    """End pose σ(q) (8-tuple); fills ``directions`` and ``points`` (n, 3) with every joint's unit axis and a point
    on it, base frame: the local z axis r·k·r* and the origin of the running product just before the joint."""
    pose = row_of(constants, 0)
    for i in range(q.shape[0]):
        direction, origin = z_axis_of(pose), translation_of(pose)
        for k in range(3):
            directions[i, k], points[i, k] = direction[k], origin[k]
        pose = multiply(move_joint(pose, revolute[i], q[i] + offsets[i]), row_of(constants, i + 1))
    return pose
