"""The commands that talk to the robot: `status`, `record-pose` (and --teach), `run-poses`."""
from __future__ import annotations

import sys

import click
from rich.console import Console

from ur3dq.cli.app import Settings, cli, confirm, emit_json, one_line, robot_session
from ur3dq.cli.background_simulator import running_simulator_host
from ur3dq.cli.display import (
    angles_text, count_text, key_value_table, pose_rows, pose_vector_text, print_table, progress_bar, reached_table,
    replay_plan,
)
from ur3dq.cli.options import (
    DEFAULT_ACCELERATION, DEFAULT_SPEED, angular_option, cell_option, check_blend, check_max_travel, display_options,
    motion_options, placement_options, speed_and_acceleration, waypoint_motion_options,
)
from ur3dq.cli.path_report import require_clear_path
from ur3dq.cli.program_workflow import check_waypoint_options, record_waypoint, run_program_command
from ur3dq.collector import built_to_last
from ur3dq.errors import RobotError, SafetyCheckError, StoreError
from ur3dq.kinematics import robot_model
from ur3dq.pose import next_free_name
from ur3dq.replay import (
    TCP_CURRENT, TCP_RECORDED, execute_plan, loop_closing_travel, plan_replay, read_pose, retarget_to_tcp, tcp_changed,
)
from ur3dq.robot.safety import DEFAULT_MAX_JOINT_TRAVEL


def plan_to_json(steps) -> list[dict]:
    """The plan in SI units for --json."""
    return [{"pose": step.pose.name, "joints": step.joints.tolist(), "source": step.source,
             "solutions": step.solutions, "travel": step.travel, "duration": step.duration,
             "fk_error_m": step.fk_error_m, "fk_error_rad": step.fk_error_rad} for step in steps]


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
    record-pose at once both keep their poses; a taken --name is refused (the store stays unchanged). To
    re-teach a pose: `ur3dq poses rm NAME`, then record it again (it then moves to the end of the replay order).

    \b
    Examples:
      ur3dq record-pose --name pick
      ur3dq record-pose --yes --note "above the tray"   # for scripts
      ur3dq record-pose --teach --name station   # station-1, -2, ... by hand
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
            settings.out.print(key_value_table(f"{robot.model_name} at {robot.host}", pose_rows(robot.model, pose,
                                                                                                 settings.deg)))
        confirm("Record this pose?", yes, default=True)  # not a motion: Enter records
        stored = record_waypoint(settings, pose, name is None, move, speed, acceleration, blend, after, before)
    if settings.json:
        emit_json({"recorded": stored.name, "store": str(settings.store_path)})
    else:
        click.echo(f"Recorded {stored.name!r} in {settings.store_path}.")


def _teach(settings: Settings, robot, prefix: str, note: str) -> None:
    """Freedrive on; every line on stdin records a pose (named by the line, else prefix-N) until `q` or end of
    input; `f` switches freedrive on again after another program ended it. Freedrive goes off again at the end
    (unless another program already ended it: switching it off would replace that program)."""
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
            if text.lower() == "f":
                robot.teach_mode(True)
                err.print("Freedrive is on again.")
                continue
            if not robot.freedrive_active():
                err.print("not recorded: freedrive was switched off by another program sent to the controller; "
                          "f then Enter switches it on again, q ends")
                continue
            taken = [pose.name for pose in settings.store.load()]
            try:
                pose = read_pose(robot, text or next_free_name(prefix, taken), note)
                stored = settings.store.add(pose, number_if_taken=not text)
            except (StoreError, ValueError) as error:  # a taken or bad name: say so and keep teaching
                err.print(f"not recorded: {error}")
                continue
            except RobotError as error:  # e.g. a dropped stream: ur3dq's own message, and the session goes on
                err.print(f"not recorded: {one_line(error)}; Enter tries again, q ends")
                continue
            recorded.append(stored.name)
            err.print(f"recorded {stored.name!r}:\n  {pose_vector_text(stored.ur_pose, settings.deg)}")
    finally:
        if robot.freedrive_active():
            robot.teach_mode(False)
    if settings.json:
        emit_json({"recorded": recorded, "store": str(settings.store_path)})
    else:
        click.echo(f"Freedrive off. Recorded {count_text(len(recorded), 'pose')} in {settings.store_path}"
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
@click.option("--tcp", "tcp_choice", type=click.Choice([TCP_RECORDED, TCP_CURRENT]),
              help="When the controller's TCP offset changed since a pose was recorded (required then): "
                   "`recorded` puts the flange where it was, `current` puts the current TCP on the recorded pose.")
@click.option("--from", "start", metavar="N", help="Run the program from the step N (resume after a stop).")
@click.option("--to", "end", metavar="N", help="Run the program up to the step N.")
@click.option("--speed-scale", type=float, default=None, help="Scale every step's speed by F (0 < F ≤ 1).")
@cell_option
@display_options
@click.pass_obj
def run_poses(settings: Settings, names, dry_run, yes, speed, acceleration, blend, loops, replay_joints,
              max_travel, tcp_choice, start, end, speed_scale, cell_path):
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
      ur3dq run-poses --joints --yes            # the recorded joints, no IK
    """
    err = Console(stderr=True, highlight=False)
    speed = angular_option(speed, DEFAULT_SPEED, settings.deg)
    acceleration = angular_option(acceleration, DEFAULT_ACCELERATION, settings.deg)
    max_travel = check_max_travel(angular_option(max_travel, DEFAULT_MAX_JOINT_TRAVEL, settings.deg))
    if start or end or speed_scale is not None or settings.store.version() == 2:  # a cell program
        if names or loops > 1:
            raise click.UsageError("a cell program runs as a whole or --from/--to: no NAMES, no --loop")
        check_blend(blend)
        return run_program_command(settings, start, end, 1.0 if speed_scale is None else speed_scale, dry_run,
                                   yes, speed, acceleration, blend, replay_joints, max_travel, cell_path)
    with built_to_last():   # the poses and the plan live until the command ends
        poses = settings.store.select(names)
    if not poses:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    check_blend(blend)
    if dry_run and not (settings.host or running_simulator_host()):
        model = robot_model(settings.model or poses[0].robot_model)
        a, v = speed_and_acceleration(model, speed, acceleration, err)
        with built_to_last():
            steps = plan_replay(model, poses, None, a, v, replay_joints, max_travel)
            _show_plan(settings, steps, loops, f"Plan on a nominal {model.name} (no robot: travel from the first "
                                               "pose)")
            require_clear_path(settings, model, steps, None, blend, cell_path, loops)
        if settings.json:
            emit_json({"plan": plan_to_json(steps)})
        return
    with robot_session(settings, max_joint_travel=max_travel) as robot:
        a, v = speed_and_acceleration(robot.model, speed, acceleration, err)
        poses = _for_the_current_tcp(poses, robot.model.tcp, tcp_choice, replay_joints, err)
        with built_to_last():
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
        confirm(f"Move the arm through {count_text(len(steps), 'pose')}{f' {loops} times' if loops > 1 else ''}?", yes)
        with progress_bar(err) as progress:
            results = execute_plan(robot, steps, a, v, blend, loops, progress)
    if settings.json:
        emit_json({"plan": plan_to_json(steps), "reached": [
            {"pose": r.step.pose.name, "error_m": r.error_m, "error_rad": r.error_rad, "seconds": r.seconds,
             "target_ur_pose": r.target.to_ur_pose().tolist(), "target_from_recorded_m": r.target_off_m}
            for r in results]})
    else:
        settings.out.print(reached_table(results, "Where the arm ended (reported TCP vs where it was aimed)",
                                          settings.out.width))


def _for_the_current_tcp(poses, tcp_now, choice, replay_joints: bool, err: Console):
    """The poses to plan, given the controller's TCP `tcp_now`: unchanged when every pose was recorded with it;
    otherwise a warning before anything moves, and the user's --tcp choice (SafetyCheckError without one)."""
    changed = [pose.name for pose in poses if tcp_changed(pose, tcp_now)]
    if not changed:
        return poses
    current = ", ".join(f"{value:.4f}" for value in tcp_now.to_ur_pose())
    err.print(f"Warning: the controller's TCP offset (p[{current}]) differs from the one {', '.join(changed)} "
              "was recorded with.")
    if choice is None:
        raise SafetyCheckError(f"the TCP offset changed since {', '.join(changed)} was recorded: choose --tcp "
                               "recorded (the flange goes where it was) or --tcp current (the current TCP goes on "
                               "the recorded pose)")
    if choice == TCP_CURRENT:
        if replay_joints:
            raise SafetyCheckError("--tcp current needs IK for the new TCP: drop --joints")
        return [retarget_to_tcp(pose, tcp_now) for pose in poses]
    return poses


def _show_plan(settings: Settings, steps, loops: int, title: str) -> None:
    """Print the plan table (to stderr with --json, so stdout carries exactly one JSON document)."""
    console = Console(stderr=True, highlight=False) if settings.json else settings.out
    columns, rows = replay_plan(steps, settings.deg, console.width)
    print_table(console, title + (f", × {loops}" if loops > 1 else ""), columns, rows, len(steps))
