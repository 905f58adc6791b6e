"""`ur3dq record-pose` (and --teach): record the arm's pose into the store."""
from __future__ import annotations

import sys
from typing import TYPE_CHECKING

import click
from rich.console import Console
from rich.markup import escape

from ur3dq.cli.app import Settings, cli, confirm, emit_json, one_line, robot_session, solving_poses
from ur3dq.cli.display import count_text, key_value_table, pose_rows, pose_vector_text
from ur3dq.cli.options import TypedValue, display_options, placement_options, waypoint_motion_options
from ur3dq.cli.program_workflow import check_waypoint_options, record_waypoint, same_spot_as
from ur3dq.errors import RobotError, StoreError
from ur3dq.pose import next_free_name
from ur3dq.replay import read_pose

if TYPE_CHECKING:
    from ur3dq.robot.robot import Robot


@cli.command("record-pose", short_help="Record the arm's pose (--teach: many, by hand).")
@click.option("--name", help="Name of the pose (default: pose-N, the next free number); with --teach, the prefix.")
@click.option("--note", default="", help="A note kept with the pose.")
@click.option("--yes", "-y", is_flag=True, help="Record without asking.")
@click.option("--teach", is_flag=True,
              help="Freedrive on; each Enter records a pose (type a name first to name it), q ends.")
@waypoint_motion_options
@placement_options
@display_options
@click.pass_obj
def record_pose(settings: Settings, name: str | None, note: str, yes: bool, teach: bool, move: str | None,
                speed: TypedValue | None, acceleration: TypedValue | None, blend: TypedValue | None, after: str | None,
                before: str | None) -> None:
    """Record the arm's current pose: shows joints, TCP pose and dual quaternion, asks "Record this pose?".

    Each pose keeps its name, time, model, joints, dual quaternion, UR pose vector and TCP offset. Two
    record-pose at once both keep their poses; a taken --name is refused (the store stays unchanged). To
    re-teach a pose: `ur3dq poses rm NAME`, then record it again (it then moves to the end of the replay order).

    \b
    Examples:
      ur3dq record-pose --name pick
      ur3dq record-pose --name pick --move linear --speed 100mm/s
      ur3dq record-pose --yes --note "above the tray"   # for scripts
      ur3dq record-pose --teach --name station   # station-1, -2, ... by hand
    """
    solving_poses(1)   # each recorded pose is one FK at most
    store = settings.store
    store.require_directory()
    steps = store.load_program()  # also refuses a corrupt store before touching the robot
    existing = [step.name for step in steps]
    motion = check_waypoint_options(settings, name, move, speed, acceleration, blend, after, before, steps)
    if name and not teach and name in existing:
        raise StoreError(f"a pose named {name!r} already exists in {settings.store_path}; choose another --name")
    with robot_session(settings) as robot:
        if teach:
            _teach(settings, robot, name or "pose", note)
            return
        pose = read_pose(robot, name or next_free_name("pose", existing), note)
        if not settings.json:
            settings.out.print(key_value_table(f"{robot.model_name} at {robot.host}", pose_rows(robot.model, pose,
                                                                                                 settings.units)))
        twin = same_spot_as(pose, steps)
        if twin:   # said before the question, whose default then becomes No
            Console(stderr=True, highlight=False).print(
                f"Warning: this is the spot of {escape(repr(twin))} (within 0.5 mm): did you forget to move the arm?")
        confirm("Record this pose?", yes, default=twin is None)  # not a motion: Enter records
        stored = record_waypoint(settings, pose, name is None, motion, after, before)
    if settings.json:
        emit_json({"recorded": stored.name, "store": str(settings.store_path), "same_spot_as": twin})
    else:
        click.echo(f"Recorded {stored.name!r} in {settings.store_path}.")


def simulator_hand_hint(robot: Robot) -> str | None:
    """On `ur3dq sim start`'s simulator, where nobody can push the arm: the command that does, from another
    terminal, at the arm's joints (rad) for the person to edit; None on any other controller."""
    from ur3dq.cli.background_simulator import running_simulator_host

    if robot.host != running_simulator_host():
        return None
    joints = " ".join(f"{value:.2f}".replace("-0.00", "0.00") for value in robot.joints())
    return ("On the simulator, be the hand from another terminal (six joints, rad):\n"   # two lines of < 80
            f"  sim-ursim move-by-hand --host {robot.host} \\\n      {joints}")


def _teach(settings: Settings, robot: Robot, prefix: str, note: str) -> None:
    """Freedrive on; every line on stdin records a pose (named by the line, else prefix-N) until `q` or end of
    input; `f` switches freedrive on again after another program ended it. Freedrive goes off again at the end
    (unless another program already ended it: switching it off would replace that program)."""
    err = Console(stderr=True, highlight=False)
    robot.teach_mode(True)
    recorded = []
    try:
        err.print("Freedrive is on: move the arm by hand. Enter records the pose (type a name first to name it); "
                  "q then Enter ends.")
        hand = simulator_hand_hint(robot)
        if hand:
            err.print(hand, soft_wrap=True)   # as composed: a command rewrapped would lose its --host
        for line in sys.stdin:
            text = line.strip()
            if text.lower() == "q":
                break
            if text.lower() == "f":
                robot.teach_mode(True)
                err.print("Freedrive is on again.")
                continue
            if not robot.freedrive_active():
                err.print("not recorded: freedrive ended (another program replaced its own, or the controller's "
                          "watchdog stopped it: ur3dq's heartbeat came late); f then Enter switches it on again, "
                          "q ends")
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
            err.print(f"recorded {stored.name!r}:\n  {pose_vector_text(stored.ur_pose, settings.units)}")
            twin = same_spot_as(stored, settings.store.load_program())
            if twin:
                err.print(f"Warning: {stored.name!r} is at the spot of {twin!r} (the arm did not move?); "
                          f"`ur3dq poses rm {stored.name}` removes it")
    finally:
        if robot.freedrive_active():
            robot.teach_mode(False)
    if settings.json:
        emit_json({"recorded": recorded, "store": str(settings.store_path)})
    else:
        click.echo(f"Freedrive off. Recorded {count_text(len(recorded), 'pose')} in {settings.store_path}"
                   + (f": {', '.join(recorded)}." if recorded else "."))
