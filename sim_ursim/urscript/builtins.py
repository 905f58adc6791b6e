"""URScript built-in functions: pure maths/pose functions and functions bound to the controller.

Every built-in is `f(ctx, *args)` where `ctx` is the calling script thread's ThreadContext (controller, cancel
event, waiting helpers). Units are the controller's: metres, radians, seconds; poses are p[x, y, z, rx, ry, rz]
with a rotation vector. Bad arguments raise ScriptError (the interpreter adds line and column).

Built-ins the simulator cannot back (force control, F/T sensor, dynamics) exist so that scripts using them compile,
as on the controller, and raise a run-time error naming themselves when called (`UNSUPPORTED`).
"""
import math

import numpy as np

from sim_ursim import kinematics
from sim_ursim.controller import CommandRefused
from sim_ursim.messages import PopupMessage, TextMessage
from sim_ursim.rtde.watchdog import watchdogs_of
from sim_ursim.urscript.builtins_clients import CLIENT_BUILTINS
from sim_ursim.urscript.builtins_socket import SOCKET_BUILTINS
from sim_ursim.urscript.values import Pose, ScriptError, number_list, to_str

EXTRA_BUILTINS = {**SOCKET_BUILTINS, **CLIENT_BUILTINS}

# ---------------------------------------------------------------------------------------------------- helpers


def _number(value, name):
    """`value` as a float; ScriptError naming `name` unless it is a number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScriptError(f"runtime_error:{name} must be a number, got {to_str(value)}:")
    return float(value)


def _integer(value, name):
    """`value` as an int (integral floats accepted); ScriptError naming `name` otherwise."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ScriptError(f"runtime_error:{name} must be an integer, got {to_str(value)}:")
    return value


def _pose(value, name):
    """`value` (pose or list of 6 numbers) as a float array of 6."""
    return np.array(number_list(value, 6, name))


def _to_pose(array):
    """A numpy 6-vector as a URScript pose."""
    return Pose([float(v) for v in array])


def _to_list(array):
    """A numpy vector as a URScript list of floats."""
    return [float(v) for v in array]


def _controller_call(function, *args, **kwargs):
    """Call a controller command, turning its refusals into script errors (the program stops, as on a robot)."""
    try:
        return function(*args, **kwargs)
    except (CommandRefused, kinematics.IKError, ValueError) as error:
        raise ScriptError(f"runtime_error:{error}:") from None


# ------------------------------------------------------------------------------------------------ pure maths


def _unary_math(name, function):
    def builtin(ctx, x):
        try:
            return function(_number(x, name))
        except (ValueError, OverflowError):
            raise ScriptError(f"runtime_error:{name}({to_str(x)}) is undefined:") from None

    builtin.__name__ = name
    return builtin


def atan2(ctx, y, x):
    """atan2(y, x) in radians."""
    return math.atan2(_number(y, "y"), _number(x, "x"))


def pow_(ctx, base, exponent):
    """base ** exponent (ScriptError when undefined, e.g. a negative base with a fractional exponent)."""
    try:
        result = math.pow(_number(base, "base"), _number(exponent, "exponent"))
    except (ValueError, OverflowError):
        raise ScriptError(f"runtime_error:pow({to_str(base)}, {to_str(exponent)}) is undefined:") from None
    return result


def norm(ctx, a):
    """Absolute value of a number, Euclidean norm of a list, or norm of a pose's position."""
    if isinstance(a, Pose):
        return float(np.linalg.norm(a[:3]))
    if isinstance(a, list):
        return float(np.linalg.norm(number_list(a, len(a), "a")))
    return abs(_number(a, "a"))


def length(ctx, value):
    """Number of elements of a list or characters of a string."""
    if not isinstance(value, (list, str)):
        raise ScriptError(f"runtime_error:length needs a list or string, got {to_str(value)}:")
    return len(value)


def to_str_(ctx, value):
    """URScript text of any value."""
    return to_str(value)


def str_cat(ctx, a, b):
    """Concatenation of the texts of a and b."""
    return to_str(a) + to_str(b)


def to_num(ctx, text):
    """Number written in `text` (int when it has no point or exponent)."""
    if not isinstance(text, str):
        raise ScriptError(f"runtime_error:to_num needs a string, got {to_str(text)}:")
    try:
        return int(text) if text.strip().lstrip("+-").isdigit() else float(text)
    except ValueError:
        raise ScriptError(f"runtime_error:to_num cannot read {text!r}:") from None


def floor(ctx, x):
    """Largest integer ≤ x (an int)."""
    return math.floor(_number(x, "x"))


def ceil(ctx, x):
    """Smallest integer ≥ x (an int)."""
    return math.ceil(_number(x, "x"))


def round_(ctx, x):
    """x rounded half away from zero (an int)."""
    x = _number(x, "x")
    return int(math.floor(abs(x) + 0.5)) * (1 if x >= 0 else -1)


def binary_list_to_integer(ctx, bits):
    """Integer whose bit n is bits[n] (booleans, least significant first)."""
    if not isinstance(bits, list):
        raise ScriptError(f"runtime_error:binary_list_to_integer needs a list, got {to_str(bits)}:")
    return sum(1 << n for n, bit in enumerate(bits) if bit)


def integer_to_binary_list(ctx, x):
    """32 booleans, bit n of x (two's complement) at index n."""
    x = _integer(x, "x") & 0xFFFFFFFF
    return [bool((x >> n) & 1) for n in range(32)]


# ------------------------------------------------------------------------------------------------ pose maths


def pose_trans(ctx, p_from, p_from_to):
    """Pose composition p_from · p_from_to (the second pose expressed in the first one's frame)."""
    first = kinematics.pose_to_matrix(_pose(p_from, "p_from"))
    matrix = first @ kinematics.pose_to_matrix(_pose(p_from_to, "p_from_to"))
    return _to_pose(kinematics.matrix_to_pose(matrix))


def pose_inv(ctx, p_from):
    """Inverse transform of a pose."""
    return _to_pose(kinematics.matrix_to_pose(np.linalg.inv(kinematics.pose_to_matrix(_pose(p_from, "p_from")))))


def pose_add(ctx, p_1, p_2):
    """URScript pose addition: positions added, rotations composed p_1.R · p_2.R."""
    a, b = _pose(p_1, "p_1"), _pose(p_2, "p_2")
    rotation = kinematics.rotation_vector_to_matrix(a[3:]) @ kinematics.rotation_vector_to_matrix(b[3:])
    return _to_pose(np.concatenate([a[:3] + b[:3], kinematics.matrix_to_rotation_vector(rotation)]))


def pose_sub(ctx, p_to, p_from):
    """URScript pose subtraction: positions subtracted, rotation p_from.R⁻¹ · p_to.R (undoes pose_add(p_from, x))."""
    a, b = _pose(p_to, "p_to"), _pose(p_from, "p_from")
    rotation = kinematics.rotation_vector_to_matrix(b[3:]).T @ kinematics.rotation_vector_to_matrix(a[3:])
    return _to_pose(np.concatenate([a[:3] - b[:3], kinematics.matrix_to_rotation_vector(rotation)]))


def pose_dist(ctx, p_from, p_to):
    """sqrt(Δposition² + Δangle²) between two poses (metres and radians mixed, as URScript defines it)."""
    a, b = kinematics.pose_to_matrix(_pose(p_from, "p_from")), kinematics.pose_to_matrix(_pose(p_to, "p_to"))
    return math.hypot(float(np.linalg.norm(a[:3, 3] - b[:3, 3])), kinematics.rotation_angle_between(a, b))


def point_dist(ctx, p_from, p_to):
    """Distance between the positions of two poses [m]."""
    return float(np.linalg.norm(_pose(p_from, "p_from")[:3] - _pose(p_to, "p_to")[:3]))


def interpolate_pose(ctx, p_from, p_to, alpha):
    """Pose a fraction alpha (0..1) along the line from p_from to p_to, orientation at a constant angular rate."""
    matrix = kinematics.interpolate_pose(
        kinematics.pose_to_matrix(_pose(p_from, "p_from")), kinematics.pose_to_matrix(_pose(p_to, "p_to")),
        _number(alpha, "alpha"),
    )
    return _to_pose(kinematics.matrix_to_pose(matrix))


def rotvec2rpy(ctx, rotation_vector):
    """Rotation vector -> [roll, pitch, yaw] (R = Rz(yaw) · Ry(pitch) · Rx(roll))."""
    r = kinematics.rotation_vector_to_matrix(number_list(rotation_vector, 3, "rotation_vector"))
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    if abs(math.cos(pitch)) < 1e-12:  # gimbal lock: put the whole rotation about z into yaw
        return [0.0, pitch, math.atan2(-r[0, 1], r[1, 1])]
    return [math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])]


def rpy2rotvec(ctx, rpy_vector):
    """[roll, pitch, yaw] (R = Rz(yaw) · Ry(pitch) · Rx(roll)) -> rotation vector."""
    roll, pitch, yaw = number_list(rpy_vector, 3, "rpy_vector")
    rz = kinematics.rotation_vector_to_matrix([0.0, 0.0, yaw])
    ry = kinematics.rotation_vector_to_matrix([0.0, pitch, 0.0])
    rx = kinematics.rotation_vector_to_matrix([roll, 0.0, 0.0])
    return _to_list(kinematics.matrix_to_rotation_vector(rz @ ry @ rx))


# ------------------------------------------------------------------------------------------------ motion


def _unreachable_stops(ctx, function, *args):
    """Call a motion command; an unreachable target protective-stops the arm with a robot error code (C209 error
    message on 30001) and ends the program, as a controller does, instead of a URScript runtime exception."""
    try:
        return function(*args)
    except kinematics.IKError as error:
        ctx.controller.protective_stop(f"target unreachable: {error}")
        ctx.check()  # the protective stop stopped this program: Cancelled ends it without a runtime exception
        raise ScriptError(f"runtime_error:{error}:") from None


def _joint_target(ctx, q):
    """movej's target: a joint list, or a pose solved by IK near the joints where the queued motion ends."""
    if isinstance(q, Pose):
        state = ctx.controller.state()
        return _controller_call(_unreachable_stops, ctx, ctx.controller.ik, np.array(q), state.target_q)
    return np.array(number_list(q, 6, "q"))


def _pose_target(ctx, pose):
    """movel's target: a pose, or a joint list converted by forward kinematics."""
    if isinstance(pose, Pose):
        return np.array(pose)
    return _controller_call(ctx.controller.fk, number_list(pose, 6, "q"))


def movej(ctx, q, a=1.4, v=1.05, t=0, r=0):
    """Joint move (leading axis a [rad/s²], v [rad/s], t [s] overrides); blocks until done, or within r [m]."""
    target = _joint_target(ctx, q)
    ctx.run_motion(lambda: _controller_call(ctx.controller.movej, target, a, v, t, r))


def movel(ctx, pose, a=1.2, v=0.25, t=0, r=0):
    """Linear TCP move (a [m/s²], v [m/s], t [s] overrides); blocks until done, or within r [m]."""
    target = _pose_target(ctx, pose)
    # Reachability first (the controller refuses an unreachable movel like any other refusal): see _unreachable_stops.
    _controller_call(_unreachable_stops, ctx, ctx.controller.ik, target, ctx.controller.state().target_q)
    ctx.run_motion(lambda: _controller_call(ctx.controller.movel, target, a, v, t, r))


def movep(ctx, pose, a=1.2, v=0.25, r=0):
    """Process move: modelled as a linear move (the constant-speed circular blends are not emulated)."""
    movel(ctx, pose, a, v, 0, r)


def _wait_for(ctx, seconds):
    """Return after `seconds` (at least one control cycle) of controller time, interruptibly."""
    if seconds > 0:
        ctx.sleep(seconds)
    else:
        ctx.sync()


def speedj(ctx, qd, a, t=None):
    """Accelerate the joints to speeds qd [rad/s] at a [rad/s²] and keep them; returns after t [s], or without t
    once the speeds are reached (the ramp time max|Δqd| / a)."""
    qd = np.array(number_list(qd, 6, "qd"))
    acceleration = _number(a, "a")
    if acceleration == 0.0:
        # Zero acceleration: the speeds cannot change, the joints keep the speeds they have (URCL's spline
        # interpolation sends a = 0 when consecutive speeds are equal; controllers accept it).
        qd = np.array(ctx.controller.state().target_qd)
        acceleration = 1.0
    _controller_call(ctx.controller.speedj, qd, acceleration, 0.0)
    if t is None:
        _wait_for(ctx, float(np.max(np.abs(qd - ctx.controller.state().actual_qd))) / acceleration)
    else:
        _wait_for(ctx, _number(t, "t"))


def speedl(ctx, xd, a, t=None, aRot=None):
    """Accelerate the TCP to twist xd [m/s, rad/s] at a [m/s²] and keep it; returns after t [s], or without t
    once the linear speed is reached (the ramp time |Δv| / a)."""
    xd = np.array(number_list(xd, 6, "xd"))
    acceleration = _number(a, "a")
    _controller_call(ctx.controller.speedl, xd, acceleration, 0.0)
    if t is None:
        _wait_for(ctx, float(np.linalg.norm(xd[:3] - ctx.controller.state().actual_tcp_speed[:3])) / acceleration)
    else:
        _wait_for(ctx, _number(t, "t"))


def servoj(ctx, q, a=0, v=0, t=0.008, lookahead_time=0.1, gain=300):
    """Servo to joints q, arriving after t [s]; blocks for t, as the controller does."""
    q = number_list(q, 6, "q")
    duration = _number(t, "t")
    _controller_call(ctx.controller.servoj, q, a, v, duration, lookahead_time, gain)
    _wait_for(ctx, duration)


def stopj(ctx, a):
    """Decelerate the joints to rest at a [rad/s²]; blocks until the arm stands still."""
    deceleration = _number(a, "a")
    ctx.run_motion(lambda: _controller_call(ctx.controller.stopj, deceleration))


def stopl(ctx, a, aRot=None):
    """Decelerate the TCP to rest at a [m/s²]; blocks until the arm stands still."""
    deceleration = _number(a, "a")
    ctx.run_motion(lambda: _controller_call(ctx.controller.stopl, deceleration))


def sleep(ctx, t):
    """Wait t seconds."""
    seconds = _number(t, "t")
    if seconds < 0:
        raise ScriptError(f"runtime_error:sleep time must be ≥ 0, got {to_str(t)}:")
    ctx.sleep(seconds)


def sync(ctx):
    """Wait for the next control cycle (uses up the rest of this thread's physical time slot)."""
    ctx.sync()


def is_steady(ctx):
    """True when the arm stands still and no motion is active."""
    state = ctx.controller.state()
    return bool(not state.motion_active and np.all(np.abs(state.actual_qd) < 1e-6))


def freedrive_mode(ctx, *args, **kwargs):
    """Freedrive on (the axis/feature constraints of 5.x, positional or freeAxes=/feature=, accepted and ignored)."""
    _controller_call(ctx.controller.set_freedrive, True)


def end_freedrive_mode(ctx):
    """Freedrive off."""
    _controller_call(ctx.controller.set_freedrive, False)


def get_freedrive_status(ctx):
    """0 when freedrive is off, 1 when on (no singularity/limit reporting)."""
    return 1 if ctx.controller.state().freedrive else 0


# ------------------------------------------------------------------------------------------------ settings & state


def set_tcp(ctx, pose):
    """TCP offset in the flange frame."""
    _controller_call(ctx.controller.set_tcp, _pose(pose, "pose"))


def set_payload(ctx, m, cog=None):
    """Payload mass [kg] and optional centre of gravity [m] in the flange frame."""
    _controller_call(ctx.controller.set_payload, _number(m, "m"), None if cog is None else number_list(cog, 3, "cog"))


def set_payload_mass(ctx, m):
    """Payload mass [kg], centre of gravity unchanged."""
    _controller_call(ctx.controller.set_payload, _number(m, "m"))


def set_payload_cog(ctx, cog):
    """Payload centre of gravity [m] in the flange frame, mass unchanged."""
    mass = float(ctx.controller.state().payload)
    _controller_call(ctx.controller.set_payload, mass, number_list(cog, 3, "cog"))


def set_target_payload(ctx, m, cog, inertia=None, transition_time=0):
    """Payload mass, centre of gravity and optional inertia [Ixx Iyy Izz Ixy Ixz Iyz] (5.10+); the change is applied
    at once (transition_time [s], 5.12+, accepted: payload changes have no dynamic effect in the simulator)."""
    _number(transition_time, "transition_time")
    _controller_call(ctx.controller.set_payload, _number(m, "m"), number_list(cog, 3, "cog"),
                     None if inertia is None else number_list(inertia, 6, "inertia"))


def get_target_payload(ctx):
    """Payload mass [kg]."""
    return float(ctx.controller.state().payload)


def get_target_payload_cog(ctx):
    """Payload centre of gravity [m]."""
    return _to_list(ctx.controller.state().payload_cog)


def get_target_payload_inertia(ctx):
    """Payload inertia [Ixx Iyy Izz Ixy Ixz Iyz]."""
    return _to_list(ctx.controller.state().payload_inertia)


def get_actual_joint_positions(ctx):
    """Measured joints [rad]."""
    return _to_list(ctx.controller.state().actual_q)


def get_target_joint_positions(ctx):
    """Commanded joints [rad]."""
    return _to_list(ctx.controller.state().target_q)


def get_actual_joint_speeds(ctx):
    """Measured joint speeds [rad/s]."""
    return _to_list(ctx.controller.state().actual_qd)


def get_target_joint_speeds(ctx):
    """Commanded joint speeds [rad/s]."""
    return _to_list(ctx.controller.state().target_qd)


def get_actual_tcp_pose(ctx):
    """Measured TCP pose in the base frame."""
    return _to_pose(ctx.controller.state().actual_tcp_pose)


def get_target_tcp_pose(ctx):
    """Commanded TCP pose in the base frame."""
    return _to_pose(ctx.controller.state().target_tcp_pose)


def get_actual_tcp_speed(ctx):
    """Measured TCP twist [m/s, rad/s]."""
    return _to_list(ctx.controller.state().actual_tcp_speed)


def get_target_tcp_speed(ctx):
    """Commanded TCP twist [m/s, rad/s]."""
    return _to_list(ctx.controller.state().target_tcp_speed)


def get_actual_tool_flange_pose(ctx):
    """Flange (DH frame 6) pose in the base frame."""
    return _to_pose(ctx.controller.state().flange_pose)


def get_tcp_force(ctx):
    """Wrench at the TCP [N, Nm] in the base frame, as the controller reports it (a pose-typed value)."""
    return _to_pose(ctx.controller.state().actual_tcp_force)


def get_tcp_offset(ctx):
    """Active TCP offset in the flange frame."""
    return _to_pose(ctx.controller.state().tcp_offset)


def get_steptime(ctx):
    """One control cycle [s]: 0.008 on CB3, 0.002 on e-series."""
    return float(ctx.controller.period)


def get_forward_kin(ctx, q=None, tcp=None):
    """TCP pose at joints q (default: the actual joints) with the active TCP or `tcp`."""
    joints = ctx.controller.state().actual_q if q is None else number_list(q, 6, "q")
    if tcp is None:
        return _to_pose(_controller_call(ctx.controller.fk, joints))
    return _to_pose(kinematics.tcp_pose(ctx.controller.model.dh, np.array(joints), _pose(tcp, "tcp")))


def get_inverse_kin(ctx, x, qnear=None, maxPositionError=1e-10, maxOrientationError=1e-10, tcp=None):
    """Joints reaching pose x nearest to qnear (default: the actual joints), with the active TCP or `tcp`."""
    near = ctx.controller.state().actual_q if qnear is None else np.array(number_list(qnear, 6, "qnear"))
    if tcp is None:
        return _to_list(_controller_call(ctx.controller.ik, _pose(x, "x"), near))
    return _to_list(_controller_call(kinematics.inverse_kinematics, ctx.controller.model.dh, _pose(x, "x"), near,
                                     _pose(tcp, "tcp")))


def get_inverse_kin_has_solution(ctx, pose, qnear=None, maxPositionError=1e-10, maxOrientationError=1e-10, tcp=None):
    """True when get_inverse_kin would find joints for `pose`."""
    try:
        get_inverse_kin(ctx, pose, qnear, maxPositionError, maxOrientationError, tcp)
    except ScriptError:
        return False
    return True


def is_within_safety_limits(ctx, pose, qnear=None):
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


# ------------------------------------------------------------------------------------------------ messages


def textmsg(ctx, s1, s2=""):
    """Log message: the texts of s1 and s2 concatenated (primary interface text message)."""
    ctx.publish(TextMessage(text=to_str(s1) + to_str(s2)))


def popup(ctx, s, title="Popup", warning=False, error=False, blocking=False):
    """Popup message to the operator (never blocks here: there is no operator to close it)."""
    ctx.publish(PopupMessage(title=to_str(title), text=to_str(s), warning=bool(warning), error=bool(error)))


# ------------------------------------------------------------------------------------------------ I/O


def _digital_out_group(index):
    """(group, local index) of a set_digital_out/get_digital_out index: 0-7 standard, 8-15 configurable, 16-17 tool."""
    index = _integer(index, "n")
    if 0 <= index < 8:
        return "standard", index
    if 8 <= index < 16:
        return "configurable", index - 8
    if 16 <= index < 18:
        return "tool", index - 16
    raise ScriptError(f"runtime_error:digital output {index} does not exist (0..17):")


def _set_out(ctx, group, index, value):
    setter = getattr(ctx.controller.io, f"set_{group}_digital_out")
    _controller_call(setter, _integer(index, "n"), bool(value))


def _get_bit(word, index, count, what):
    index = _integer(index, "n")
    if not 0 <= index < count:
        raise ScriptError(f"runtime_error:{what} {index} does not exist (0..{count - 1}):")
    return bool((int(word) >> index) & 1)


def set_digital_out(ctx, n, b):
    """Digital output n (0-7 standard, 8-15 configurable, 16-17 tool) on or off."""
    group, index = _digital_out_group(n)
    _set_out(ctx, group, index, b)


def get_digital_out(ctx, n):
    """State of digital output n (0-7 standard, 8-15 configurable, 16-17 tool)."""
    return _get_bit(ctx.controller.io.digital_output_bits, n, 18, "digital output")


def set_standard_digital_out(ctx, n, b):
    """Standard digital output n (0-7)."""
    _set_out(ctx, "standard", n, b)


def set_configurable_digital_out(ctx, n, b):
    """Configurable digital output n (0-7)."""
    _set_out(ctx, "configurable", n, b)


def set_tool_digital_out(ctx, n, b):
    """Tool digital output n (0-1)."""
    _set_out(ctx, "tool", n, b)


def get_standard_digital_out(ctx, n):
    """State of standard digital output n (0-7)."""
    return _get_bit(ctx.controller.io.standard_digital_outputs, n, 8, "standard digital output")


def get_configurable_digital_out(ctx, n):
    """State of configurable digital output n (0-7)."""
    return _get_bit(ctx.controller.io.configurable_digital_outputs, n, 8, "configurable digital output")


def get_tool_digital_out(ctx, n):
    """State of tool digital output n (0-1)."""
    return _get_bit(ctx.controller.io.tool_digital_outputs, n, 2, "tool digital output")


def get_digital_in(ctx, n):
    """State of digital input n (0-7 standard, 8-15 configurable, 16-17 tool)."""
    return _get_bit(ctx.controller.io.digital_input_bits, n, 18, "digital input")


def get_standard_digital_in(ctx, n):
    """State of standard digital input n (0-7)."""
    return _get_bit(ctx.controller.io.standard_digital_inputs, n, 8, "standard digital input")


def get_configurable_digital_in(ctx, n):
    """State of configurable digital input n (0-7)."""
    return _get_bit(ctx.controller.io.configurable_digital_inputs, n, 8, "configurable digital input")


def get_tool_digital_in(ctx, n):
    """State of tool digital input n (0-1)."""
    return _get_bit(ctx.controller.io.tool_digital_inputs, n, 2, "tool digital input")


def set_standard_analog_out(ctx, n, f):
    """Standard analog output n (0-1) to the ratio f (0..1)."""
    _controller_call(ctx.controller.io.set_analog_out, _integer(n, "n"), _number(f, "f"))


def _register(bank, kind):
    array_name = f"{bank}_{kind}_registers"

    def read(ctx, address):
        values = getattr(ctx.controller.io, array_name)
        index = _integer(address, "address")
        if not 0 <= index < len(values):
            raise ScriptError(f"runtime_error:{bank} {kind} register {index} does not exist (0..{len(values) - 1}):")
        value = values[index]
        return bool(value) if kind == "bit" else int(value) if kind == "int" else float(value)

    return read


def _register_writer(kind):
    def write(ctx, address, value):
        setter = getattr(ctx.controller.io, f"set_{kind}_register")
        converted = {"int": lambda v: _integer(v, "value"), "double": lambda v: _number(v, "value"),
                     "bit": bool}[kind](value)
        _controller_call(setter, "output", _integer(address, "address"), converted)

    return write


# ------------------------------------------------------------------------------------------------ ur_rtde support


def rtde_set_watchdog(ctx, variable_name, min_frequency, action="pause"):
    """Arm the RTDE input watchdog of `variable_name` (sim_ursim.rtde.watchdog): pause/stop/ignore when the input
    is not updated at `min_frequency` Hz; removed when this program stops."""
    if not isinstance(variable_name, str):
        raise ScriptError(f"runtime_error:rtde_set_watchdog needs a variable name, got {to_str(variable_name)}:")
    execution = ctx.execution
    try:
        watchdogs_of(ctx.controller).arm(variable_name, _number(min_frequency, "min_frequency"), to_str(action),
                                         lambda: execution.main.done.is_set() or execution.main.cancel.is_set())
    except ValueError as error:
        raise ScriptError(f"runtime_error:rtde_set_watchdog: {error}:") from None


def get_target_waypoint(ctx):
    """Where the current motion ends (joints solved to a TCP pose); the target pose when no motion is queued."""
    return _to_pose(ctx.controller.state().target_tcp_pose)


def protective_stop(ctx):
    """Trigger a protective stop (the program then stops)."""
    ctx.controller.protective_stop("protective_stop() called by the program")
    ctx.check()


def _force_parameter(ctx, value):
    """Force-mode damping / gain scaling (0..1): checked and accepted; force mode itself is not emulated."""
    value = _number(value, "value")
    if not 0.0 <= value <= 2.0:
        raise ScriptError(f"runtime_error:force mode parameter must be 0..2, got {to_str(value)}:")


def set_gravity(ctx, d):
    """Gravity direction [m/s²] in the base frame: checked and accepted; the simulator models no dynamics."""
    number_list(d, 3, "d")


def tool_contact(ctx, direction):
    """Cycles since the tool touched something along `direction`: always 0, the simulated arm never collides."""
    number_list(direction, 6, "direction")
    return 0


def get_target_joint_accelerations(ctx):
    """Commanded joint accelerations [rad/s²]."""
    return _to_list(ctx.controller.state().target_qdd)


def get_jacobian(ctx, q=None, tcp=None):
    """6x6 geometric Jacobian (rows: TCP twist [v; ω] in the base frame, columns: joints) as a list of rows."""
    state = ctx.controller.state()
    joints = state.actual_q if q is None else np.array(number_list(q, 6, "q"))
    offset = state.tcp_offset if tcp is None else _pose(tcp, "tcp")
    jacobian = kinematics.geometric_jacobian(ctx.controller.model.dh, joints, offset)
    return [_to_list(row) for row in jacobian]


def zero_ftsensor(ctx):
    """Zero the F/T sensor: the simulated sensor always reads zero, so nothing changes."""


def _unsupported(name):
    def builtin(ctx, *args, **kwargs):
        raise ScriptError(f"runtime_error:{name} is not supported by sim_ursim:")

    builtin.__name__ = name
    return builtin


UNSUPPORTED = (
    "servoc",
    "get_actual_joint_positions_history", "direct_torque", "get_mass_matrix", "get_coriolis_and_centrifugal_torques",
    "get_jacobian_time_derivative", "teach_mode_set_params", "set_analog_inputrange",
)


def _table():
    table = {
        # maths
        "sin": _unary_math("sin", math.sin), "cos": _unary_math("cos", math.cos), "tan": _unary_math("tan", math.tan),
        "asin": _unary_math("asin", math.asin), "acos": _unary_math("acos", math.acos),
        "atan": _unary_math("atan", math.atan), "atan2": atan2, "sqrt": _unary_math("sqrt", math.sqrt),
        "log": _unary_math("log", math.log), "pow": pow_, "floor": floor, "ceil": ceil, "round": round_,
        "d2r": _unary_math("d2r", math.radians), "r2d": _unary_math("r2d", math.degrees), "norm": norm,
        "length": length, "to_str": to_str_, "str_cat": str_cat, "to_num": to_num,
        "binary_list_to_integer": binary_list_to_integer, "integer_to_binary_list": integer_to_binary_list,
        # poses
        "pose_trans": pose_trans, "pose_inv": pose_inv, "pose_add": pose_add, "pose_sub": pose_sub,
        "pose_dist": pose_dist, "point_dist": point_dist, "interpolate_pose": interpolate_pose,
        "rotvec2rpy": rotvec2rpy, "rpy2rotvec": rpy2rotvec,
        # motion
        "movej": movej, "movel": movel, "movep": movep,
        # optimove*: modelled as movej/movel with the same a/v/r (the controller's time-optimal profile is not)
        "optimovej": movej, "optimovel": movel, "speedj": speedj, "speedl": speedl, "servoj": servoj,
        "stopj": stopj, "stopl": stopl, "sleep": sleep, "sync": sync, "is_steady": is_steady,
        "freedrive_mode": freedrive_mode, "end_freedrive_mode": end_freedrive_mode,
        "teach_mode": freedrive_mode, "end_teach_mode": end_freedrive_mode,
        "get_freedrive_status": get_freedrive_status, "protective_stop": protective_stop,
        # settings and state
        "set_tcp": set_tcp, "set_payload": set_payload, "set_payload_mass": set_payload_mass,
        "set_payload_cog": set_payload_cog, "set_target_payload": set_target_payload,
        "get_target_payload": get_target_payload, "get_target_payload_cog": get_target_payload_cog,
        "get_target_payload_inertia": get_target_payload_inertia,
        "get_actual_joint_positions": get_actual_joint_positions,
        # used by URCL's External Control script; not in UR's manual: the measured joints, as its name says
        "get_joint_positions": get_actual_joint_positions,
        "get_target_joint_positions": get_target_joint_positions, "get_actual_joint_speeds": get_actual_joint_speeds,
        "get_target_joint_speeds": get_target_joint_speeds, "get_actual_tcp_pose": get_actual_tcp_pose,
        "get_target_tcp_pose": get_target_tcp_pose, "get_actual_tcp_speed": get_actual_tcp_speed,
        "get_target_tcp_speed": get_target_tcp_speed, "get_actual_tool_flange_pose": get_actual_tool_flange_pose,
        "get_tcp_offset": get_tcp_offset, "get_tcp_force": get_tcp_force, "get_steptime": get_steptime,
        "get_forward_kin": get_forward_kin,
        "get_inverse_kin": get_inverse_kin, "get_inverse_kin_has_solution": get_inverse_kin_has_solution,
        "is_within_safety_limits": is_within_safety_limits, "get_target_waypoint": get_target_waypoint,
        # messages
        "textmsg": textmsg, "popup": popup,
        # I/O
        "set_digital_out": set_digital_out, "get_digital_out": get_digital_out,
        "set_standard_digital_out": set_standard_digital_out,
        "set_configurable_digital_out": set_configurable_digital_out, "set_tool_digital_out": set_tool_digital_out,
        "get_standard_digital_out": get_standard_digital_out,
        "get_configurable_digital_out": get_configurable_digital_out, "get_tool_digital_out": get_tool_digital_out,
        "get_digital_in": get_digital_in, "get_standard_digital_in": get_standard_digital_in,
        "get_configurable_digital_in": get_configurable_digital_in, "get_tool_digital_in": get_tool_digital_in,
        "set_standard_analog_out": set_standard_analog_out, "set_analog_out": set_standard_analog_out,
        "rtde_set_watchdog": rtde_set_watchdog,
        # force control: parameters accepted (force_mode itself: builtins_clients, free-space approximation)
        "force_mode_set_damping": _force_parameter, "force_mode_set_gain_scaling": _force_parameter,
        "zero_ftsensor": zero_ftsensor, "set_gravity": set_gravity,
        "tool_contact": tool_contact,
        # dynamics-free state
        "get_target_joint_accelerations": get_target_joint_accelerations, "get_jacobian": get_jacobian,
    }
    for bank in ("input", "output"):
        table[f"read_{bank}_integer_register"] = _register(bank, "int")
        table[f"read_{bank}_float_register"] = _register(bank, "double")
        table[f"read_{bank}_boolean_register"] = _register(bank, "bit")
    table["write_output_integer_register"] = _register_writer("int")
    table["write_output_float_register"] = _register_writer("double")
    table["write_output_boolean_register"] = _register_writer("bit")
    for name in UNSUPPORTED:
        table[name] = _unsupported(name)
    table.update(EXTRA_BUILTINS)  # family modules (sockets, client-script built-ins) registered on top
    return table


BUILTINS = _table()
