"""Planning a cell program (pure, no robot): a joint target for every waypoint, clamped speeds, travel, time.

Every waypoint gets an FK-verified IK solution with its own taught TCP offset, nearest its recorded joints (a
relative waypoint: its root recorded pose's joints), else the previous target. Linear and process moves are sent
with these joint targets too (URScript's movel/movep accept joints and reach them by FK), so the controller goes
exactly to the configuration checked here. Speeds: rad/s and rad/s² for joint moves, clamped to the model's
slowest joint; m/s and m/s² for linear/process moves, clamped to MAX_TCP_SPEED / MAX_TCP_ACCELERATION.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from ur3dq import dqarray
from ur3dq import units as u
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import JointLimitError, SafetyCheckError, UnreachablePoseError
from ur3dq.program.resolve import Target, resolve_targets
from ur3dq.program.steps import Comment, Motion, Step, Waypoint, is_waypoint
from ur3dq.robot import motion, safety

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel

# The driver's TCP limits and URScript's movel defaults: one source (ur3dq.robot.safety).
MAX_TCP_SPEED = safety.MAX_TCP_SPEED
MAX_TCP_ACCELERATION = safety.MAX_TCP_ACCELERATION
MIN_JOINT_SPEED = 1e-3       # rad/s: slower, a move of one degree takes over 17 s; a typo, not a wish
MIN_JOINT_ACCELERATION = 1e-3
MIN_TCP_SPEED = 1e-3         # m/s: 1 mm/s
MIN_TCP_ACCELERATION = 1e-3
DEFAULT_TCP_SPEED = safety.DEFAULT_TCP_SPEED
DEFAULT_TCP_ACCELERATION = safety.DEFAULT_TCP_ACCELERATION


def motion_ranges(model: URModel, move: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """((lowest, highest) speed, (lowest, highest) acceleration) a waypoint of `move` may ask for on `model`: rad/s
    and rad/s² up to the slowest joint's limits for a joint move, m/s and m/s² up to MAX_TCP_SPEED and
    MAX_TCP_ACCELERATION for a linear or process move (what plan_program would otherwise clamp to).

    >>> from ur3dq.kinematics import robot_model
    >>> motion_ranges(robot_model("ur3"), "linear")
    ((0.001, 1.0), (0.001, 4.0))
    """
    if move == "joint":
        return ((MIN_JOINT_SPEED, float(np.min(model.max_joint_speed))),
                (MIN_JOINT_ACCELERATION, float(np.min(model.max_joint_acceleration))))
    return (MIN_TCP_SPEED, MAX_TCP_SPEED), (MIN_TCP_ACCELERATION, MAX_TCP_ACCELERATION)


class MotionRangeError(ValueError):
    """A waypoint's speed or acceleration outside what its model allows; `what` is 'speed' or 'acceleration',
    `angular` whether the move is a joint move (a caller adds its own example of a good value)."""

    def __init__(self, text: str, what: str, angular: bool):
        super().__init__(text)
        self.what, self.angular = what, angular


def check_motion_range(motion: Motion, model: URModel, who: str, units: u.Units) -> None:
    """MotionRangeError naming `who` and the valid range (written in `units`) when `motion`'s speed or acceleration
    is outside motion_ranges(model, its move): the one range check of every editor (command line, screen and .urp
    import).

    >>> from ur3dq.kinematics import robot_model
    >>> check_motion_range(Motion("linear", 1e-9), robot_model("ur3"), "waypoint 'p1'", u.Units("deg", "mm"))
    Traceback (most recent call last):
    ...
    ur3dq.program.plan.MotionRangeError: waypoint 'p1': speed 1e-06 mm/s is outside the ur3's range for a linear \
move, 1 mm/s to 1000 mm/s
    >>> check_motion_range(Motion("linear", 1.0000000001), robot_model("ur3"), "waypoint 'p1'", u.Units("deg", "mm"))
    Traceback (most recent call last):
    ...
    ur3dq.program.plan.MotionRangeError: waypoint 'p1': speed 1000.0000001 mm/s is outside the ur3's range for a \
linear move, 1 mm/s to 1000 mm/s
    """
    angular = u.angular_kind(motion.move)
    speeds, accelerations = motion_ranges(model, motion.move)
    for value, (low, high), kind, what in ((motion.speed, speeds, u.SPEED[angular], "speed"),
                                           (motion.acceleration, accelerations, u.ACCELERATION[angular],
                                            "acceleration")):
        if value is not None and not low <= value <= high:
            bounds = u.show(low, kind, units), u.show(high, kind, units)
            shown = u.show(value, kind, units)
            if shown in bounds:   # just past a bound: rounded, it would read as inside the range
                shown = f"{u.to_display(value, kind, units):.12g} {u.unit_label(kind, units)}"
            raise MotionRangeError(f"{who}: {what} {shown} is outside the {model.name}'s range for a {motion.move} "
                                   f"move, {bounds[0]} to {bounds[1]}", what, angular)


@dataclasses.dataclass(frozen=True)
class Defaults:
    """The run's defaults for what a waypoint leaves unset.

    The run's defaults for waypoints that leave a value unset: joint a (rad/s²), v (rad/s), TCP a (m/s²),
    v (m/s), blend (m)."""

    joint_acceleration: float = 1.4
    joint_speed: float = 1.05
    tcp_acceleration: float = DEFAULT_TCP_ACCELERATION
    tcp_speed: float = DEFAULT_TCP_SPEED
    blend: float = 0.0


@dataclasses.dataclass(frozen=True, slots=True)  # slots: a big program plans 10⁵ of them
class PlannedStep:
    """One step of a planned program.

    One step of a planned program. Waypoints carry their joint target (rad), the TCP pose and offset they
    aim at, move type, clamped a/v, blend radius (m), travel (rad, largest joint) and time (s, at 100 %; None
    when the start is unknown). Action steps carry only `step`."""

    step: Step
    joints: np.ndarray | None = None
    coefficients: tuple[float, ...] | None = None   # the target TCP pose's 8 dual-quaternion coefficients (base frame)
    tcp_offset: tuple[float, ...] | None = None
    move: str | None = None
    acceleration: float | None = None
    speed: float | None = None
    blend: float = 0.0
    travel: float | None = None
    duration: float | None = None
    fk_error_m: float = 0.0
    clamped: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        """The step's name."""
        return self.step.name

    @property
    def pose(self) -> DualQuaternion | None:
        """The target TCP pose as a DualQuaternion (None for an action step)."""
        return None if self.coefficients is None else DualQuaternion.from_array(self.coefficients)


def _clamp(value: float, limit: float, what: str, clamped: list[str]) -> float:
    if value > limit:
        clamped.append(f"{what} {value:g} → {limit:g}")
        return limit
    return value


def _joints_for(model: URModel, target: Target, previous: np.ndarray | None,
                replay_recorded_joints: bool) -> np.ndarray:
    """The joint target of a resolved waypoint (see the module docstring); errors name the step."""
    who = target.step.who
    solver = model.with_tcp(target.tcp_offset)
    if replay_recorded_joints and isinstance(target.step, Waypoint):
        if target.joints_hint is None:
            raise ValueError(f"{who}: no recorded joints (imported from thesis lines?); replay it without --joints")
        if target.robot_model != model.name:
            raise ValueError(f"{who}: recorded on a {target.robot_model}; its joints mean nothing on this "
                             f"{model.name}: replay it without --joints")
        try:
            return solver.check_joints(target.joints_hint)
        except (JointLimitError, ValueError) as error:
            raise JointLimitError(f"{who}: {error}") from None
    if target.joints_hint is not None:
        reference = np.asarray(target.joints_hint, dtype=float)
    elif previous is not None:
        reference = np.asarray(previous, dtype=float)
    else:
        reference = np.zeros(6)
    try:
        return np.asarray(solver.ik(target.pose, reference), dtype=float)
    except UnreachablePoseError as error:
        raise error.prefixed(f"{who}: unreachable on the {model.name}: ") from None


def _solve_hinted(model: URModel, targets: Sequence[Target], replay_recorded_joints: bool) -> dict[int, np.ndarray]:
    """{index: joints} for the targets that have joints to prefer, solved in one batch IK per TCP offset (the
    nearest FK-verified solution to the hint, as `ik` chooses); unreachable rows are left out, for the
    sequential pass to report with its own error."""
    groups: dict[tuple[float, ...], list[int]] = {}
    for index, target in enumerate(targets):
        if target.joints_hint is not None and not (replay_recorded_joints and isinstance(target.step, Waypoint)):
            groups.setdefault(target.tcp_offset, []).append(index)
    solved = {}
    for tcp_offset, indices in groups.items():
        poses = np.array([targets[i].coefficients for i in indices], dtype=float)
        hints = np.array([targets[i].joints_hint for i in indices], dtype=float)
        joints = model.with_tcp(tcp_offset).ik_batch(poses, hints)
        for i, q, finite in zip(indices, joints, np.isfinite(joints).all(axis=1).tolist(), strict=True):
            if finite:
                solved[i] = q
    return solved


def plan_program(model: URModel, steps: Iterable[Step], start_joints: npt.ArrayLike | None = None,
                 defaults: Defaults = Defaults(), speed_scale: float = 1.0,
                 replay_recorded_joints: bool = False, max_joint_travel: float | None = None,
                 resolve_from: Sequence[Step] | None = None) -> list[PlannedStep]:
    """The plan of a cell program: a checked joint target and clamped speeds for every waypoint.

    Parameters
    ----------
    model : URModel
        The arm; each waypoint is solved with its own taught TCP offset.
    steps : sequence of Step
        The steps to plan (a whole program or a --from/--to part of `resolve_from`).
    start_joints : (6,) array_like, optional
        Where the arm is (rad); None when unknown (a dry run).
    defaults : Defaults
        What a waypoint leaves unset.
    speed_scale : float
        0 < F ≤ 1, scales every speed.
    replay_recorded_joints : bool
        Use recorded joints instead of solving IK.
    max_joint_travel : float, optional
        Refuse a move that swings a joint further than this (rad).
    resolve_from : sequence of Step, optional
        The whole program relative waypoints are resolved in (default `steps`), so a part finds bases outside it.

    Returns
    -------
    list of PlannedStep
        One per step; a waypoint's blend is 0 when it is the last waypoint or an action (not a comment)
        follows it.

    Raises
    ------
    UnreachablePoseError, JointLimitError, SafetyCheckError, ValueError
        Naming the step: nothing moves unless the whole plan is sound.

    Examples
    --------
    >>> from ur3dq.kinematics import robot_model
    >>> from ur3dq.pose import Pose
    >>> from ur3dq.program.steps import DigitalOut, Motion, RelativeWaypoint, Waypoint
    >>> ur3 = robot_model("ur3")
    >>> q = [0.0, -1.2, 1.0, -1.4, -1.57, 0.0]
    >>> pick = Waypoint("pick", Pose.from_dual_quaternion("pick", ur3.fk(q), "ur3", joints=tuple(q)),
    ...                 Motion("linear", speed=0.05))
    >>> steps = [RelativeWaypoint("above", "pick", (0, 0, -0.05, 0, 0, 0)), pick, DigitalOut("grip", "tool", 0, True)]
    >>> [(planned.name, planned.move, planned.speed) for planned in plan_program(ur3, steps, q)]
    [('above', 'joint', 1.05), ('pick', 'linear', 0.05), ('grip', None, None)]
    """
    if not (isinstance(speed_scale, (int, float)) and math.isfinite(speed_scale) and 0 < speed_scale <= 1):
        raise ValueError(f"--speed-scale must be a fraction 0 < F ≤ 1, got {speed_scale!r}")
    steps = list(steps)
    resolved = resolve_targets(resolve_from if resolve_from is not None else steps)
    waypoints = [step for step in steps if is_waypoint(step)]
    targets = [resolved[step.name] for step in waypoints]
    solved = _solve_targets(model, targets, start_joints, replay_recorded_joints)
    fk_errors, _ = model.fk_errors(solved, [t.coefficients for t in targets], [t.tcp_offset for t in targets])
    travels, paths = _leading_distances(model, targets, solved, start_joints)
    limits = (float(np.min(model.max_joint_speed)), float(np.min(model.max_joint_acceleration)))
    # id(Motion) -> _motion_figures: a big program's waypoints share a few Motion objects
    shared: dict[int, tuple[str, float, float, float, tuple[str, ...]]] = {}
    figures = [shared.get(id(step.motion)) or shared.setdefault(id(step.motion), _motion_figures(
        step.motion, defaults, speed_scale, limits)) for step in waypoints]
    durations = _durations(waypoints, figures, travels, paths, max_joint_travel)
    moving = [is_waypoint(step) for step in steps]
    blends_on = _moves_next(steps, moving)
    plan: list[PlannedStep] = []
    at = 0
    for index, step in enumerate(steps):
        if not moving[index]:
            plan.append(PlannedStep(step))
            continue
        target, (move, a, v, blend, clamped) = targets[at], figures[at]
        if not blends_on[index]:
            blend = 0.0   # the last waypoint, or an action follows: the action happens at the waypoint
        plan.append(PlannedStep(step, solved[at], target.coefficients, target.tcp_offset, move, a, v, blend,
                                durations[at][0], durations[at][1], fk_errors[at], clamped))
        at += 1
    return plan


def _solve_targets(model: URModel, targets: Sequence[Target], start_joints: npt.ArrayLike | None,
                   replay_recorded_joints: bool) -> list[np.ndarray]:
    """The joints of every target, each solved nearest the one before (the first nearest `start_joints`)."""
    batch = _solve_hinted(model, targets, replay_recorded_joints)
    previous = None if start_joints is None else np.asarray(start_joints, dtype=float)
    solved = []
    for index, target in enumerate(targets):
        q = batch.get(index)
        if q is None:
            q = _joints_for(model, target, previous, replay_recorded_joints)
        solved.append(q)
        previous = q
    return solved


def _leading_distances(model: URModel, targets: Sequence[Target], solved: Sequence[np.ndarray],
                       start_joints: npt.ArrayLike | None) -> tuple[np.ndarray, np.ndarray]:
    """Each move's leading joint travel (rad) and TCP "distance", both (N,), NaN for a first move from nowhere.

    A linear/process move's distance is the larger of its TCP path (m) and its rotation (rad), as a controller
    times movel.
    """
    joints = np.array(solved).reshape(-1, 6)
    poses = np.array([t.coefficients for t in targets], dtype=float).reshape(-1, 8)
    if start_joints is not None:
        joints = np.vstack([np.asarray(start_joints, dtype=float), joints])
        start_tcp = model.with_tcp(targets[0].tcp_offset).fk(joints[0]) if targets else model.fk(joints[0])
        poses = np.vstack([start_tcp.to_array(), poses])
    travels = motion.leading_travels(joints)
    metres, radians = dqarray.pose_distance(poses[:-1], poses[1:]) if len(poses) > 1 else (np.zeros(0),) * 2
    paths = np.maximum(metres, radians)
    if start_joints is None and targets:  # the first move's start is unknown
        travels, paths = np.concatenate([[np.nan], travels]), np.concatenate([[np.nan], paths])
    return travels, paths


def _moves_next(steps: Sequence[Step], moving: Sequence[bool]) -> list[bool]:
    """Per step: whether the next step that is not a comment is a waypoint (a waypoint then keeps its blend)."""
    result = [False] * len(steps)
    following = False
    for index in range(len(steps) - 1, -1, -1):
        result[index] = following
        if not isinstance(steps[index], Comment):
            following = moving[index]
    return result


def _motion_figures(m: Motion, defaults: Defaults, speed_scale: float,
                    limits: tuple[float, float]) -> tuple[str, float, float, float, tuple[str, ...]]:
    """(move, a, v, blend, clamped) of a waypoint's Motion `m`: the run's defaults where it leaves a value unset,
    the speed scaled, a and v clamped (joint moves to `limits` = (slowest joint's speed, acceleration), linear and
    process moves to MAX_TCP_SPEED / MAX_TCP_ACCELERATION); `clamped` says what was."""
    clamped: list[str] = []
    if m.move == "joint":
        v = _clamp((m.speed or defaults.joint_speed) * speed_scale, limits[0], "speed", clamped)
        a = _clamp(m.acceleration or defaults.joint_acceleration, limits[1], "acceleration", clamped)
    else:
        v = _clamp((m.speed or defaults.tcp_speed) * speed_scale, MAX_TCP_SPEED, "speed", clamped)
        a = _clamp(m.acceleration or defaults.tcp_acceleration, MAX_TCP_ACCELERATION, "acceleration", clamped)
    return m.move, a, v, (m.blend if m.blend is not None else defaults.blend), tuple(clamped)


def _durations(waypoints: Sequence[Step], figures: list[tuple[str, float, float, float, tuple[str, ...]]],
               travels: np.ndarray, paths: np.ndarray,
               max_joint_travel: float | None) -> list[tuple[float | None, float | None]]:
    """[(travel rad or None, seconds at 100 % or None)] per waypoint: its leading joint travel (`travels`, NaN
    where the start is unknown) and the trapezoid of joint moves' travel, linear and process moves' `paths`;
    SafetyCheckError naming the first waypoint that swings a joint further than `max_joint_travel` (rad)."""
    known = ~np.isnan(travels)
    if max_joint_travel is not None:
        over = np.flatnonzero(known & (travels > max_joint_travel))
        if over.size:
            step, travel = waypoints[over[0]], float(travels[over[0]])
            raise SafetyCheckError(
                f"{step.who}: a joint would travel {travel:.3f} rad in one move, more than --max-travel "
                f"{max_joint_travel:.3f} rad (add an intermediate waypoint, or raise --max-travel)")
    joint = np.array([move == "joint" for move, *_ in figures], dtype=bool)
    a, v = (np.array([values[k] for values in figures], dtype=float).reshape(-1) for k in (1, 2))
    seconds = np.full(len(travels), np.nan)
    seconds[known] = motion.trapezoid_durations(np.where(joint, travels, paths)[known], a[known], v[known])
    return [(None, None) if math.isnan(travel) else (travel, duration)
            for travel, duration in zip(travels.tolist(), seconds.tolist(), strict=True)]
