"""Where every waypoint of a program is: recorded poses as stored, relative waypoints through their base chain.

A relative waypoint's pose is computed from its base's pose every time the program is resolved, so re-teaching
the base moves it too. Tool frame: σ = σ_base · Δ (the offset expressed in the base waypoint's TCP frame). Base
frame: the translation is added in the robot's base frame and the rotation turns the TCP about its own position,
as the pendant's "base" feature does. Δ is the UR pose vector [dx, dy, dz, rx, ry, rz] (metres, rotation vector).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence

from ur3dq.dualquat import DualQuaternion
from ur3dq.pose import closest_name_text
from ur3dq.program.steps import RelativeWaypoint, Step, Waypoint, is_waypoint


@dataclasses.dataclass(frozen=True, slots=True)  # slots: one per waypoint, 10⁵ in a big program
class Target:
    """A resolved waypoint: the TCP pose to reach and how it was taught.

    A resolved waypoint: the TCP pose to reach (base frame; its 8 coefficients, `pose` as a DualQuaternion),
    the TCP offset it was taught with (flange frame, UR pose vector), the model it was taught on, and joints to
    prefer when solving IK (the root recorded pose's joints, or None)."""

    step: Step
    coefficients: tuple[float, ...]
    tcp_offset: tuple[float, ...]
    robot_model: str
    joints_hint: tuple[float, ...] | None

    @property
    def pose(self) -> DualQuaternion:
        """The TCP pose to reach, as a DualQuaternion."""
        return DualQuaternion.from_array(self.coefficients)


def offset_pose(base: DualQuaternion, offset: Sequence[float], frame: str) -> DualQuaternion:
    """The pose `offset` (UR pose vector) away from `base`, in `base`'s tool frame or the robot's base frame."""
    delta = DualQuaternion.from_ur_pose(offset)
    if frame == "tool":
        return base * delta
    rotation = delta.rotation * base.rotation
    return DualQuaternion.from_rotation_translation(rotation, base.translation + delta.translation)


def resolve_targets(steps: Iterable[Step], relative_only: bool = False) -> dict[str, Target]:
    """The Target of every waypoint, relative ones resolved.

    {name: Target} for every waypoint of `steps` (only relative ones and their bases when `relative_only`);
    ValueError naming the step when a relative
    waypoint's base is missing or not a waypoint, or relative waypoints form a cycle."""
    by_name = {step.name: step for step in steps}
    resolved: dict[str, Target] = {}
    for step in steps:
        if isinstance(step, Waypoint):   # most steps of a big program: a recorded pose as it is, no base to follow
            if not relative_only and step.name not in resolved:
                resolved[step.name] = _recorded_target(step)
        elif is_waypoint(step):
            _resolve(step, [], by_name, resolved)
    return resolved


def _recorded_target(step: Waypoint) -> Target:
    """The Target of a recorded waypoint: its pose's own fields (a Target checks nothing, so it is built past its
    frozen __init__, a third of a big program's resolve)."""
    pose = step.pose
    return Target(step, pose.dual_quaternion, pose.tcp_offset, pose.robot_model, pose.joints)


def _resolve(step: Step, chain: list[str], by_name: dict[str, Step], resolved: dict[str, Target]) -> Target:
    """The Target of waypoint `step`, kept in `resolved` (its relative bases first, through `by_name`); `chain`:
    the relative waypoints that led here. A function of its own, not a closure: a closure that calls itself is
    a reference cycle, which would keep the whole program alive until the cyclic collector runs."""
    if step.name in resolved:
        return resolved[step.name]
    if isinstance(step, Waypoint):
        target = _recorded_target(step)
    elif isinstance(step, RelativeWaypoint):
        if step.name in chain:
            loop = " → ".join(repr(name) for name in [*chain[chain.index(step.name):], step.name])
            raise ValueError(f"{step.who}: relative waypoints form a cycle: {loop}")
        base = by_name.get(step.base)
        if base is None:
            raise ValueError(f"{step.who}: its base waypoint {step.base!r} is not in the program "
                             "(removed or renamed?)")
        if not is_waypoint(base):
            raise ValueError(f"{step.who}: its base {step.base!r} is a {base.kind} step, not a waypoint")
        parent = _resolve(base, [*chain, step.name], by_name, resolved)
        pose = offset_pose(parent.pose, step.offset, step.frame)
        target = Target(step, tuple(pose.to_array().tolist()), parent.tcp_offset, parent.robot_model,
                        parent.joints_hint)
    else:
        raise ValueError(f"{step.who}: not a waypoint")
    resolved[step.name] = target
    return target


def check_program(steps: Sequence[Step]) -> None:
    """ValueError naming the first step at fault: duplicate names, unresolvable relative waypoints."""
    seen = set()
    for step in steps:
        if step.name in seen:
            raise ValueError(f"{step.who}: the name appears twice in the program")
        seen.add(step.name)
    resolve_targets(steps, relative_only=True)


def select_range(steps: Sequence[Step], start: str | None = None, end: str | None = None) -> list[Step]:
    """The steps from `start` to `end`, inclusive.

    The steps from the one named `start` to the one named `end`, inclusive (the whole program by default);
    ValueError when a name is unknown or `end` comes before `start`."""
    names = [step.name for step in steps]
    for option, name in (("--from", start), ("--to", end)):
        if name is not None and name not in names:
            raise ValueError(f"{option} {name!r}: no step of that name in the program"
                             f"{closest_name_text(name, names, '; `ur3dq poses list` shows them')}")
    first = names.index(start) if start is not None else 0
    last = names.index(end) if end is not None else len(steps) - 1
    if last < first:
        raise ValueError(f"--to {end!r} comes before --from {start!r} in the program")
    return list(steps[first:last + 1])
