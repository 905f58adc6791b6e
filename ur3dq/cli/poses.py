"""`ur3dq poses ...`: look after the pose store (list, show, rm, rename, import, export) and edit it as a cell
program (set, retouch, move, copy, offset, add-step; docs/store-schema.md, version 2). The workflows these share
with other commands are in program_workflow.py.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import click
from rich.markup import escape
from rich.text import Text

from ur3dq.cli.app import Settings, cli, confirm, emit_json, emit_json_list, robot_session
from ur3dq.cli.display import (
    NARROW_WIDTH,
    Column,
    angles_text,
    coefficients_text,
    compact_pose_text,
    count_text,
    fitted_table,
    key_value_table,
    pose_vector_text,
)
from ur3dq.cli.options import (
    NUMBERS_CONTEXT,
    display_options,
    placement_options,
    ur_pose_from_input,
    waypoint_motion_options,
)
from ur3dq.cli.program_workflow import (
    add_step_at,
    find_step,
    insertion_index,
    list_program,
    motion_from_options,
    replace_step,
)
from ur3dq.errors import StoreError
from ur3dq.pose import next_free_name, utc_now_iso
from ur3dq.program.steps import (
    AnalogOut,
    DigitalOut,
    Message,
    Motion,
    RelativeWaypoint,
    Wait,
    WaitInput,
    Waypoint,
    describe,
    is_waypoint,
)
from ur3dq.store import format_store, format_thesis_lines, parse_store, pose_to_dict, write_atomically


@cli.group()
def poses():
    """Look after the pose store and edit it as a cell program.

    Look after the pose store: list, show, rm, rename, import, export; and edit it as a cell program: set,
    retouch, move, copy, offset, add-step (docs/store-schema.md, version 2).

    \b
    Examples:
      ur3dq poses list
      ur3dq poses show pick --deg
      ur3dq poses rename pose-3 place
      ur3dq poses import recorded.txt --prefix thesis   # thesis lines (8 numbers)
      ur3dq poses export cell.txt pick place           # back to thesis lines
      ur3dq --store other.json poses export all.json --format json
      ur3dq poses offset approach --from pick --z -0.05 --before pick
      ur3dq poses set pick --move linear --speed 0.05
      ur3dq poses add-step --after pick tool-out 0 on
    """


PLAIN_LIST_ROWS = 2000


@poses.command("list")
@display_options
@click.pass_obj
def list_poses(settings: Settings):
    """List the stored poses, or the cell program's steps.

    Every stored pose: name, time, model, TCP position and orientation, whether joints are known; for a cell
    program (store version 2) every step with its move type and parameters."""
    if list_program(settings):
        return
    stored = settings.store.load()
    if settings.json:
        emit_json_list(pose_to_dict(pose) for pose in stored)
        return
    if not stored:
        click.echo(f"{settings.store_path} has no poses yet: record one with `ur3dq record-pose`.")
        return
    narrow = settings.out.width < NARROW_WIDTH
    headers = ("#", "name", "recorded (UTC)", "model", "TCP pose", "joints", "note")
    title = f"{count_text(len(stored), 'pose')} in {settings.store_path}"
    if len(stored) > PLAIN_LIST_ROWS:  # a rich table of 10⁵ rows takes a minute to lay out: tab-separated lines
        rows = ((str(index), pose.name, pose.time, pose.robot_model, pose_vector_text(pose.ur_pose, settings.deg),
                 "yes" if pose.joints is not None else "no", pose.note) for index, pose in enumerate(stored, start=1))
        click.echo("\n".join([title, "\t".join(headers), *("\t".join(row) for row in rows)]))
        return
    settings.out.print(Text(title, no_wrap=True, overflow="ignore"))   # unwrapped: a table's title would cut the path
    columns = [Column("#", justify="right", no_wrap=True), Column("name", no_wrap=True),  # a name is never cut
               Column("recorded (UTC)", narrow_header="recorded", drop_order=2), Column("model", drop_order=3),
               Column("TCP pose", min_width=len(compact_pose_text([-0.9999] * 3, False)) if narrow else None),
               Column("joints", drop_order=1), Column("note", drop_order=4)]
    # narrow: the time to the minute, the pose vector's numbers compact so they wrap between values; user text
    # (names, notes) is shown as typed, never read as rich markup
    rows = [[str(index), escape(pose.name), pose.time[:16].replace("T", " ") if narrow else pose.time,
             escape(pose.robot_model), compact_pose_text(pose.ur_pose, settings.deg) if narrow
             else pose_vector_text(pose.ur_pose, settings.deg), "yes" if pose.joints is not None else "no",
             escape(pose.note)] for index, pose in enumerate(stored, start=1)]
    settings.out.print(fitted_table(None, columns, rows, settings.out.width))


@poses.command()
@click.argument("name")
@display_options
@click.pass_obj
def show(settings: Settings, name):
    """Everything stored about the pose NAME, and its thesis text line.

    \b
    Example:
      ur3dq poses show pick --deg
    """
    step = settings.store.get_step(name)
    if not hasattr(step, "pose"):  # a relative waypoint or an action step of a cell program: its stored fields
        from ur3dq.store_format import step_to_dict

        fields = step_to_dict(step)
        if settings.json:
            emit_json(fields)
            return
        settings.out.print(key_value_table(escape(f"Step {step.name!r} ({step.kind})"),
                                           [(key, escape(str(value))) for key, value in fields.items()]))
        return
    pose = step.pose
    if settings.json:
        emit_json({**pose_to_dict(pose), "thesis_line": pose.dq.to_thesis_line()})
        return
    settings.out.print(key_value_table(escape(f"Pose {pose.name!r}"), [
        ("recorded (UTC)", pose.time),
        ("robot", escape(f"{pose.robot_model}" + (f", serial {pose.robot_serial}" if pose.robot_serial else ""))),
        ("joints", angles_text(pose.joints, settings.deg) if pose.joints is not None else "not recorded"),
        ("TCP pose", pose_vector_text(pose.ur_pose, settings.deg)),
        ("dual quaternion", coefficients_text(pose.dual_quaternion)),
        ("thesis line", pose.dq.to_thesis_line()),
        ("TCP offset", pose_vector_text(pose.tcp_offset, settings.deg)),
        ("note", escape(pose.note)),
    ]))


@poses.command()
@click.argument("name")
@click.option("--yes", "-y", is_flag=True, help="Do not ask for confirmation.")
@click.pass_obj
def rm(settings: Settings, name, yes):
    """Remove the pose or step NAME from the store (asks first).

    \b
    Example:
      ur3dq poses rm pose-3 --yes
    """
    settings.store.get_step(name)  # an unknown name fails before the question
    confirm(f"Remove pose {name!r} from {settings.store_path}?", yes, default=False)
    removed = settings.store.remove(name)
    click.echo(f"Removed {removed.name!r}.")


@poses.command()
@click.argument("old")
@click.argument("new")
@click.pass_obj
def rename(settings: Settings, old, new):
    """Rename the pose OLD to NEW (NEW must be free).

    \b
    Example:
      ur3dq poses rename pose-1 pick
    """
    renamed = settings.store.rename(old, new)
    click.echo(f"Renamed {old!r} to {renamed.name!r}.")


@poses.command("import", context_settings=NUMBERS_CONTEXT)
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--prefix", help="Name thesis poses PREFIX-1, PREFIX-2, ... (default: the file's name).")
@click.option("--tcp", nargs=6, type=float, metavar="X Y Z RX RY RZ",
              help="TCP offset the thesis poses were recorded with (default none).")
@display_options
@click.pass_obj
def import_poses(settings: Settings, file: Path, prefix, tcp):
    """Add the poses of FILE (thesis lines or a ur3dq store).

    Add the poses of FILE: the thesis' text lines (`q.w q.x q.y q.z 0 p.x p.y p.z`, one pose a line,
    `#` comments allowed) or another ur3dq JSON store. All or nothing; taken names are numbered on.

    Thesis lines carry no joints and no model: --model (default ur3) and --tcp say what they were recorded with.

    \b
    Examples:
      ur3dq poses import poses/thesis-poses.txt --prefix thesis
      ur3dq --model ur5 poses import recorded.txt --tcp 0 0 0.2 0 0 0
      ur3dq poses import other-cell.json
    """
    text = file.read_text(encoding="utf-8")
    if text.lstrip().startswith("{"):
        if prefix or tcp:
            raise ValueError(f"{file} is a JSON pose store: --prefix and --tcp apply to thesis text files only")
        added = settings.store.add_many(parse_store(text, str(file)), number_if_taken=True)
    else:
        tcp_offset = ur_pose_from_input(tcp, settings.deg, "--tcp") if tcp else (0.0,) * 6
        added = settings.store.import_thesis_lines(file, settings.model or "ur3", tcp_offset, prefix)
    if settings.json:
        emit_json([pose.name for pose in added])
    else:
        names = ", ".join(p.name for p in added)
        click.echo(f"Imported {count_text(len(added), 'pose')} into {settings.store_path}: {names}")


@poses.command("export")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("names", nargs=-1)
@click.option("--format", "file_format", type=click.Choice(["thesis", "json"]), default="thesis", show_default=True,
              help="thesis: one 8-coefficient line per pose; json: a pose store file.")
@click.option("--yes", "-y", is_flag=True, help="Overwrite FILE without asking.")
@click.pass_obj
def export_poses(settings: Settings, file: Path, names, file_format, yes):
    """Write the poses (all, or NAMES in that order) to FILE (`-` for stdout), atomically.

    \b
    Examples:
      ur3dq poses export recorded.txt       # thesis lines, every pose
      ur3dq poses export - pick place       # two thesis lines on stdout
      ur3dq poses export backup.json --format json --yes
    """
    selected = settings.store.select(names)
    text = format_store(selected) if file_format == "json" else format_thesis_lines(pose.dq for pose in selected)
    if str(file) == "-":
        click.echo(text, nl=False)
        return
    if file.resolve() == settings.store_path.resolve():
        raise StoreError(f"{file} is the pose store itself; export to another file")
    if file.exists():
        confirm(f"Overwrite {file}?", yes, default=False)
    write_atomically(file, text)
    click.echo(f"Exported {count_text(len(selected), 'pose')} to {file} ({file_format}).")


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
    """Re-record the waypoint NAME from the arm's current pose.

    Re-record the waypoint NAME from the arm's current pose, in place: its move, speed, blend and its position
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
