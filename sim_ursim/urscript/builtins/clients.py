"""URScript built-ins that UR's client programs reach beyond the core families:
URCL's External Control script, ur_rtde's control script, urx.  Strings, lists, matrices, analog inputs, tool
power (movec is with the other moves in motion.py).  Each follows UR's script manual; where the simulator
approximates, the docstring says how.
"""
import random as _random

import numpy as np

from sim_ursim import kinematics
from sim_ursim.urscript.builtins.arguments import controller_call as _call
from sim_ursim.urscript.builtins.registry import builtin
from sim_ursim.urscript.values import ScriptError, number_list, to_str

TOOL_VOLTAGES = (0, 12, 24)


def _text(value, name):
    if not isinstance(value, str):
        raise ScriptError(f"runtime_error:{name} must be a string, got {to_str(value)}:")
    return value


def _index(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
        raise ScriptError(f"runtime_error:{name} must be an integer, got {to_str(value)}:")
    return int(value)


# --- strings ----------------------------------------------------------------------------------------------------

@builtin
def str_len(ctx, text):
    """Number of characters."""
    return len(_text(text, "str"))


@builtin
def str_empty(ctx, text):
    """True for ""."""
    return len(_text(text, "str")) == 0


@builtin
def str_at(ctx, text, index):
    """The character at `index` (0-based); ScriptError outside the string."""
    text, index = _text(text, "str"), _index(index, "index")
    if not 0 <= index < len(text):
        raise ScriptError(f"runtime_error:str_at: index {index} is outside a string of {len(text)} characters:")
    return text[index]


@builtin
def str_find(ctx, text, target, start_from=0):
    """Index of the first `target` at or after `start_from`, or -1."""
    return _text(text, "str").find(_text(target, "target"), _index(start_from, "start_from"))


@builtin
def str_sub(ctx, text, index, length=None):
    """The substring from `index` of `length` characters (to the end without one); "" when index is past it."""
    text, index = _text(text, "str"), _index(index, "index")
    if index < 0:
        raise ScriptError(f"runtime_error:str_sub: negative index {index}:")
    if length is None:
        return text[index:]
    return text[index:index + max(0, _index(length, "length"))]


# --- lists and matrices -----------------------------------------------------------------------------------------

@builtin
def get_list_length(ctx, values):
    """Number of elements of a list (a pose has 6)."""
    if not isinstance(values, list):
        raise ScriptError(f"runtime_error:get_list_length needs a list, got {to_str(values)}:")
    return len(values)


@builtin
def random(ctx):
    """A random float in [0, 1)."""
    return _random.random()


def _matrix(value, name):
    """A URScript matrix (list of equal-length number lists, or a list of numbers as one row) as a 2-D array."""
    if not isinstance(value, list) or not value:
        raise ScriptError(f"runtime_error:{name} must be a matrix, got {to_str(value)}:")
    rows = value if isinstance(value[0], list) else [value]
    try:
        matrix = np.array([number_list(row, len(rows[0]), name) for row in rows], dtype=float)
    except ScriptError:
        raise ScriptError(f"runtime_error:{name} must have rows of equal length:") from None
    return matrix


def _matrix_value(matrix):
    return [[float(v) for v in row] for row in matrix]


@builtin
def transpose(ctx, value):
    """Transposed matrix (a plain list is a row and becomes a column)."""
    return _matrix_value(_matrix(value, "transpose").T)


@builtin
def inv(ctx, value):
    """Inverse of a square matrix; ScriptError for a singular one."""
    matrix = _matrix(value, "inv")
    if matrix.shape[0] != matrix.shape[1]:
        raise ScriptError(f"runtime_error:inv needs a square matrix, got {matrix.shape[0]}x{matrix.shape[1]}:")
    if abs(np.linalg.det(matrix)) < 1e-12:
        raise ScriptError("runtime_error:inv: the matrix is singular:")
    return _matrix_value(np.linalg.inv(matrix))


@builtin
def wrench_trans(ctx, T_from_to, w_from):
    """The wrench w_from [Fx, Fy, Fz, Mx, My, Mz] expressed in the frame T_from_to points to (moments about its
    origin): F_to = Rᵀ F, M_to = Rᵀ (M − p × F)."""
    transform = kinematics.pose_to_matrix(np.array(number_list(T_from_to, 6, "T_from_to")))
    wrench = np.array(number_list(w_from, 6, "w_from"))
    rotation, origin = transform[:3, :3], transform[:3, 3]
    force = rotation.T @ wrench[:3]
    moment = rotation.T @ (wrench[3:] - np.cross(origin, wrench[:3]))
    return [float(v) for v in np.concatenate([force, moment])]


# --- I/O ----------------------------------------------------------------------------------------------------------

def _analog(ctx, prefix, n):
    n = _index(n, "n")
    if n not in (0, 1):
        raise ScriptError(f"runtime_error:analog input {n} does not exist (0 or 1):")
    return float(getattr(ctx.controller.state(), f"{prefix}{n}"))


@builtin
def get_standard_analog_in(ctx, n):
    """Control-box analog input n (0, 1) [V or A, as configured]."""
    return _analog(ctx, "standard_analog_input", n)


@builtin
def get_tool_analog_in(ctx, n):
    """Tool analog input n (0, 1)."""
    return _analog(ctx, "tool_analog_input", n)


@builtin
def get_analog_in(ctx, n):
    """Legacy analog input: 0, 1 the control box, 2, 3 the tool."""
    n = _index(n, "n")
    if n in (2, 3):
        return get_tool_analog_in(ctx, n - 2)
    return get_standard_analog_in(ctx, n)


@builtin
def set_tool_voltage(ctx, voltage):
    """Tool power supply 0, 12 or 24 V: checked and accepted; the simulated tool draws no power, so the state keeps
    reporting the idle tool (tool_output_voltage 0 in RTDE)."""
    if _index(voltage, "voltage") not in TOOL_VOLTAGES:
        raise ScriptError(f"runtime_error:set_tool_voltage: {to_str(voltage)} V is not one of 0, 12, 24:")


@builtin
def ft_rtde_input_enable(ctx, enable, sensor_mass=0.0, sensor_measuring_offset=None, sensor_cog=None):
    """Use the RTDE input external_force_torque as the F/T sensor (arguments checked).  The simulator always reports
    that input as the TCP wrench (actual_TCP_force), enabled or not: there is no other sensor to switch from."""
    if not isinstance(enable, bool):
        raise ScriptError(f"runtime_error:ft_rtde_input_enable needs True or False, got {to_str(enable)}:")
    if isinstance(sensor_mass, bool) or not isinstance(sensor_mass, (int, float)) or sensor_mass < 0:
        raise ScriptError("runtime_error:ft_rtde_input_enable: sensor_mass must be >= 0 kg:")
    for name, value in (("sensor_measuring_offset", sensor_measuring_offset), ("sensor_cog", sensor_cog)):
        if value is not None:
            number_list(value, 3, name)


@builtin
def enable_external_ft_sensor(ctx, enable, sensor_mass=0.0, sensor_measuring_offset=None, sensor_cog=None):
    """Deprecated name of ft_rtde_input_enable (UR's manual), same behaviour."""
    ft_rtde_input_enable(ctx, enable, sensor_mass, sensor_measuring_offset, sensor_cog)


# --- dynamics ----------------------------------------------------------------------------------------------------

@builtin
def get_joint_torques(ctx):
    """Joint torques [Nm] "corrected by the torque needed to move the robot itself (gravity, friction, etc.)" (UR's
    script manual): what is left is the external load, τ = Jᵀ·w with w the wrench at the TCP in the base frame
    (actual_TCP_force, e.g. fed through RTDE external_force_torque).  No contact is modelled, so a free arm reads
    zeros, as a correctly configured robot at rest does."""
    state = ctx.controller.state()
    jacobian = kinematics.geometric_jacobian(ctx.controller.model.dh, state.actual_q, state.tcp_offset)
    return [float(v) for v in jacobian.T @ np.asarray(state.actual_tcp_force, dtype=float)]


# --- force mode (free-space approximation) -----------------------------------------------------------------------

FORCE_MODE_ACCELERATION = 1.0  # m/s² (rad/s² for rotations) at which the free-space drift reaches its speed limit
FORCE_MODE_TYPES = (1, 2, 3)


@builtin
def force_mode(ctx, task_frame, selection_vector, wrench, type, limits):
    """Force mode, approximated for an arm in free space (no contact is modelled): along each compliant axis
    (selection 1) with a non-zero wrench component nothing resists, so the TCP moves at that axis' speed limit
    (`limits`, m/s or rad/s) in the direction of the force/torque, in `task_frame`; other axes hold still.  The arm
    keeps drifting until end_force_mode(), another motion, or a limit stops it (a protective stop, as a real arm
    pushing into nothing would reach).  Frame types 1–3 are checked; the frame is used as given."""
    frame = kinematics.pose_to_matrix(np.array(number_list(task_frame, 6, "task_frame")))
    selection = number_list(selection_vector, 6, "selection_vector")
    if any(value not in (0, 1) for value in selection):
        raise ScriptError(f"runtime_error:force_mode: selection_vector must hold 0 or 1, got {to_str(selection)}:")
    forces = np.array(number_list(wrench, 6, "wrench"))
    speed_limits = np.array(number_list(limits, 6, "limits"))
    if _index(type, "type") not in FORCE_MODE_TYPES:
        raise ScriptError(f"runtime_error:force_mode: type must be 1, 2 or 3, got {to_str(type)}:")
    if np.any(speed_limits < 0):
        raise ScriptError(f"runtime_error:force_mode: limits must be >= 0, got {to_str(list(speed_limits))}:")
    drift = np.where(np.array(selection) == 1, np.sign(forces) * speed_limits, 0.0)
    rotation = frame[:3, :3]
    twist = np.concatenate([rotation @ drift[:3], rotation @ drift[3:]])
    _call(ctx.controller.speedl, twist, FORCE_MODE_ACCELERATION, 0.0)


@builtin
def end_force_mode(ctx):
    """Leave force mode: the free-space drift decelerates to rest (stopl)."""
    _call(ctx.controller.stopl, FORCE_MODE_ACCELERATION * 10)
