"""URScript settings and state built-ins: TCP, payload, and the getters of the controller's state.

Settings (TCP, payload) are read from the controller's own settings, never from a snapshot field. The state getters
are table-driven: one row per built-in names the ControllerState field it reads and the URScript value it returns;
each call reads `controller.state()` when it runs (commands commit to it before they return).
"""
from collections.abc import Callable
from typing import Any

from sim_ursim.urscript.builtins.arguments import as_number, as_pose_array, controller_call, to_list, to_pose
from sim_ursim.urscript.builtins.registry import builtin, register
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import ScriptError, number_list


@builtin
def set_tcp(ctx: ThreadContext, pose):
    """TCP offset in the flange frame."""
    controller_call(ctx.controller.set_tcp, as_pose_array(pose, "pose"))


@builtin
def set_payload(ctx: ThreadContext, m, cog=None):
    """Payload mass [kg] and optional centre of gravity [m] in the flange frame."""
    controller_call(ctx.controller.set_payload, as_number(m, "m"), None if cog is None else number_list(cog, 3, "cog"))


@builtin
def set_payload_mass(ctx: ThreadContext, m):
    """Payload mass [kg], centre of gravity unchanged."""
    controller_call(ctx.controller.set_payload, as_number(m, "m"))


@builtin
def set_payload_cog(ctx: ThreadContext, cog):
    """Payload centre of gravity [m] in the flange frame, mass unchanged."""
    mass = float(ctx.controller.payload[0])
    controller_call(ctx.controller.set_payload, mass, number_list(cog, 3, "cog"))


@builtin
def set_target_payload(ctx: ThreadContext, m, cog, inertia=None, transition_time=0):
    """Payload mass, centre of gravity and optional inertia [Ixx Iyy Izz Ixy Ixz Iyz] (5.10+); the change is applied
    at once (transition_time [s], 5.12+, accepted: payload changes have no dynamic effect in the simulator)."""
    as_number(transition_time, "transition_time")
    controller_call(ctx.controller.set_payload, as_number(m, "m"), number_list(cog, 3, "cog"),
                     None if inertia is None else number_list(inertia, 6, "inertia"))


@builtin
def get_steptime(ctx: ThreadContext):
    """One control cycle [s]: 0.008 on CB3, 0.002 on e-series."""
    return float(ctx.controller.period)


# built-in name, ControllerState field, URScript value, what it returns
_STATE_GETTERS: tuple[tuple[str, str, Callable[[Any], Any], str], ...] = (
    ("get_actual_joint_positions", "actual_q", to_list, "Measured joints [rad]."),
    # Used by URCL's External Control script, not in UR's manual: the measured joints, as its name says.
    ("get_joint_positions", "actual_q", to_list, "Measured joints [rad] (URCL's name for get_actual_joint_positions)."),
    ("get_target_joint_positions", "target_q", to_list, "Commanded joints [rad]."),
    ("get_actual_joint_speeds", "actual_qd", to_list, "Measured joint speeds [rad/s]."),
    ("get_target_joint_speeds", "target_qd", to_list, "Commanded joint speeds [rad/s]."),
    ("get_target_joint_accelerations", "target_qdd", to_list, "Commanded joint accelerations [rad/s²]."),
    ("get_actual_tcp_pose", "actual_tcp_pose", to_pose, "Measured TCP pose in the base frame."),
    ("get_target_tcp_pose", "target_tcp_pose", to_pose, "Commanded TCP pose in the base frame."),
    ("get_target_waypoint", "target_tcp_pose", to_pose,
     "Where the current motion ends (joints solved to a TCP pose); the target pose when no motion is queued."),
    ("get_actual_tcp_speed", "actual_tcp_speed", to_list, "Measured TCP twist [m/s, rad/s]."),
    ("get_target_tcp_speed", "target_tcp_speed", to_list, "Commanded TCP twist [m/s, rad/s]."),
    ("get_actual_tool_flange_pose", "flange_pose", to_pose, "Flange (DH frame 6) pose in the base frame."),
    ("get_tcp_force", "actual_tcp_force", to_pose,
     "Wrench at the TCP [N, Nm] in the base frame, as the controller reports it (a pose-typed value)."),
)


def _state_getter(name: str, field: str, convert: Callable[[Any], Any], doc: str) -> Callable[[Any], Any]:
    """A built-in returning `convert(controller.state().<field>)`."""

    def getter(ctx: ThreadContext):
        return convert(getattr(ctx.controller.state(), field))

    getter.__name__, getter.__doc__ = name, doc
    return getter


for _row in _STATE_GETTERS:
    register(_row[0], _state_getter(*_row))


@builtin
def get_actual_joint_positions_history(ctx: ThreadContext, steps=0):
    """Measured joints [rad] `steps` control cycles ago (0: as get_actual_joint_positions); the simulator keeps the
    last controller.JOINT_HISTORY_CYCLES (a cycle that caught up after a stall counts its missed periods)."""
    count = as_number(steps, "steps")
    history = ctx.controller.joint_history
    if count != int(count) or not 0 <= count < len(history):
        raise ScriptError(f"runtime_error:get_actual_joint_positions_history: steps must be a whole number from 0 "
                          f"to {len(history) - 1}, got {count:g}:")
    return to_list(history[-1 - int(count)])


@builtin
def get_tcp_offset(ctx: ThreadContext):
    """Active TCP offset in the flange frame."""
    return to_pose(ctx.controller.tcp_offset)


@builtin
def get_target_payload(ctx: ThreadContext):
    """Payload mass [kg]."""
    return float(ctx.controller.payload[0])


@builtin
def get_target_payload_cog(ctx: ThreadContext):
    """Payload centre of gravity [m]."""
    return to_list(ctx.controller.payload[1])


@builtin
def get_target_payload_inertia(ctx: ThreadContext):
    """Payload inertia [Ixx Iyy Izz Ixy Ixz Iyz]."""
    return to_list(ctx.controller.payload[2])
