"""The controller's TCP offset against the one the poses were taught with, for every command that moves the arm to
taught poses (`run-poses`, replay and cell program, and `move-to`): the change said before anything moves, and the
operator's `--tcp` choice applied — never ignored.

Use: add `@tcp_option` to the command, then, once connected, pass the poses (for_the_current_tcp) or the cell
program's steps (steps_for_the_current_tcp) through with `robot.model.tcp`; after a move, aimed_pose says where the
controller's TCP was aimed, to measure the move against.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar

import click
from rich.console import Console
from rich.markup import escape

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import SafetyCheckError
from ur3dq.pose import Pose
from ur3dq.program.resolve import resolve_targets
from ur3dq.program.steps import Step, Waypoint
from ur3dq.replay import TCP_CURRENT, TCP_RECORDED, retarget_to_tcp, tcp_changed

F = TypeVar("F", bound=Callable[..., Any])


def tcp_option(command: F) -> F:
    """The `--tcp recorded|current` option (its value in `tcp_choice`) of a command that moves to taught poses."""
    return click.option(
        "--tcp", "tcp_choice", type=click.Choice([TCP_RECORDED, TCP_CURRENT]),
        help="When the controller's TCP offset changed since a pose was recorded (required then): `recorded` puts "
             "the flange where it was, `current` puts the current TCP on the recorded pose.")(command)


def for_the_current_tcp(poses: list[Pose], tcp_now: DualQuaternion, choice: str | None, replay_joints: bool,
                        err: Console) -> list[Pose]:
    """The poses to plan, given the controller's TCP `tcp_now`.

    Unchanged when every pose was recorded with it; otherwise a warning before anything moves, and the user's
    --tcp `choice` applied (SafetyCheckError without one, and for `current` with --joints)."""
    changed = [pose.name for pose in poses if tcp_changed(pose, tcp_now)]
    if _retarget(changed, tcp_now, choice, replay_joints, err):
        return [retarget_to_tcp(pose, tcp_now) for pose in poses]
    return poses


def steps_for_the_current_tcp(steps: list[Step], names: Iterable[str], tcp_now: DualQuaternion, choice: str | None,
                              replay_joints: bool, err: Console) -> list[Step]:
    """The cell program `steps` to plan, given the controller's TCP `tcp_now`, for running the steps `names`.

    As for_the_current_tcp, for the waypoints among `names` (a relative waypoint was taught with its base's TCP):
    with `current`, every recorded waypoint is retargeted, so relative ones follow their bases."""
    wanted = set(names)
    targets = resolve_targets(steps)
    changed = [name for name, target in targets.items() if name in wanted and tcp_changed(target, tcp_now)]
    if not _retarget(changed, tcp_now, choice, replay_joints, err):
        return steps
    return [dataclasses.replace(step, pose=retarget_to_tcp(step.pose, tcp_now)) if isinstance(step, Waypoint)
            else step for step in steps]


def aimed_pose(pose: DualQuaternion, tcp_offset: Sequence[float] | None, tcp_now: DualQuaternion) -> DualQuaternion:
    """Where a move to `pose` (taught with `tcp_offset`) aims the controller's TCP `tcp_now`: the pose itself when
    the TCP is the taught one, else where the current TCP is when the flange sits where the taught one put it."""
    if tcp_offset is None:
        return pose
    return pose * DualQuaternion.from_ur_pose(tcp_offset).inverse() * tcp_now


def _retarget(changed: list[str], tcp_now: DualQuaternion, choice: str | None, replay_joints: bool,
              err: Console) -> bool:
    """Whether to retarget the poses: say a change (`changed` names the poses taught with another TCP) and apply
    `choice`; SafetyCheckError when a change has no choice, or `current` comes with --joints. A choice with no
    change is said to change nothing (both choices are then the same move)."""
    if not changed:
        if choice is not None:
            err.print(f"Note: --tcp {choice} changes nothing: every pose was taught with the controller's TCP offset.")
        return False
    current = ", ".join(f"{value:.4f}" for value in tcp_now.to_ur_pose())
    names = ", ".join(repr(name) for name in changed[:3]) + (f" and {len(changed) - 3} more" if len(changed) > 3
                                                               else "")
    err.print(escape(f"Warning: the controller's TCP offset (p[{current}]) differs from the one {names} "
                     "was recorded with."), soft_wrap=True)
    if choice is None:
        raise SafetyCheckError(f"the TCP offset changed since {names} was recorded: choose --tcp recorded (the "
                               "flange goes where it was) or --tcp current (the current TCP goes on the recorded "
                               "pose)")
    if choice == TCP_CURRENT and replay_joints:
        raise SafetyCheckError("--tcp current needs IK for the new TCP: drop --joints")
    return choice == TCP_CURRENT
