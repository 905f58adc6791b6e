"""The commands that talk to the robot: `status`, `record-pose` (and --teach), `run-poses`."""
from __future__ import annotations

import dataclasses
import math
import sys

import click
import numpy as np
from rich.console import Console
from rich.markup import escape  # user text (pose names) is shown as typed, never read as markup
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from ur3dq.cli.app import Settings, cli, confirm, display_options, emit_json, robot_session
from ur3dq.cli.commands_check import cell_option, require_clear_path
from ur3dq.cli.commands_program import (
    check_waypoint_options, placement_options, record_waypoint, run_program_command, waypoint_motion_options,
)
from ur3dq.cli.display import (
    angle_text, angles_text, coefficients_text, distance_text, key_value_table, pose_vector_text,
)
from ur3dq.cli.plan import PlanStep, loop_closing_travel, plan_replay, tcp_pose_for
from ur3dq.cli.simstate import running_simulator_host
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import ConnectionLostError, SafetyCheckError, StoreError
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose, next_free_name
from ur3dq.robot.safety import DEFAULT_MAX_JOINT_TRAVEL

DEFAULT_SPEED = 1.05         # rad/s, URScript's movej default
DEFAULT_ACCELERATION = 1.4   # rad/s²
MAX_STATUS_AGE_S = 1.0       # a reading older than this is a frozen stream, not the arm's pose


# ---------------------------------------------------------------- pure helpers


def angular_option(value: float | None, default: float, deg: bool) -> float:
    """An angular option (speed, acceleration, travel) in radians: `default` when not given, else the typed value,
    read as degrees when `deg` (so `--deg --speed 30` is 30°/s, never 30 rad/s)."""
    if value is None:
        return default
    return math.radians(value) if deg else value


def motion_options(command):
    """--speed, --acceleration and --max-travel, in radians (degrees with --deg); resolve with angular_option."""
    command = click.option(
        "--max-travel", type=float, default=None,
        help="Refuse a plan in which one move swings a joint further than this (rad, ° with --deg) "
             "[default: π rad].")(command)
    command = click.option(
        "--acceleration", type=float, default=None,
        help=f"Leading joint acceleration, rad/s² (°/s² with --deg), clamped to the model "
             f"[default: {DEFAULT_ACCELERATION} rad/s²].")(command)
    return click.option(
        "--speed", type=float, default=None,
        help=f"Leading joint speed, rad/s (°/s with --deg), clamped to the model [default: {DEFAULT_SPEED} rad/s]."
    )(command)


def clamp_to_model(value: float, limits, name: str) -> tuple[float, bool]:
    """(value, clamped?) with `value` lowered to the slowest joint's limit; ValueError unless finite and > 0."""
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    limit = float(np.min(limits))
    return (limit, True) if value > limit else (value, False)


@dataclasses.dataclass(frozen=True)
class Reached:
    """Where one replayed move ended: the TCP the controller reports vs the recorded pose."""

    step: PlanStep
    error_m: float
    error_rad: float
    seconds: float


# ---------------------------------------------------------------- robot helpers


def read_pose(robot, name: str, note: str = "") -> Pose:
    """The arm's current TCP pose as a Pose (one status reading, so joints and TCP belong together)."""
    status = robot.state()
    if status.age > MAX_STATUS_AGE_S:
        raise ConnectionLostError(f"the robot's state stream is frozen ({status.age:.1f} s old); pose not recorded")
    return Pose.from_dual_quaternion(
        name, DualQuaternion.from_ur_pose(status.tcp_pose), robot.model_name, joints=status.joints,
        robot_serial=robot.serial_number, tcp_offset=robot.model.tcp.to_ur_pose(), note=note)


def pose_rows(robot, pose: Pose, deg: bool) -> list[tuple[str, str]]:
    """What record-pose shows about a reading: joints, TCP pose, dual quaternion, and the model's FK check."""
    metres, radians = robot.model.fk(pose.joints).distance(pose.dq)
    return [
        ("joints", angles_text(pose.joints, deg)),
        ("TCP pose", pose_vector_text(pose.ur_pose, deg)),
        ("dual quaternion", coefficients_text(pose.dual_quaternion)),
        ("thesis line", pose.dq.to_thesis_line()),
        ("TCP offset", pose_vector_text(pose.tcp_offset, deg)),
        ("model FK check", f"{distance_text(metres, radians)} from the controller's TCP"),
    ]


def plan_table(steps, deg: bool, title: str) -> Table:
    """The replay plan: each pose's chosen joints, how they were chosen, travel and time, FK residual."""
    table = Table(title=title, title_justify="left")
    for header in ("#", "pose", "joints", "chosen by", "travel", "time", "FK check"):
        # every column wraps (joints at their spaces), so an 80-column terminal still shows every pose name
        table.add_column(header, overflow="fold", min_width=6 if header == "pose" else None)
    for index, step in enumerate(steps, start=1):
        travel = "—" if step.travel is None else angle_text(step.travel, deg)
        seconds = "—" if step.duration is None else f"{step.duration:.2f} s"
        source = step.source + (f" (of {step.solutions})" if step.solutions else "")
        table.add_row(str(index), escape(step.pose.name), angles_text(step.joints, deg), source, travel, seconds,
                      distance_text(step.fk_error_m, step.fk_error_rad))
    return table


def reached_table(results, title: str) -> Table:
    """Where each replayed pose ended vs where it was recorded."""
    table = Table(title=title, title_justify="left")
    for header in ("#", "pose", "recorded TCP (x, y, z m)", "error", "move time"):
        table.add_column(header)
    for index, result in enumerate(results, start=1):
        x, y, z = result.step.pose.ur_pose[:3]
        table.add_row(str(index), escape(result.step.pose.name), f"{x:.4f}, {y:.4f}, {z:.4f}",
                      distance_text(result.error_m, result.error_rad), f"{result.seconds:.2f} s")
    return table


def plan_to_json(steps) -> list[dict]:
    """The plan in SI units for --json."""
    return [{"pose": step.pose.name, "joints": step.joints.tolist(), "source": step.source,
             "solutions": step.solutions, "travel": step.travel, "duration": step.duration,
             "fk_error_m": step.fk_error_m, "fk_error_rad": step.fk_error_rad} for step in steps]


def execute_plan(robot, steps, a: float, v: float, blend: float, loops: int, console: Console) -> list[Reached]:
    """Move through `steps` `loops` times, showing progress; returns where each move ended (with `blend` > 0 the
    whole run is one blended program, and only its end is measured). Ctrl-C or any fault stops the arm (the
    driver sends stopj) and propagates."""
    results = []
    tcp_now = robot.model.tcp
    expected = [tcp_pose_for(step.pose, tcp_now) for step in steps]
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
               TimeElapsedColumn())
    try:
        with Progress(*columns, console=console, transient=False) as progress:
            task = progress.add_task("moving", total=len(steps) * loops)
            if blend > 0:
                progress.update(task, description=f"blended path through {len(steps) * loops} poses")
                seconds = robot.movej_path([s.joints for s in steps] * loops, blend=blend, a=a, v=v,
                                           expected_poses=expected * loops)
                progress.advance(task, len(steps) * loops)
                return [Reached(steps[-1], *robot.tcp_pose().distance(expected[-1]), seconds)]
            for loop in range(loops):
                for step, pose in zip(steps, expected):
                    progress.update(task, description=escape(f"pass {loop + 1}/{loops}: {step.pose.name}"))
                    seconds = robot.movej(step.joints, a=a, v=v, expected_pose=pose)
                    results.append(Reached(step, *robot.tcp_pose().distance(pose), seconds))
                    progress.advance(task)
    except KeyboardInterrupt:
        robot.stop()  # the driver already stops a motion it was watching; this covers a Ctrl-C between moves
        raise
    return results


def speed_and_acceleration(model, speed: float, acceleration: float, err: Console) -> tuple[float, float]:
    """--speed and --acceleration clamped to the model's slowest joint, saying so when they are lowered."""
    v, v_clamped = clamp_to_model(speed, model.max_joint_speed, "--speed")
    a, a_clamped = clamp_to_model(acceleration, model.max_joint_acceleration, "--acceleration")
    if v_clamped:
        err.print(f"--speed {speed} rad/s exceeds the {model.name}'s limit: using {v:.4f} rad/s")
    if a_clamped:
        err.print(f"--acceleration {acceleration} rad/s² exceeds the {model.name}'s limit: using {a:.4f} rad/s²")
    return a, v


# ---------------------------------------------------------------- commands


@cli.command()
@display_options
@click.pass_obj
def status(settings: Settings):
    """The robot: model, software, modes, joints, TCP pose and TCP offset.

    \b
    Examples:
      ur3dq --host 192.168.1.10 status
      ur3dq status --deg --json
    """
    with robot_session(settings) as robot:
        state = robot.state()
        version = ".".join(str(part) for part in robot.controller_version)
        if settings.json:
            emit_json({"host": robot.host, "backend": robot.backend_name, "model": robot.model_name,
                       "controller_version": version, "robot_mode": state.robot_mode_name,
                       "safety_mode": state.safety_mode_name, "program_running": state.program_running,
                       "joints": state.joints.tolist(), "tcp_pose": state.tcp_pose.tolist(),
                       "tcp_offset": robot.model.tcp.to_ur_pose().tolist(),
                       "speed_slider": state.target_speed_fraction})
            return
        settings.out.print(key_value_table(f"{robot.model_name} at {robot.host} ({robot.backend_name})", [
            ("controller software", version),
            ("robot mode", state.robot_mode_name),
            ("safety mode", state.safety_mode_name),
            ("program running", "yes" if state.program_running else "no"),
            ("joints", angles_text(state.joints, settings.deg)),
            ("TCP pose", pose_vector_text(state.tcp_pose, settings.deg)),
            ("TCP offset", pose_vector_text(robot.model.tcp.to_ur_pose(), settings.deg)),
            ("speed slider", f"{state.target_speed_fraction * 100:.0f} %"),
        ]))


@cli.command("record-pose")
@click.option("--name", help="Name of the pose (default: pose-N, the next free number); with --teach, the prefix.")
@click.option("--note", default="", help="A note kept with the pose.")
@click.option("--yes", "-y", is_flag=True, help="Record without asking.")
@click.option("--teach", is_flag=True,
              help="Freedrive on; each Enter records a pose (type a name first to name it), q ends.")
@waypoint_motion_options
@placement_options
@display_options
@click.pass_obj
def record_pose(settings: Settings, name, note, yes, teach, move, speed, acceleration, blend, after, before):
    """Record the arm's current pose: shows joints, TCP pose and dual quaternion, asks "Record this pose?".

    Each pose keeps its name, time, model, joints, dual quaternion, UR pose vector and TCP offset. Two
    record-pose at once both keep their poses; a taken --name is refused (the store stays unchanged).

    \b
    Examples:
      ur3dq record-pose --name pick
      ur3dq record-pose --yes --note "above the tray"      # for scripts
      ur3dq record-pose --teach --name station             # station-1, station-2, ... by hand
    """
    store = settings.store
    store.require_directory()
    steps = store.load_program()  # also refuses a corrupt store before touching the robot
    existing = [step.name for step in steps]
    check_waypoint_options(name, move, speed, acceleration, blend, after, before, steps, settings.store_path)
    if name and not teach and name in existing:
        raise StoreError(f"a pose named {name!r} already exists in {settings.store_path}; choose another --name")
    with robot_session(settings) as robot:
        if teach:
            _teach(settings, robot, name or "pose", note)
            return
        pose = read_pose(robot, name or next_free_name("pose", existing), note)
        if not settings.json:
            settings.out.print(key_value_table(f"{robot.model_name} at {robot.host}", pose_rows(robot, pose,
                                                                                                 settings.deg)))
        confirm("Record this pose?", yes)
        stored = record_waypoint(settings, pose, name is None, move, speed, acceleration, blend, after, before)
    if settings.json:
        emit_json({"recorded": stored.name, "store": str(settings.store_path)})
    else:
        click.echo(f"Recorded {stored.name!r} in {settings.store_path}.")


def _teach(settings: Settings, robot, prefix: str, note: str) -> None:
    """Freedrive on; every line on stdin records a pose (named by the line, else prefix-N) until `q` or end of
    input; freedrive goes off again whatever happens."""
    err = Console(stderr=True, highlight=False)
    robot.teach_mode(True)
    recorded = []
    try:
        err.print("Freedrive is on: move the arm by hand. Enter records the pose (type a name first to name it); "
                  "q then Enter ends.")
        for line in sys.stdin:
            text = line.strip()
            if text.lower() == "q":
                break
            taken = [pose.name for pose in settings.store.load()]
            try:
                pose = read_pose(robot, text or next_free_name(prefix, taken), note)
                stored = settings.store.add(pose, number_if_taken=not text)
            except (StoreError, ValueError) as error:  # a taken or bad name: say so and keep teaching
                err.print(f"not recorded: {error}")
                continue
            recorded.append(stored.name)
            err.print(f"recorded {stored.name!r}: {pose_vector_text(stored.ur_pose, settings.deg)}")
    finally:
        robot.teach_mode(False)
    if settings.json:
        emit_json({"recorded": recorded, "store": str(settings.store_path)})
    else:
        click.echo(f"Freedrive off. Recorded {len(recorded)} poses in {settings.store_path}"
                   + (f": {', '.join(recorded)}." if recorded else "."))


@cli.command("run-poses")
@click.argument("names", nargs=-1)
@click.option("--dry-run", is_flag=True, help="Show the plan and stop (no robot needed; uses it if one is set).")
@click.option("--yes", "-y", is_flag=True, help="Move without asking.")
@motion_options
@click.option("--blend", type=float, default=0.0, show_default=True,
              help="Blend radius in metres: the poses become one smooth path (0: stop at each pose).")
@click.option("--loop", "loops", type=click.IntRange(min=1), default=1, show_default=True,
              help="Run the sequence this many times.")
@click.option("--joints", "replay_joints", is_flag=True,
              help="Replay the recorded joint angles directly instead of solving IK.")
@click.option("--from", "start", metavar="N", help="Run the program from the step N (resume after a stop).")
@click.option("--to", "end", metavar="N", help="Run the program up to the step N.")
@click.option("--speed-scale", type=float, default=None, help="Scale every step's speed by F (0 < F ≤ 1).")
@cell_option
@display_options
@click.pass_obj
def run_poses(settings: Settings, names, dry_run, yes, speed, acceleration, blend, loops, replay_joints,
              max_travel, start, end, speed_scale, cell_path):
    """Replay stored poses (all, or NAMES in that order) with movej.

    For each pose: IK of its dual quaternion (every solution FK-checked), the solution nearest the recorded
    joints when the pose has them, else nearest the previous joints. The plan table shows each pose's chosen
    joints, the travel and the time; nothing moves unless every pose is reachable and within --max-travel.
    Ctrl-C stops the arm (stopj).

    \b
    Examples:
      ur3dq run-poses --dry-run
      ur3dq run-poses pick place --speed 0.5 --yes
      ur3dq run-poses --blend 0.02 --loop 3 --yes
      ur3dq run-poses --joints --yes                         # the recorded joints, no IK
    """
    err = Console(stderr=True, highlight=False)
    speed = angular_option(speed, DEFAULT_SPEED, settings.deg)
    acceleration = angular_option(acceleration, DEFAULT_ACCELERATION, settings.deg)
    max_travel = angular_option(max_travel, DEFAULT_MAX_JOINT_TRAVEL, settings.deg)
    if start or end or speed_scale is not None or settings.store.version() == 2:  # a cell program
        if names or loops > 1:
            raise click.UsageError("a cell program runs as a whole or --from/--to: no NAMES, no --loop")
        if not (math.isfinite(blend) and blend >= 0):
            raise ValueError(f"--blend must be a radius ≥ 0 in metres, got {blend!r}")
        if cell_path is not None:  # never run what was asked to be checked unchecked
            raise click.UsageError(f"the path check (--cell / UR3DQ_CELL {cell_path}) does not cover cell programs "
                                   "yet: run without it, or check the recorded poses with `ur3dq check`")
        return run_program_command(settings, start, end, 1.0 if speed_scale is None else speed_scale, dry_run,
                                   yes, speed, acceleration, blend, replay_joints, max_travel)
    poses = settings.store.select(names)
    if not poses:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    if not (math.isfinite(blend) and blend >= 0):
        raise ValueError(f"--blend must be a radius ≥ 0 in metres, got {blend!r}")
    if dry_run and not (settings.host or running_simulator_host()):
        model = robot_model(settings.model or poses[0].robot_model)
        a, v = speed_and_acceleration(model, speed, acceleration, err)
        steps = plan_replay(model, poses, None, a, v, replay_joints, max_travel)
        _show_plan(settings, steps, loops, f"Plan on a nominal {model.name} (no robot: travel from the first pose)")
        require_clear_path(settings, model, steps, None, blend, cell_path, loops)
        if settings.json:
            emit_json({"plan": plan_to_json(steps)})
        return
    with robot_session(settings, max_joint_travel=max_travel) as robot:
        a, v = speed_and_acceleration(robot.model, speed, acceleration, err)
        steps = plan_replay(robot.model, poses, robot.joints(), a, v, replay_joints, max_travel)
        if loops > 1 and loop_closing_travel(steps) > max_travel:
            raise SafetyCheckError(f"--loop: going back from {steps[-1].pose.name!r} to {steps[0].pose.name!r} "
                                   f"swings a joint further than --max-travel {max_travel:.3f} rad")
        _show_plan(settings, steps, loops, f"Plan on the {robot.model_name} at {robot.host}")
        require_clear_path(settings, robot.model, steps, robot.joints(), blend, cell_path, loops)
        if dry_run:
            if settings.json:
                emit_json({"plan": plan_to_json(steps)})
            return
        confirm(f"Move the arm through {len(steps)} poses{f' {loops} times' if loops > 1 else ''}?", yes)
        results = execute_plan(robot, steps, a, v, blend, loops, err)
    if settings.json:
        emit_json({"plan": plan_to_json(steps), "reached": [
            {"pose": r.step.pose.name, "error_m": r.error_m, "error_rad": r.error_rad, "seconds": r.seconds}
            for r in results]})
    else:
        settings.out.print(reached_table(results, "Where the arm ended (reported TCP vs recorded pose)"))


def _show_plan(settings: Settings, steps, loops: int, title: str) -> None:
    """Print the plan table (to stderr with --json, so stdout carries exactly one JSON document)."""
    if settings.json:
        Console(stderr=True, highlight=False).print(plan_table(steps, settings.deg, title))
        return
    settings.out.print(plan_table(steps, settings.deg, title + (f", × {loops}" if loops > 1 else "")))
