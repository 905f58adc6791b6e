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

import numpy as np

from ur3dq.errors import JointLimitError, SafetyCheckError, UnreachablePoseError
from ur3dq.program.resolve import resolve_targets
from ur3dq.program.steps import Waypoint, is_waypoint
from ur3dq.robot import motion

MAX_TCP_SPEED = 1.0          # m/s: the pendant's default tool speed limit region; faster is refused by clamping
MAX_TCP_ACCELERATION = 4.0   # m/s²
DEFAULT_TCP_SPEED = 0.25     # m/s, URScript movel's default
DEFAULT_TCP_ACCELERATION = 1.2


@dataclasses.dataclass(frozen=True)
class Defaults:
    """The run's defaults for waypoints that leave a value unset: joint a (rad/s²), v (rad/s), TCP a (m/s²),
    v (m/s), blend (m)."""

    joint_acceleration: float = 1.4
    joint_speed: float = 1.05
    tcp_acceleration: float = DEFAULT_TCP_ACCELERATION
    tcp_speed: float = DEFAULT_TCP_SPEED
    blend: float = 0.0


@dataclasses.dataclass(frozen=True)
class PlannedStep:
    """One step of a planned program. Waypoints carry their joint target (rad), the TCP pose and offset they
    aim at, move type, clamped a/v, blend radius (m), travel (rad, largest joint) and time (s, at 100 %; None
    when the start is unknown). Action steps carry only `step`."""

    step: object
    joints: np.ndarray | None = None
    pose: object = None
    tcp_offset: tuple | None = None
    move: str | None = None
    acceleration: float | None = None
    speed: float | None = None
    blend: float = 0.0
    travel: float | None = None
    duration: float | None = None
    fk_error_m: float = 0.0
    clamped: tuple = ()

    @property
    def name(self) -> str:
        return self.step.name


def _clamp(value: float, limit: float, what: str, clamped: list) -> float:
    if value > limit:
        clamped.append(f"{what} {value:g} → {limit:g}")
        return limit
    return value


def _joints_for(model, target, previous, replay_recorded_joints: bool):
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
        raise UnreachablePoseError(f"{who}: unreachable on the {model.name}: {error}") from None


def plan_program(model, steps, start_joints=None, defaults: Defaults = Defaults(), speed_scale: float = 1.0,
                 replay_recorded_joints: bool = False, max_joint_travel: float | None = None,
                 resolve_from=None) -> list[PlannedStep]:
    """The plan of `steps` on `model` from `start_joints` (rad, or None when unknown).

    `resolve_from` (default `steps`) is the whole program relative waypoints are resolved in, so a --from/--to
    part still finds bases outside it. `speed_scale` (0 < F ≤ 1) scales every speed. A waypoint's blend is 0
    when it is the last waypoint or an action follows it (the action must happen at the waypoint). Raises,
    naming the step, if a target is unreachable, outside the limits, or swings a joint further than
    `max_joint_travel` (rad): nothing moves unless the whole plan is sound.
    """
    if not (isinstance(speed_scale, (int, float)) and math.isfinite(speed_scale) and 0 < speed_scale <= 1):
        raise ValueError(f"--speed-scale must be a fraction 0 < F ≤ 1, got {speed_scale!r}")
    targets = resolve_targets(resolve_from if resolve_from is not None else steps)
    joint_v_limit = float(np.min(model.max_joint_speed))
    joint_a_limit = float(np.min(model.max_joint_acceleration))
    plan: list[PlannedStep] = []
    previous = None if start_joints is None else np.asarray(start_joints, dtype=float)
    previous_pose = None if previous is None else model.fk(previous)
    steps = list(steps)
    for index, step in enumerate(steps):
        if not is_waypoint(step):
            plan.append(PlannedStep(step))
            continue
        target = targets[step.name]
        q = _joints_for(model, target, previous, replay_recorded_joints)
        m = step.motion
        clamped: list[str] = []
        if m.move == "joint":
            v = _clamp((m.speed or defaults.joint_speed) * speed_scale, joint_v_limit, "speed", clamped)
            a = _clamp(m.acceleration or defaults.joint_acceleration, joint_a_limit, "acceleration", clamped)
        else:
            v = _clamp((m.speed or defaults.tcp_speed) * speed_scale, MAX_TCP_SPEED, "speed", clamped)
            a = _clamp(m.acceleration or defaults.tcp_acceleration, MAX_TCP_ACCELERATION, "acceleration", clamped)
        later = steps[index + 1:]
        ends_here = not later or not is_waypoint(later[0])
        blend = 0.0 if ends_here else (m.blend if m.blend is not None else defaults.blend)
        travel = duration = None
        if previous is not None:
            travel = motion.leading_travel(previous, q)
            if max_joint_travel is not None and travel > max_joint_travel:
                raise SafetyCheckError(
                    f"{step.who}: a joint would travel {travel:.3f} rad in one move, more than --max-travel "
                    f"{max_joint_travel:.3f} rad (add an intermediate waypoint, or raise --max-travel)")
            if m.move == "joint":
                duration = motion.movej_duration(previous, q, a, v)
            else:
                metres, radians = previous_pose.distance(model.with_tcp(target.tcp_offset).fk(q))
                duration = motion.trapezoid_duration(max(metres, radians), a, v)
        fk_error_m, _ = model.with_tcp(target.tcp_offset).fk(q).distance(target.pose)
        plan.append(PlannedStep(step, q, target.pose, target.tcp_offset, m.move, a, v, blend, travel, duration,
                                fk_error_m, tuple(clamped)))
        previous = q
        previous_pose = model.with_tcp(target.tcp_offset).fk(q)
    return plan
