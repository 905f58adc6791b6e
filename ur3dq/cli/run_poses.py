"""`ur3dq run-poses`: replay the stored poses, or run the stored cell program, on the arm."""
from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import click
import numpy as np
from rich.console import Console
from rich.text import Text

from ur3dq.cli import run_session
from ur3dq.cli.app import Settings, cli, confirm, emit_json, robot_session, solving_poses
from ur3dq.cli.background_simulator import running_simulator_host
from ur3dq.cli.display import count_text, print_table, reached_table, recorded_joints_warnings, replay_plan
from ur3dq.cli.options import (
    DEFAULT_ACCELERATION,
    DEFAULT_SPEED,
    SMALL_LENGTH,
    cell_option,
    check_blend,
    check_max_travel,
    display_options,
    motion_options,
    or_default,
    speed_and_acceleration,
)
from ur3dq.cli.path_report import check_replay, check_verdict, report_path_check, require_passed
from ur3dq.cli.plan_summary import replay_figures, summary_lines
from ur3dq.cli.program_workflow import run_program_command
from ur3dq.cli.resume_state import ResumeState, load_resume_state, store_digest
from ur3dq.cli.tcp_check import for_the_current_tcp, tcp_option
from ur3dq.errors import SafetyCheckError, StoreError
from ur3dq.kinematics import robot_model
from ur3dq.kinematics.models import URModel
from ur3dq.pose import Pose
from ur3dq.replay import PlanStep, execute_plan, loop_closing_travel, plan_replay
from ur3dq.robot.safety import DEFAULT_MAX_JOINT_TRAVEL


def plan_to_json(steps: Iterable[PlanStep]) -> list[dict[str, Any]]:
    """The plan in SI units for --json."""
    return [{"pose": step.pose.name, "joints": step.joints.tolist(), "source": step.source,
             "solutions": step.solutions, "travel": step.travel, "duration": step.duration,
             "fk_error_m": step.fk_error_m, "fk_error_rad": step.fk_error_rad} for step in steps]


@cli.command("run-poses", short_help="Run the poses or cell program on the arm.")
@click.argument("names", nargs=-1)
@click.option("--dry-run", is_flag=True, help="Show the plan and stop (no robot needed; uses it if one is set).")
@click.option("--plan", "full_plan", is_flag=True,
              help="Show the full plan table and the path check's table before the question.")
@click.option("--yes", "-y", is_flag=True, help="Move without asking.")
@motion_options
@click.option("--blend", type=SMALL_LENGTH, default=0.0, metavar="R",
              help="Blend radius, e.g. 20mm: the poses become one smooth path [default: 0, stop at each pose].")
@click.option("--loop", "loops", type=click.IntRange(min=1), default=1, show_default=True,
              help="Run the sequence this many times.")
@click.option("--joints", "replay_joints", is_flag=True,
              help="Replay the recorded joint angles directly instead of solving IK.")
@tcp_option
@click.option("--from", "start", metavar="N", help="Run the program from the step N (resume after a stop).")
@click.option("--to", "end", metavar="N", help="Run the program up to the step N.")
@click.option("--speed-scale", type=float, default=None, metavar="F",
              help="Scale every step's speed by F (0 < F ≤ 1).")
@click.option("--resume", is_flag=True,
              help="Go on from the step where the last run of this store stopped (Ctrl-C, a stop, a fault): first "
                   "from where the arm is to that step's target by its own move (a new path, checked), then the "
                   "rest, with that run's options. Refused if the store changed or the arm is another one.")
@cell_option
@display_options
@click.pass_obj
def run_poses(settings: Settings, names: tuple[str, ...], dry_run: bool, full_plan: bool, yes: bool,
              speed: float | None, acceleration: float | None, blend: float, loops: int, replay_joints: bool,
              max_travel: float | None, tcp_choice: str | None, start: str | None, end: str | None,
              speed_scale: float | None, resume: bool, cell_path: Path | None) -> None:
    """Replay stored poses (all, or NAMES in that order) with movej.

    For each pose: IK of its dual quaternion (every solution FK-checked), the solution nearest the recorded
    joints when the pose has them, else nearest the previous joints. The question comes under a short summary
    (steps, time, travel, the path check's verdict, warnings); --plan shows the whole plan table first. Nothing
    moves unless every pose is reachable, within --max-travel and through the path check. A cell program (after
    `poses set/offset/add-step`) runs as one URScript program. While the arm moves: p (or Ctrl-Z, SIGUSR1) pauses
    it on its path, then r (SIGCONT) resumes, s stops, q quits; Ctrl-C stops the arm (stopj). A run that stops
    early says where, and --resume goes on from there.

    \b
    Examples:
      ur3dq run-poses --dry-run
      ur3dq run-poses --cell cell.json --plan
      ur3dq run-poses pick place --speed 30deg/s --yes
      ur3dq run-poses --blend 20mm --loop 3 --yes
      ur3dq run-poses --joints --yes            # the recorded joints, no IK
      ur3dq run-poses --resume                  # go on after a stop
    """
    err = Console(stderr=True, highlight=False)
    if resume:
        if names or start or end or loops > 1:
            raise click.UsageError("--resume goes on with the stopped run's own steps and options: no NAMES, "
                                   "--from, --to or --loop")
        return _resume(settings, dry_run, yes, full_plan)
    speed = or_default(speed, DEFAULT_SPEED)
    acceleration = or_default(acceleration, DEFAULT_ACCELERATION)
    max_travel = check_max_travel(or_default(max_travel, DEFAULT_MAX_JOINT_TRAVEL))
    if start or end or speed_scale is not None or settings.store.version() == 2:  # a cell program
        if names or loops > 1:
            raise click.UsageError("a cell program runs as a whole or --from/--to: no NAMES, no --loop")
        check_blend(blend)
        return run_program_command(settings, start, end, 1.0 if speed_scale is None else speed_scale, dry_run,
                                   yes, speed, acceleration, blend, replay_joints, max_travel, cell_path, full_plan,
                                   tcp_choice=tcp_choice)
    poses = settings.store.select(names)
    if not poses:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    check_blend(blend)
    if dry_run and not (settings.host or running_simulator_host()):
        model = robot_model(settings.model or poses[0].robot_model)
        solving_poses(len(poses) * loops, model)
        for line in recorded_joints_warnings(poses, model):
            click.echo(line, err=True)
        a, v = speed_and_acceleration(model, speed, acceleration, err, settings.units)
        steps = plan_replay(model, poses, None, a, v, replay_joints, max_travel)
        _present(settings, model, steps, None, blend, cell_path, loops, True, True,
                 f"Plan on a nominal {model.name} (no robot: travel from the first pose)")
        return
    options = {"speed": speed, "acceleration": acceleration, "blend": blend, "replay_joints": replay_joints,
               "max_travel": max_travel, "tcp": tcp_choice, "cell": None if cell_path is None else str(cell_path)}
    _replay(settings, poses, loops, dry_run, full_plan, yes, options)


def _replay(settings: Settings, poses: list[Pose], loops: int, dry_run: bool, full_plan: bool, yes: bool,
            options: dict[str, Any], resume: ResumeState | None = None) -> None:
    """Plan the replay of `poses` (`loops` times) on the arm, check its path, ask, and run it watched.

    `options` are the run's (speeds in SI, blend, --joints, --max-travel, --tcp, --cell); `resume` first checks
    that this is the arm the stopped run was on."""
    err = Console(stderr=True, highlight=False)
    digest = store_digest(settings.store_path)
    speed, acceleration, blend = options["speed"], options["acceleration"], options["blend"]
    replay_joints, max_travel = options["replay_joints"], options["max_travel"]
    cell_path = None if options["cell"] is None else Path(options["cell"])
    with robot_session(settings, max_joint_travel=max_travel) as robot:
        if resume is not None:
            resume.require_same_arm(robot)
        solving_poses(len(poses) * loops, robot.model)
        a, v = speed_and_acceleration(robot.model, speed, acceleration, err, settings.units)
        poses = for_the_current_tcp(poses, robot.model.tcp, options["tcp"], replay_joints, err)
        for line in recorded_joints_warnings(poses, robot.model):
            click.echo(line, err=True)
        steps = plan_replay(robot.model, poses, robot.joints(), a, v, replay_joints, max_travel)
        if loops > 1 and loop_closing_travel(steps) > max_travel:
            raise SafetyCheckError(f"--loop: going back from {steps[-1].pose.name!r} to {steps[0].pose.name!r} "
                                   f"swings a joint further than --max-travel {max_travel:.3f} rad")
        _present(settings, robot.model, steps, robot.joints(), blend, cell_path, loops, dry_run or full_plan,
                 dry_run, f"Plan on the {robot.model_name} at {robot.host}")
        if dry_run:
            return
        run_session.confirm_replacing_foreign_program(robot, yes)
        confirm(f"Move the arm through {count_text(len(steps), 'pose')}{f' {loops} times' if loops > 1 else ''}?", yes)
        names = [step.pose.name for step in steps] * loops
        record = run_session.run_record(settings, robot, "replay", None, options, digest)
        results = run_session.run_replay(
            settings, robot, lambda progress: execute_plan(robot, steps, a, v, blend, loops, progress), names, record)
    if settings.json:
        emit_json({"plan": plan_to_json(steps), "reached": [
            {"pose": r.step.pose.name, "error_m": r.error_m, "error_rad": r.error_rad, "seconds": r.seconds,
             "target_ur_pose": r.target.to_ur_pose().tolist(), "target_from_recorded_m": r.target_off_m}
            for r in results]})
    else:
        settings.out.print(reached_table(results, "Where the arm ended (reported TCP vs where it was aimed)",
                                          settings.out.width))


def _resume(settings: Settings, dry_run: bool, yes: bool, full_plan: bool) -> None:
    """`run-poses --resume`: the stopped run of this store, from its step, on the arm it stopped on."""
    state = load_resume_state(settings.store_path)
    state.require_same_store(settings.store_path)
    options = state.options
    cell_path = None if options["cell"] is None else Path(options["cell"])
    if state.kind == "program":
        return run_program_command(settings, state.step, state.end, options["speed_scale"], dry_run, yes,
                                   options["speed"], options["acceleration"], options["blend"],
                                   options["replay_joints"], options["max_travel"], cell_path, full_plan,
                                   resume=state, tcp_choice=options.get("tcp"))
    Console(stderr=True, highlight=False).print(Text(
        f"Resuming the replay at move {state.position}, to {state.step!r}: first a movej from where the arm is, "
        "path-checked from its joints."))
    return _replay(settings, settings.store.select(state.names), 1, dry_run, full_plan, yes, options, resume=state)


def _present(settings: Settings, model: URModel, steps: list[PlanStep], start_joints: np.ndarray | None,
             blend: float, cell_path: Path | None, loops: int, full: bool, final: bool, title: str) -> None:
    """Show the plan before the question: the full table and the check's margins when `full`, else a summary
    that fits 24 rows with the question; the check's problems once; SafetyCheckError when it failed. A dry
    run's (`final`) JSON is printed here."""
    result, _ = check_replay(model, steps, cell_path, start_joints, blend, loops, keep_samples=False)
    if full:
        _show_plan(settings, steps, loops, title)
        report_path_check(settings, result, cell_path)
    if not full or not final:
        err = Console(stderr=True, highlight=False)
        for line in summary_lines(replay_figures(steps, loops), check_verdict(result, cell_path), [],
                                  settings.units):
            err.print(Text(line))
    require_passed(settings, result)
    if settings.json and final:
        emit_json({"plan": plan_to_json(steps), "path_check": result.to_dict()})


def _show_plan(settings: Settings, steps: list[PlanStep], loops: int, title: str) -> None:
    """Print the plan table (to stderr with --json, so stdout carries exactly one JSON document)."""
    console = Console(stderr=True, highlight=False) if settings.json else settings.out
    columns, rows = replay_plan(steps, settings.units, console.width)
    print_table(console, title + (f", × {loops}" if loops > 1 else ""), columns, rows, len(steps))
