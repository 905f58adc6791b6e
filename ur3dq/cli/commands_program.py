"""`ur3dq poses set/retouch/move/copy/offset/add-step`: editing the store as a cell program
(docs/store-schema.md, version 2); the workflows they share with other commands are in program_workflow.py.
"""
from __future__ import annotations

import dataclasses

import click

from ur3dq.cli.app import Settings, confirm, poses, robot_session
from ur3dq.cli.options import placement_options, waypoint_motion_options
from ur3dq.cli.program_workflow import add_step_at, find_step, insertion_index, motion_from_options, replace_step
from ur3dq.errors import StoreError
from ur3dq.pose import next_free_name, utc_now_iso
from ur3dq.program.steps import (
    AnalogOut, DigitalOut, Message, Motion, RelativeWaypoint, Wait, WaitInput, Waypoint, describe, is_waypoint,
)
@poses.command("set")
@click.argument("name")
@waypoint_motion_options
@click.option("--clear", is_flag=True, help="Back to a joint move at the run's speed, acceleration and blend.")
@click.pass_obj
def set_waypoint(settings: Settings, name, move, speed, acceleration, blend, clear):
    """Change how the arm moves to the waypoint NAME (only the options given change).

    \b
    Examples:
      ur3dq poses set pick --move linear --speed 0.05
      ur3dq poses set via --blend 0.02
      ur3dq poses set pick --clear
    """

    def edit(steps):
        step = find_step(steps, name, settings.store_path)
        if not is_waypoint(step):
            raise ValueError(f"{step.who}: not a waypoint; only waypoints have a move, speed and blend")
        base = Motion() if clear else step.motion
        return replace_step(steps, name, dataclasses.replace(
            step, motion=motion_from_options(base, move, speed, acceleration, blend)), settings.store_path), None

    settings.store.update_program(edit)
    click.echo(f"Updated {name!r}.")


@poses.command()
@click.argument("name")
@click.option("--yes", "-y", is_flag=True, help="Re-record without asking.")
@click.pass_obj
def retouch(settings: Settings, name, yes):
    """Re-record the waypoint NAME from the arm's current pose, in place: its move, speed, blend and its position
    in the program stay; relative waypoints based on it move with it. Asks first.

    \b
    Example:
      ur3dq poses retouch pick --yes
    """
    from ur3dq.replay import read_pose

    step = find_step(settings.store.load_program(), name, settings.store_path)
    if not isinstance(step, Waypoint):
        raise ValueError(f"{step.who}: only a recorded waypoint can be re-recorded")
    with robot_session(settings) as robot:
        pose = read_pose(robot, name, note=step.pose.note)
        confirm(f"Re-record {name!r} at the arm's current pose?", yes, default=False)

        def edit(steps):
            current = find_step(steps, name, settings.store_path)
            if not isinstance(current, Waypoint):
                raise ValueError(f"{current.who}: only a recorded waypoint can be re-recorded")
            return replace_step(steps, name, Waypoint(name, pose, current.motion), settings.store_path), None

        settings.store.update_program(edit)
    click.echo(f"Re-recorded {name!r}.")


@poses.command("move")
@click.argument("name")
@placement_options
@click.pass_obj
def move_step(settings: Settings, name, after, before):
    """Move the step NAME to just after/before the step M.

    \b
    Example:
      ur3dq poses move approach --before pick
    """
    if not (after or before):
        raise click.UsageError("give --after M or --before M")

    def edit(steps):
        step = find_step(steps, name, settings.store_path)
        rest = [s for s in steps if s is not step]
        index = insertion_index(rest, after, before, settings.store_path)
        return rest[:index] + [step] + rest[index:], None

    settings.store.update_program(edit)
    click.echo(f"Moved {name!r}.")


@poses.command("copy")
@click.argument("name")
@click.argument("new")
@placement_options
@click.pass_obj
def copy_step(settings: Settings, name, new, after, before):
    """Copy the step NAME as NEW (just after NAME unless --after/--before say otherwise).

    \b
    Example:
      ur3dq poses copy pick pick-again
    """

    def make(steps):
        if any(step.name == new for step in steps):
            raise StoreError(f"a step named {new!r} already exists")
        step = find_step(steps, name, settings.store_path)
        if isinstance(step, Waypoint):
            return Waypoint(new, step.pose.renamed(new), step.motion)
        return dataclasses.replace(step, name=new)

    add_step_at(settings, make, after or (None if before else name), before)
    click.echo(f"Copied {name!r} to {new!r}.")


@poses.command("offset")
@click.argument("new")
@click.option("--from", "base", required=True, metavar="N", help="The waypoint it is relative to.")
@click.option("--x", "dx", type=float, default=0.0, help="Offset along x (m).")
@click.option("--y", "dy", type=float, default=0.0, help="Offset along y (m).")
@click.option("--z", "dz", type=float, default=0.0, help="Offset along z (m).")
@click.option("--rx", type=float, default=0.0, help="Rotation vector x (rad).")
@click.option("--ry", type=float, default=0.0, help="Rotation vector y (rad).")
@click.option("--rz", type=float, default=0.0, help="Rotation vector z (rad).")
@click.option("--frame", type=click.Choice(["tool", "base"]), default="tool", show_default=True,
              help="tool: along N's own TCP axes; base: along the robot's base axes.")
@waypoint_motion_options
@placement_options
@click.pass_obj
def offset(settings: Settings, new, base, dx, dy, dz, rx, ry, rz, frame, move, speed, acceleration, blend, after,
           before):
    """A relative waypoint NEW at an offset from the waypoint N; it follows N when N is re-taught.

    \b
    Examples:
      ur3dq poses offset approach --from pick --z -0.05 --before pick
          (5 cm back along the tool's z, run before pick)
      ur3dq poses offset lift --from place --z 0.1 --frame base \\
          --move linear --speed 0.1
    """

    def make(steps):
        if any(step.name == new for step in steps):
            raise StoreError(f"a step named {new!r} already exists")
        motion = motion_from_options(Motion(), move, speed, acceleration, blend)
        return RelativeWaypoint(new, base, (dx, dy, dz, rx, ry, rz), frame, motion,
                                note=f"offset from {base} ({frame} frame), {utc_now_iso()}")

    add_step_at(settings, make, after, before)
    click.echo(f"Added relative waypoint {new!r} ({frame} frame of {base!r}).")


# ---------------------------------------------------------------- poses add-step ...


@poses.group("add-step")
@placement_options
@click.option("--name", help="Name of the step (default: its type, numbered: wait-1, ...).")
@click.pass_context
def add_step(ctx, after, before, name):
    """Add an action step: an output, a wait, a wait for an input, a message.

    \b
    Examples:
      ur3dq poses add-step --after pick tool-out 0 on
      ur3dq poses add-step --after pick wait 0.5
      ur3dq poses add-step --before place wait-input 3 on --timeout 10
      ur3dq poses add-step digital-out 2 off
      ur3dq poses add-step message "cycle done"
    """
    ctx.meta["ur3dq.add_step"] = (after, before, name)


def _add_action(build, prefix: str) -> None:
    """Insert the action `build(name)` where the add-step options say; prints what was added."""
    ctx = click.get_current_context()
    settings: Settings = ctx.obj
    after, before, name = ctx.meta["ur3dq.add_step"]

    def make(steps):
        taken = {step.name for step in steps}
        if name and name in taken:
            raise StoreError(f"a step named {name!r} already exists")
        return build(name or next_free_name(prefix, taken))

    step = add_step_at(settings, make, after, before)
    click.echo(f"Added {step.kind} step {step.name!r}: {describe(step)}.")


ON_OFF = click.Choice(["on", "off"])


def _digital_out_command(command_name: str, output: str):
    @add_step.command(command_name)
    @click.argument("pin", type=int)
    @click.argument("value", type=ON_OFF)
    def command(pin, value):
        _add_action(lambda name: DigitalOut(name, output, pin, value == "on"), command_name)

    command.__doc__ = f"Set {output} digital output PIN on or off."
    return command


_digital_out_command("digital-out", "standard")
_digital_out_command("tool-out", "tool")
_digital_out_command("configurable-out", "configurable")


@add_step.command("analog-out")
@click.argument("pin", type=int)
@click.argument("value", type=float)
def analog_out(pin, value):
    """Set standard analog output PIN to VALUE, a fraction 0..1 of its range."""
    _add_action(lambda name: AnalogOut(name, pin, value), "analog-out")


@add_step.command("wait")
@click.argument("seconds", type=float)
def wait(seconds):
    """Wait SECONDS."""
    _add_action(lambda name: Wait(name, seconds), "wait")


@add_step.command("wait-input")
@click.argument("pin", type=int)
@click.argument("value", type=ON_OFF)
@click.option("--timeout", type=float, default=10.0, show_default=True,
              help="Fail the run if the input has not changed after this many seconds.")
@click.option("--input", "kind", type=click.Choice(["standard", "tool", "configurable"]), default="standard",
              show_default=True)
def wait_input(pin, value, timeout, kind):
    """Wait until digital input PIN is on/off."""
    _add_action(lambda name: WaitInput(name, kind, pin, value == "on", timeout), "wait-input")


@add_step.command("message")
@click.argument("text")
def message(text):
    """Write TEXT to the controller's log (shown by the run)."""
    _add_action(lambda name: Message(name, text), "message")


# ---------------------------------------------------------------- run-poses / export-urscript of a program


