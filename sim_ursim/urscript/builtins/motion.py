"""URScript motion built-ins: moves (movej, movel, movep, movec), speed and servo commands, stops, waiting,
freedrive, protective stop.

Blocking moves go through `ctx.run_motion`, which returns when this motion has ended (or at its blend radius).
"""
import functools

import numpy as np

from sim_ursim import kinematics
from sim_ursim.urscript.builtins.arguments import as_number, controller_call
from sim_ursim.urscript.builtins.registry import builtin
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import Pose, ScriptError, number_list, to_str


def _unreachable_stops(ctx: ThreadContext, function, *args):
    """Call a motion command; an unreachable target protective-stops the arm with a robot error code (C209 error
    message on 30001) and ends the program, as a controller does, instead of a URScript runtime exception."""
    try:
        return function(*args)
    except kinematics.IKError as error:
        ctx.controller.protective_stop(f"target unreachable: {error}")
        ctx.check()  # the protective stop stopped this program: Cancelled ends it without a runtime exception
        raise ScriptError(f"runtime_error:{error}:") from None


def _joint_target(ctx: ThreadContext, q):
    """movej's target: a joint list, or a pose solved by IK near the joints where the queued motion ends. A pose no
    joints reach is a runtime exception, as on a controller (its IK fails before any motion is planned; URCL's
    PrimaryClientTest expects RobotRuntimeException for movej(p[10,0,0,0,0,0]) and a robot error code for movel)."""
    if isinstance(q, Pose):
        return controller_call(ctx.controller.ik, np.array(q), ctx.controller.state().target_q)
    return np.array(number_list(q, 6, "q"))


def _pose_target(ctx: ThreadContext, pose):
    """movel's target: a pose, or a joint list converted by forward kinematics."""
    if isinstance(pose, Pose):
        return np.array(pose)
    return controller_call(ctx.controller.fk, number_list(pose, 6, "q"))


@builtin("movej", "optimovej")   # optimove*: the same a/v/r; the time-optimal profile is not modelled
def movej(ctx: ThreadContext, q, a=1.4, v=1.05, t=0, r=0):
    """Joint move (leading axis a [rad/s²], v [rad/s], t [s] overrides); blocks until done, or within r [m]."""
    target = _joint_target(ctx, q)
    ctx.run_motion(lambda: controller_call(ctx.controller.movej, target, a, v, t, r))


@builtin("movel", "optimovel")
def movel(ctx: ThreadContext, pose, a=1.2, v=0.25, t=0, r=0):
    """Linear TCP move (a [m/s²], v [m/s], t [s] overrides); blocks until done, or within r [m]."""
    target = _pose_target(ctx, pose)
    # Reachability first (the controller refuses an unreachable movel like any other refusal): see _unreachable_stops.
    controller_call(_unreachable_stops, ctx, ctx.controller.ik, target, ctx.controller.state().target_q)
    ctx.run_motion(lambda: controller_call(ctx.controller.movel, target, a, v, t, r))


@builtin
def movep(ctx: ThreadContext, pose, a=1.2, v=0.25, r=0):
    """Process move: modelled as a linear move (the constant-speed circular blends are not emulated)."""
    movel(ctx, pose, a, v, 0, r)


MOVEC_SEGMENTS = 24  # linear pieces of a movec arc (each 1/24 of the sweep)


def _arc(start, via, end):
    """Positions along the circle through three points, from start to end through via (MOVEC_SEGMENTS + 1 points)."""
    a, b, c = (np.asarray(p, dtype=float) for p in (start, via, end))
    ab, ac = b - a, c - a
    normal = np.cross(ab, ac)
    if np.linalg.norm(normal) < 1e-9:
        raise ScriptError("runtime_error:movec: the three points are on one line, no circle passes through them:")
    # Circumcentre of the triangle a, b, c.
    centre = a + (np.dot(ac, ac) * np.cross(normal, ab) + np.dot(ab, ab) * np.cross(ac, normal)) / (
        2.0 * np.dot(normal, normal))
    axis = normal / np.linalg.norm(normal)
    u = (a - centre) / np.linalg.norm(a - centre)
    v = np.cross(axis, u)
    radius = np.linalg.norm(a - centre)

    def angle(point):
        d = point - centre
        return np.arctan2(np.dot(d, v), np.dot(d, u)) % (2 * np.pi)

    sweep = angle(c)  # counter-clockwise about the normal of (b - a) × (c - a) passes through b first
    return [centre + radius * (np.cos(t) * u + np.sin(t) * v) for t in np.linspace(0.0, sweep, MOVEC_SEGMENTS + 1)]


def _arc_poses(start, via, to):
    """The TCP poses of a movec arc after `start` (MOVEC_SEGMENTS of them, the last is `to`): positions on the
    circle through the three points, orientation interpolated from start's to to's."""
    start_matrix, end_matrix = kinematics.pose_to_matrix(start), kinematics.pose_to_matrix(to)
    points = _arc(start[:3], via[:3], to[:3])
    poses = []
    for index, point in enumerate(points[1:], start=1):
        matrix = np.array(kinematics.interpolate_pose(start_matrix, end_matrix, index / (len(points) - 1)))
        matrix[:3, 3] = point
        poses.append(np.array(kinematics.matrix_to_pose(matrix)))
    return poses


@builtin
def movec(ctx: ThreadContext, pose_via, pose_to, a=1.2, v=0.25, r=0, mode=0):
    """Circular move through pose_via to pose_to (a [m/s²], v [m/s]); each may be joint positions, converted by
    forward kinematics (UR's script manual). The whole arc is checked before the arm moves: a point no joint
    solution reaches protective-stops as an unreachable movel does. Approximation: the arc is followed as
    MOVEC_SEGMENTS blended linear moves and the orientation is interpolated from the start pose to pose_to (UR's
    mode 0); mode 1 (orientation fixed to the arc tangent) is accepted and moves like mode 0."""
    if isinstance(mode, bool) or mode not in (0, 1):
        raise ScriptError(f"runtime_error:movec: mode must be 0 or 1, got {to_str(mode)}:")
    controller = ctx.controller
    state = controller.state()
    poses = _arc_poses(np.array(state.target_tcp_pose), _pose_target(ctx, pose_via), _pose_target(ctx, pose_to))
    q = state.target_q
    for pose in poses:   # each point solved from the previous one: the branch the linear pieces will follow
        q = controller_call(_unreachable_stops, ctx, controller.ik, pose, q)
    step = float(np.linalg.norm(poses[1][:3] - poses[0][:3]))
    for index, pose in enumerate(poses):
        blend = float(r) if index == len(poses) - 1 else 0.4 * step
        ctx.run_motion(functools.partial(controller_call, controller.movel, pose, a, v, 0.0, blend))


def _wait_for(ctx: ThreadContext, seconds):
    """Return after `seconds` (at least one control cycle) of controller time, interruptibly."""
    if seconds > 0:
        ctx.sleep(seconds)
    else:
        ctx.sync()


def _held_speed(ctx: ThreadContext, command, speed, acceleration, duration):
    """Run speedj/speedl `command` held by this thread (trajectories.SpeedRamp) and return once the arm has moved
    for `duration`: lockstep with the control cycles, not `duration` of wall time (a busy machine runs fewer cycles
    than its wall time holds; the next command would then cut this one short)."""
    motion = controller_call(command, speed, acceleration, duration, ctx)
    ctx.awaiting_hold = motion  # once it has moved its time, the control loop waits for this thread's next command
    try:
        with ctx.waiting():
            ctx.wait_for_motion(motion)
    finally:
        ctx.awaiting_hold = None
    ctx.check()


def _within_speed_limits(qd: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """qd scaled down (all joints alike, so the direction is kept) until no joint exceeds its speed limit, as a
    controller's trajectory generator saturates an over-fast speedj instead of failing the program (URCL's spline
    interpolation can ask a few parts per million over the limit at a spline's peak)."""
    overspeed = float(np.max(np.abs(qd) / limits))
    return qd / overspeed if overspeed > 1.0 else qd


@builtin
def speedj(ctx: ThreadContext, qd, a, t=None):
    """Accelerate the joints to speeds qd [rad/s] at a [rad/s²] and keep them; returns after t [s] of controller
    motion time (the arm then waits for this thread's next command: trajectories.JointSpeed), or without t once
    the speeds are reached (the ramp time max|Δqd| / a)."""
    qd = np.array(number_list(qd, 6, "qd"))
    acceleration = as_number(a, "a")
    if acceleration == 0.0:
        # Zero acceleration: the speeds cannot change, the joints keep the speeds they have (URCL's spline
        # interpolation sends a = 0 when consecutive speeds are equal; controllers accept it).
        qd = np.array(ctx.controller.state().target_qd)
        acceleration = 1.0
    qd = _within_speed_limits(qd, ctx.controller.model.max_joint_speed)
    duration = None if t is None else as_number(t, "t")
    if duration is not None and duration > 0:
        _held_speed(ctx, ctx.controller.speedj, qd, acceleration, duration)
        return
    controller_call(ctx.controller.speedj, qd, acceleration, 0.0)
    if duration is None:
        _wait_for(ctx, float(np.max(np.abs(qd - ctx.controller.state().actual_qd))) / acceleration)
    else:
        _wait_for(ctx, duration)


@builtin
def speedl(ctx: ThreadContext, xd, a, t=None, aRot=None):
    """Accelerate the TCP to twist xd [m/s, rad/s] at a [m/s²] and keep it; returns after t [s] of controller
    motion time (the arm then waits for this thread's next command, as after speedj), or without t once the linear
    speed is reached (the ramp time |Δv| / a)."""
    xd = np.array(number_list(xd, 6, "xd"))
    acceleration = as_number(a, "a")
    duration = None if t is None else as_number(t, "t")
    if duration is not None and duration > 0:
        _held_speed(ctx, ctx.controller.speedl, xd, acceleration, duration)
        return
    controller_call(ctx.controller.speedl, xd, acceleration, 0.0)
    if duration is None:
        _wait_for(ctx, float(np.linalg.norm(xd[:3] - ctx.controller.state().actual_tcp_speed[:3])) / acceleration)
    else:
        _wait_for(ctx, duration)


@builtin
def servoj(ctx: ThreadContext, q, a=0, v=0, t=0.008, lookahead_time=0.1, gain=300):
    """Servo to joints q, arriving after t [s]; blocks for t, as the controller does."""
    q = number_list(q, 6, "q")
    duration = as_number(t, "t")
    controller_call(ctx.controller.servoj, q, a, v, duration, lookahead_time, gain)
    _wait_for(ctx, duration)


@builtin
def stopj(ctx: ThreadContext, a):
    """Decelerate the joints to rest at a [rad/s²]; blocks until the arm stands still."""
    deceleration = as_number(a, "a")
    ctx.run_motion(lambda: controller_call(ctx.controller.stopj, deceleration))


@builtin
def stopl(ctx: ThreadContext, a, aRot=None):
    """Decelerate the TCP to rest at a [m/s²]; blocks until the arm stands still."""
    deceleration = as_number(a, "a")
    ctx.run_motion(lambda: controller_call(ctx.controller.stopl, deceleration))


@builtin
def sleep(ctx: ThreadContext, t):
    """Wait t seconds."""
    seconds = as_number(t, "t")
    if seconds < 0:
        raise ScriptError(f"runtime_error:sleep time must be ≥ 0, got {to_str(t)}:")
    ctx.controller.release_speed_hold(ctx)  # waiting, not commanding: a held speedj/speedl ramps to rest
    ctx.sleep(seconds)


@builtin
def sync(ctx: ThreadContext):
    """Wait for the next control cycle (uses up the rest of this thread's physical time slot)."""
    ctx.controller.release_speed_hold(ctx)  # waiting, not commanding: a held speedj/speedl ramps to rest
    ctx.sync()


@builtin
def is_steady(ctx: ThreadContext):
    """True when the arm stands still and no motion is active."""
    state = ctx.controller.state()
    return bool(not state.motion_active and np.all(np.abs(state.actual_qd) < 1e-6))


@builtin("freedrive_mode", "teach_mode")
def freedrive_mode(ctx: ThreadContext, *args, **kwargs):
    """Freedrive on while this program runs (the axis/feature constraints of 5.x, positional or freeAxes=/feature=,
    accepted and ignored)."""
    controller_call(ctx.controller.set_freedrive, True)
    ctx.execution.holds_freedrive = True


@builtin("end_freedrive_mode", "end_teach_mode")
def end_freedrive_mode(ctx: ThreadContext):
    """Freedrive off."""
    controller_call(ctx.controller.set_freedrive, False)
    ctx.execution.holds_freedrive = False


@builtin
def get_freedrive_status(ctx: ThreadContext):
    """0 when freedrive is off, 1 when on (no singularity/limit reporting)."""
    return 1 if ctx.controller.state().freedrive else 0


@builtin
def protective_stop(ctx: ThreadContext):
    """Trigger a protective stop (the program then stops)."""
    ctx.controller.protective_stop("protective_stop() called by the program")
    ctx.check()
