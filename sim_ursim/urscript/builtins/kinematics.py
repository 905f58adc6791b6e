"""URScript kinematics built-ins: forward/inverse kinematics, reachability, the Jacobian.

Without an explicit `tcp` argument they use the controller's active TCP, read from the controller at the call.
"""
import numpy as np

from sim_ursim import kinematics
from sim_ursim.urscript.builtins.arguments import as_pose_array, controller_call, to_list, to_pose
from sim_ursim.urscript.builtins.registry import builtin
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import Pose, ScriptError, number_list


@builtin
def get_forward_kin(ctx: ThreadContext, q=None, tcp=None):
    """TCP pose at joints q (default: the actual joints) with the active TCP or `tcp`."""
    joints = ctx.controller.state().actual_q if q is None else number_list(q, 6, "q")
    if tcp is None:
        return to_pose(controller_call(ctx.controller.fk, joints))
    return to_pose(kinematics.tcp_pose(ctx.controller.model.dh, np.array(joints), as_pose_array(tcp, "tcp")))


@builtin
def get_inverse_kin(ctx: ThreadContext, x, qnear=None, maxPositionError=1e-10, maxOrientationError=1e-10, tcp=None):
    """Joints reaching pose x nearest to qnear (default: the actual joints), with the active TCP or `tcp`."""
    near = ctx.controller.state().actual_q if qnear is None else np.array(number_list(qnear, 6, "qnear"))
    if tcp is None:
        return to_list(controller_call(ctx.controller.ik, as_pose_array(x, "x"), near))
    return to_list(controller_call(kinematics.inverse_kinematics, ctx.controller.model.dh, as_pose_array(x, "x"), near,
                                     as_pose_array(tcp, "tcp")))


@builtin
def get_inverse_kin_has_solution(ctx: ThreadContext, pose, qnear=None, maxPositionError=1e-10,
                                 maxOrientationError=1e-10, tcp=None):
    """True when get_inverse_kin would find joints for `pose`."""
    try:
        get_inverse_kin(ctx, pose, qnear, maxPositionError, maxOrientationError, tcp)
    except ScriptError:
        return False
    return True


@builtin
def is_within_safety_limits(ctx: ThreadContext, pose, qnear=None):
    """True when `pose` (or joint list) is reachable with joints inside the limits."""
    model = ctx.controller.model
    if isinstance(pose, Pose):
        try:
            q = get_inverse_kin(ctx, pose, qnear)
        except ScriptError:
            return False
    else:
        q = number_list(pose, 6, "q")
    return bool(np.all((np.array(q) >= model.joint_lower) & (np.array(q) <= model.joint_upper)))


@builtin
def get_jacobian(ctx: ThreadContext, q=None, tcp=None):
    """6x6 geometric Jacobian (rows: TCP twist [v; ω] in the base frame, columns: joints) as a list of rows."""
    joints = ctx.controller.state().actual_q if q is None else np.array(number_list(q, 6, "q"))
    offset = ctx.controller.tcp_offset if tcp is None else as_pose_array(tcp, "tcp")
    jacobian = kinematics.geometric_jacobian(ctx.controller.model.dh, joints, offset)
    return [to_list(row) for row in jacobian]
