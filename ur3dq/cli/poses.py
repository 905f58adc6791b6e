"""`ur3dq poses ...`: look after the pose store (list, show, rm, rename, import, export) and edit it as a cell
program (set, retouch, move, copy, offset, add-step; docs/store-schema.md, version 2). The workflows these share
with other commands are in program_workflow.py.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import click
import numpy as np
from rich.markup import escape
from rich.text import Text

from ur3dq.cli.app import (
    Settings,
    cli,
    confirm,
    emit_json,
    emit_json_list,
    prepare_output,
    report,
    robot_session,
    solving_poses,
)
from ur3dq.cli.display import (
    NARROW_WIDTH,
    Column,
    angles_text,
    coefficients_text,
    compact_pose_text,
    count_text,
    fitted_table,
    key_value_table,
    pose_label,
    pose_vector_text,
    recorded_joints_warnings,
)
from ur3dq.cli.options import (
    NUMBERS_CONTEXT,
    Quantity,
    TypedValue,
    display_options,
    placement_options,
    pose_vector_type,
    ur_pose_from_input,
    waypoint_motion_options,
)
from ur3dq.cli.program_workflow import (
    add_step_at,
    describe_step,
    find_step,
    insertion_index,
    list_program,
    motion_from_options,
    motion_text,
    program_model,
    replace_step,
    step_fields_text,
)
from ur3dq.errors import JointLimitError, StoreError, UnreachablePoseError, add_note
from ur3dq.json_text import read_utf8
from ur3dq.pose import next_free_name, utc_now_iso
from ur3dq.program.plan import plan_program
from ur3dq.program.resolve import resolve_targets
from ur3dq.program.steps import (
    MAX_OFFSET_M,
    MAX_WAIT_S,
    PIN_COUNT,
    AnalogOut,
    DigitalOut,
    Message,
    Motion,
    RelativeWaypoint,
    Step,
    Wait,
    WaitInput,
    Waypoint,
    is_waypoint,
)
from ur3dq.store import format_thesis_lines, with_added_steps, write_atomically
from ur3dq.store_format import format_store, parse_document, pose_to_dict, step_to_dict
from ur3dq.units import ANGLE, DURATION, LENGTH, plain_number, unit_label


@cli.group(short_help="List, show and edit the poses and cell program.")
def poses() -> None:
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
      ur3dq poses offset approach --from pick --z -50mm --before pick
      ur3dq poses set pick --move linear --speed 250mm/s
      ur3dq poses move place --after via
      ur3dq poses add-step --after pick tool-out 0 on
      ur3dq poses add-step --after tool-out-1 wait 500ms
    """


PLAIN_LIST_ROWS = 2000


@poses.command("list", short_help="Every stored pose or program step.")
@display_options
@click.pass_obj
def list_poses(settings: Settings) -> None:
    """List the stored poses, or the cell program's steps.

    Every stored pose: name, time, model, TCP position and orientation, whether joints are known; for a cell
    program (store version 2) every step with its move type and parameters."""
    steps = list_program(settings)
    if steps is not None:
        for line in recorded_joints_warnings([step.pose for step in steps if isinstance(step, Waypoint)]):
            click.echo(line, err=True)
        return
    stored = settings.store.load()
    for line in recorded_joints_warnings(stored):
        click.echo(line, err=True)
    if settings.json:
        emit_json_list({"store": str(settings.store_path), "version": 1}, "poses",
                       (pose_to_dict(pose) for pose in stored))
        return
    if not stored:
        click.echo(f"{settings.store_path} has no poses yet: record one with `ur3dq record-pose`.")
        return
    narrow = settings.out.width < NARROW_WIDTH
    units = settings.units
    headers = ("#", "name", "recorded (UTC)", "model", pose_label("TCP pose", units), "joints", "note")
    title = f"{count_text(len(stored), 'pose')} in {settings.store_path}"
    if len(stored) > PLAIN_LIST_ROWS:  # a rich table of 10⁵ rows takes a minute to lay out: tab-separated lines
        plain = ((str(index), pose.name, pose.time, pose.robot_model, pose_vector_text(pose.ur_pose, units),
                 "yes" if pose.joints is not None else "no", pose.note) for index, pose in enumerate(stored, start=1))
        click.echo("\n".join([title, "\t".join(headers), *("\t".join(row) for row in plain)]))
        return
    settings.out.print(Text(title, no_wrap=True, overflow="ignore"))   # unwrapped: a table's title would cut the path
    columns = [Column("#", justify="right", no_wrap=True), Column("name", no_wrap=True),  # a name is never cut
               Column("recorded (UTC)", narrow_header="recorded", drop_order=2), Column("model", drop_order=3),
               Column(headers[4], min_width=len(compact_pose_text([-0.9999] * 3, units)) if narrow else None),
               Column("joints", drop_order=1), Column("note", drop_order=4)]
    # narrow: the time to the minute, the pose vector's numbers compact so they wrap between values; user text
    # (names, notes) is shown as typed, never read as rich markup
    rows = [[str(index), escape(pose.name), pose.time[:16].replace("T", " ") if narrow else pose.time,
             escape(pose.robot_model), compact_pose_text(pose.ur_pose, units) if narrow
             else pose_vector_text(pose.ur_pose, units), "yes" if pose.joints is not None else "no",
             escape(pose.note)] for index, pose in enumerate(stored, start=1)]
    settings.out.print(fitted_table(None, columns, rows, settings.out.width))


@poses.command(short_help="Everything stored about one pose or step.")
@click.argument("name")
@display_options
@click.pass_obj
def show(settings: Settings, name: str) -> None:
    """Everything stored about the pose NAME, and its thesis text line.

    \b
    Example:
      ur3dq poses show pick --deg
    """
    step = settings.store.get_step(name)
    if not isinstance(step, Waypoint):  # a relative waypoint or an action step of a cell program: its stored fields
        fields = step_to_dict(step)
        if settings.json:
            emit_json({"step": fields})
            return
        settings.out.print(key_value_table(escape(f"Step {step.name!r} ({step.kind})"),
                                           [(key, escape(value)) for key, value in step_fields_text(
                                               step, settings.units)]))
        return
    pose = step.pose
    if settings.json:
        emit_json({"step": {"type": "waypoint", **step_to_dict(step), "thesis_line": pose.dq.to_thesis_line()}})
        return
    units = settings.units
    settings.out.print(key_value_table(escape(f"Pose {pose.name!r}"), [
        ("recorded (UTC)", pose.time),
        ("robot", escape(f"{pose.robot_model}" + (f", serial {pose.robot_serial}" if pose.robot_serial else ""))),
        (f"joints ({unit_label(ANGLE, units)})", angles_text(pose.joints, units) if pose.joints is not None
         else "not recorded"),
        (pose_label("TCP pose", units), pose_vector_text(pose.ur_pose, units)),
        ("dual quaternion", coefficients_text(pose.dual_quaternion)),
        ("thesis line", pose.dq.to_thesis_line()),
        (pose_label("TCP offset", units), pose_vector_text(pose.tcp_offset, units)),
        ("move", escape(motion_text(step.motion, units))),
        ("note", escape(pose.note)),
    ]))


@poses.command(short_help="Remove a pose or step (asks first).")
@click.argument("name")
@click.option("--yes", "-y", is_flag=True, help="Do not ask for confirmation.")
@display_options
@click.pass_obj
def rm(settings: Settings, name: str, yes: bool) -> None:
    """Remove the pose or step NAME from the store (asks first).

    \b
    Example:
      ur3dq poses rm pose-3 --yes
    """
    settings.store.get_step(name)  # an unknown name fails before the question
    confirm(f"Remove pose {name!r} from {settings.store_path}?", yes, default=False)
    removed = settings.store.remove(name)
    report(settings, {"removed": removed.name}, f"Removed {removed.name!r}.")


@poses.command(short_help="Rename a pose or step.")
@click.argument("old")
@click.argument("new")
@display_options
@click.pass_obj
def rename(settings: Settings, old: str, new: str) -> None:
    """Rename the pose OLD to NEW (NEW must be free).

    \b
    Example:
      ur3dq poses rename pose-1 pick
    """
    renamed = settings.store.rename(old, new)
    report(settings, {"renamed": old, "to": renamed.name}, f"Renamed {old!r} to {renamed.name!r}.")


@poses.command("import", context_settings=NUMBERS_CONTEXT,
               short_help="Add poses from thesis lines or a store.")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--prefix", help="Name thesis poses PREFIX-1, PREFIX-2, ... (default: the file's name).")
@click.option("--tcp", type=pose_vector_type(), default=None, metavar="X Y Z RX RY RZ",
              help="TCP offset the thesis poses were recorded with, e.g. 0 0 200mm 0 0 0 (default none).")
@display_options
@click.pass_obj
def import_poses(settings: Settings, file: Path, prefix: str | None, tcp: tuple[float, ...] | None) -> None:
    """Add the poses of FILE (thesis lines or a ur3dq store).

    Add the poses of FILE: the thesis' text lines (`q.w q.x q.y q.z 0 p.x p.y p.z`, one pose a line,
    `#` comments allowed) or another ur3dq JSON store, whose whole cell program is appended after the stored
    steps, each step as it is (move types, speeds, blends, relative waypoints, outputs, waits, messages). All or
    nothing; taken names are numbered on (said on stderr), relative waypoints following their base.

    Thesis lines carry no joints and no model: --model (default ur3) and --tcp say what they were recorded with.

    \b
    Examples:
      ur3dq poses import poses/thesis-poses.txt --prefix thesis
      ur3dq --model ur5 poses import recorded.txt --tcp 0 0 0.2 0 0 0
      ur3dq poses import other-cell.json
    """
    text = read_utf8(file)
    if text.lstrip().startswith("{"):
        if prefix or tcp:
            raise ValueError(f"{file} is a JSON pose store: --prefix and --tcp apply to thesis text files only")
        return _import_store(settings, file, text)
    tcp_offset = tuple(ur_pose_from_input(tcp, "--tcp").tolist()) if tcp else (0.0,) * 6
    added = settings.store.add_thesis_text(text, file, settings.model or "ur3", tcp_offset, prefix)
    report(settings, {"imported": [pose.name for pose in added]},
           f"Imported {count_text(len(added), 'pose')} into {settings.store_path}: "
           f"{', '.join(p.name for p in added)}")


def _import_store(settings: Settings, file: Path, text: str) -> None:
    """`poses import` of another ur3dq store: its whole program appended, each step as it is (with_added_steps);
    a taken name numbered on, with a warning naming both."""
    _, steps = parse_document(text, str(file))

    def edit(existing: list[Step]) -> tuple[list[Step], tuple[list[Step], list[tuple[str, str]]]]:
        result, added, renamed = with_added_steps(existing, steps)
        return result, (added, renamed)

    added, renamed = settings.store.update_program(edit)
    for old, new in renamed:
        click.echo(f"Warning: the name {old!r} is taken; imported as {new!r}", err=True)
    plain = all(isinstance(step, Waypoint) and step.motion == Motion() for step in added)
    report(settings, {"imported": [step.name for step in added]},
           f"Imported {count_text(len(added), 'pose' if plain else 'step')} into {settings.store_path}: "
           f"{', '.join(step.name for step in added)}")


@poses.command("export", short_help="Write poses to thesis lines or a JSON store.")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("names", nargs=-1)
@click.option("--format", "file_format", type=click.Choice(["thesis", "json"]), default="thesis", show_default=True,
              help="thesis: one 8-coefficient line per pose; json: a pose store file.")
@click.option("--yes", "-y", is_flag=True, help="Overwrite FILE without asking.")
@display_options
@click.pass_obj
def export_poses(settings: Settings, file: Path, names: tuple[str, ...], file_format: str, yes: bool) -> None:
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
        if settings.json:
            emit_json({"exported": [pose.name for pose in selected], "format": file_format, "text": text})
        else:
            click.echo(text, nl=False)
        return
    prepare_output(settings, file, yes)
    write_atomically(file, text)
    report(settings, {"exported": [pose.name for pose in selected], "format": file_format, "file": str(file)},
           f"Exported {count_text(len(selected), 'pose')} to {file} ({file_format}).")


@poses.command("set", short_help="Change a waypoint's move type, speed, blend.")
@click.argument("name")
@waypoint_motion_options
@click.option("--clear", is_flag=True, help="Back to a joint move at the run's speed, acceleration and blend.")
@display_options
@click.pass_obj
def set_waypoint(settings: Settings, name: str, move: str | None, speed: TypedValue | None,
                 acceleration: TypedValue | None, blend: TypedValue | None, clear: bool) -> None:
    """Change how the arm moves to the waypoint NAME (only the options given change). A value out of the
    model's range for the move type is refused with the range.

    \b
    Examples:
      ur3dq poses set pick --move linear --speed 250mm/s
      ur3dq poses set via --speed 60deg/s --blend 20mm
      ur3dq poses set pick --clear
    """

    def edit(steps: list[Step]) -> tuple[list[Step], Waypoint | RelativeWaypoint]:
        step = find_step(steps, name, settings.store_path)
        if not is_waypoint(step):
            raise ValueError(f"{step.who}: not a waypoint; only waypoints have a move, speed and blend")
        base = Motion() if clear else step.motion
        motion = motion_from_options(base, move, speed, acceleration, blend, step.who,
                                     program_model(settings, steps))
        new = dataclasses.replace(step, motion=motion)
        return replace_step(steps, name, new, settings.store_path), new

    updated = settings.store.update_program(edit)
    report(settings, {"updated": step_to_dict(updated)},
           f"Updated {name!r}: {motion_text(updated.motion, settings.units)}.")


@poses.command(short_help="Re-record a waypoint at the arm's pose.")
@click.argument("name")
@click.option("--yes", "-y", is_flag=True, help="Re-record without asking.")
@display_options
@click.pass_obj
def retouch(settings: Settings, name: str, yes: bool) -> None:
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

        def edit(steps: list[Step]) -> tuple[list[Step], None]:
            current = find_step(steps, name, settings.store_path)
            if not isinstance(current, Waypoint):
                raise ValueError(f"{current.who}: only a recorded waypoint can be re-recorded")
            return replace_step(steps, name, Waypoint(name, pose, current.motion), settings.store_path), None

        settings.store.update_program(edit)
    report(settings, {"retouched": name, "ur_pose": list(pose.ur_pose)}, f"Re-recorded {name!r}.")


@poses.command("move", short_help="Move a step before or after another.")
@click.argument("name")
@placement_options
@display_options
@click.pass_obj
def move_step(settings: Settings, name: str, after: str | None, before: str | None) -> None:
    """Move the step NAME to just after/before the step M.

    \b
    Example:
      ur3dq poses move approach --before pick
    """
    if not (after or before):
        raise click.UsageError("give --after M or --before M")

    def edit(steps: list[Step]) -> tuple[list[Step], int]:
        step = find_step(steps, name, settings.store_path)
        rest = [s for s in steps if s is not step]
        index = insertion_index(rest, after, before, settings.store_path)
        return rest[:index] + [step] + rest[index:], index + 1

    position = settings.store.update_program(edit)
    report(settings, {"moved": name, "position": position}, f"Moved {name!r} to position {position}.")


def name_taken(name: str) -> StoreError:
    """The refusal of a new step whose name another step has, naming the ways on."""
    return StoreError(f"a step named {name!r} already exists: choose another name, or remove it first "
                      f"(`ur3dq poses rm {name}`)")


@poses.command("copy", short_help="Copy a step under a new name.")
@click.argument("name")
@click.argument("new")
@placement_options
@display_options
@click.pass_obj
def copy_step(settings: Settings, name: str, new: str, after: str | None, before: str | None) -> None:
    """Copy the step NAME as NEW (just after NAME unless --after/--before say otherwise).

    \b
    Example:
      ur3dq poses copy pick pick-again
    """

    def make(steps: list[Step]) -> Step:
        if any(step.name == new for step in steps):
            raise name_taken(new)
        step = find_step(steps, name, settings.store_path)
        if isinstance(step, Waypoint):
            return Waypoint(new, step.pose.renamed(new), step.motion)
        return dataclasses.replace(step, name=new)

    add_step_at(settings, make, after or (None if before else name), before)
    report(settings, {"copied": name, "to": new}, f"Copied {name!r} to {new!r}.")


#: An offset's turn: a bare number over a half turn is refused (a turn of 5 is 5° far more often than 286°).
OFFSET_TURN = Quantity(ANGLE, (math.pi, "a half turn", "deg"))
#: An offset's shift: a bare number over a metre is millimetres typed without their unit.
OFFSET_LENGTH = Quantity(LENGTH, (1.0, "a metre", "mm"), most=MAX_OFFSET_M)
#: A wait or a wait's timeout: a bare number over a minute is milliseconds typed without their unit.
WAIT_TIME = Quantity(DURATION, (60.0, "a minute", "ms"), most=MAX_WAIT_S)


@poses.command("offset", short_help="Add a waypoint at an offset from another.")
@click.argument("new")
@click.option("--from", "base", required=True, metavar="N", help="The waypoint it is relative to.")
@click.option("--x", "dx", type=OFFSET_LENGTH, default=0.0, metavar="D", help="Offset along x, e.g. 20mm.")
@click.option("--y", "dy", type=OFFSET_LENGTH, default=0.0, metavar="D", help="Offset along y.")
@click.option("--z", "dz", type=OFFSET_LENGTH, default=0.0, metavar="D",
              help="Offset along z, e.g. -50mm (bare: m, mm under --mm).")
@click.option("--rx", type=OFFSET_TURN, default=0.0, metavar="ANGLE",
              help="Rotation vector x, e.g. 5deg (bare: rad up to π, ° under --deg).")
@click.option("--ry", type=OFFSET_TURN, default=0.0, metavar="ANGLE", help="Rotation vector y.")
@click.option("--rz", type=OFFSET_TURN, default=0.0, metavar="ANGLE", help="Rotation vector z.")
@click.option("--frame", type=click.Choice(["tool", "base"]), default="tool", show_default=True,
              help="tool: along N's own TCP axes; base: along the robot's base axes.")
@waypoint_motion_options
@placement_options
@display_options
@click.pass_obj
def offset(settings: Settings, new: str, base: str, dx: float, dy: float, dz: float, rx: float, ry: float,
           rz: float, frame: str, move: str | None, speed: TypedValue | None, acceleration: TypedValue | None,
           blend: TypedValue | None, after: str | None, before: str | None) -> None:
    """A relative waypoint NEW at an offset from the waypoint N; it follows N when N is re-taught.

    \b
    Examples:
      ur3dq poses offset approach --from pick --z -50mm --before pick
          (50 mm back along the tool's z, run before pick)
      ur3dq poses offset lift --from place --z 100mm --frame base \\
          --move linear --speed 100mm/s
    """

    def make(steps: list[Step]) -> Step:
        if any(step.name == new for step in steps):
            raise name_taken(new)
        who = f"step {new!r} (relative waypoint)"
        model = program_model(settings, steps)
        motion = motion_from_options(Motion(), move, speed, acceleration, blend, who, model)
        step = RelativeWaypoint(new, base, (dx, dy, dz, rx, ry, rz), frame, motion,
                                note=f"offset from {base} ({frame} frame), {utc_now_iso()}")
        # refused now, not at the next check: an offset the arm cannot reach would stop every later run
        solving_poses(1, model)
        try:
            plan_program(model, [step], resolve_from=[*steps, step])
        except (UnreachablePoseError, JointLimitError) as error:
            add_note(error, f"(nothing added: choose an offset the {model.name} reaches from {base!r})")
            raise
        return step

    step = add_step_at(settings, make, after, before)
    report(settings, {"added": step_to_dict(step)},
           f"Added relative waypoint {new!r}: {describe_step(step, settings.units)}.\n"
           f"  {where_from_base(settings.store.load_program(), new, base)}")


def where_from_base(steps: list[Step], name: str, base: str) -> str:
    """Where the relative waypoint `name` lands from its waypoint `base`, in the robot's base frame and in words
    (above, below or beside it): a tool-frame offset's direction is not what a person sees."""
    targets = resolve_targets(steps)
    shift = (targets[name].pose.translation - targets[base].pose.translation) * 1000.0
    moved = float(np.linalg.norm(shift))
    if moved < 0.05:
        return f"Base frame: at the spot of {base!r}."
    words = ("above" if shift[2] > 0 else "below") if abs(shift[2]) >= 0.5 * moved else "beside"
    return (f"Base frame: {moved:.1f} mm {words} {base!r} "
            f"(Δx {shift[0]:+.1f} Δy {shift[1]:+.1f} Δz {shift[2]:+.1f} mm).")


# ---------------------------------------------------------------- poses add-step ...


@poses.group("add-step", short_help="Add an output, a wait, a wait-input, a message.")
@placement_options
@click.option("--name", help="Name of the step (default: its type, numbered: wait-1, ...).")
@display_options
@click.pass_context
def add_step(ctx: click.Context, after: str | None, before: str | None, name: str | None) -> None:
    """Add an action step: an output, a wait, a wait for an input, a message.

    \b
    Examples:
      ur3dq poses add-step --after pick tool-out 0 on
      ur3dq poses add-step --after pick wait 500ms
      ur3dq poses add-step --before place wait-input 3 on --timeout 10s
      ur3dq poses add-step digital-out 2 off
      ur3dq poses add-step message "cycle done"
    """
    ctx.meta["ur3dq.add_step"] = (after, before, name)


def _add_action(build: Callable[[str], Step], prefix: str) -> None:
    """Insert the action `build(name)` where the add-step options say; prints what was added."""
    ctx = click.get_current_context()
    settings: Settings = ctx.obj
    after, before, name = ctx.meta["ur3dq.add_step"]

    def make(steps: list[Step]) -> Step:
        taken = {step.name for step in steps}
        if name and name in taken:
            raise name_taken(name)
        return build(name or next_free_name(prefix, taken))

    step = add_step_at(settings, make, after, before)
    report(settings, {"added": step_to_dict(step)},
           f"Added {step.kind} step {step.name!r}: {describe_step(step, settings.units)}.")


ON_OFF = click.Choice(["on", "off"])


def _digital_out_command(command_name: str, output: str) -> click.Command:
    @add_step.command(command_name, help=f"Set {output} digital output PIN (0-{PIN_COUNT[output] - 1}) on or off.",
                      short_help=f"Set a {output} digital output on or off.")
    @click.argument("pin", type=int)
    @click.argument("value", type=ON_OFF)
    @display_options
    def command(pin: int, value: str) -> None:
        _add_action(lambda name: DigitalOut(name, output, pin, value == "on"), command_name)

    return command


_digital_out_command("digital-out", "standard")
_digital_out_command("tool-out", "tool")
_digital_out_command("configurable-out", "configurable")


@add_step.command("analog-out", short_help="Set a standard analog output (0..1).")
@click.argument("pin", type=int)
@click.argument("value")
@display_options
def analog_out(pin: int, value: str) -> None:
    """Set standard analog output PIN to VALUE, a fraction 0..1 of its range."""
    fraction = plain_number(value, "VALUE")
    _add_action(lambda name: AnalogOut(name, pin, fraction), "analog-out")


@add_step.command("wait", short_help="Wait a time, e.g. 500ms or 2s.")
@click.argument("seconds", type=WAIT_TIME, metavar="TIME")
@display_options
def wait(seconds: float) -> None:
    """Wait TIME: 500ms, 2s, or a bare number of seconds up to 60 (longer: with its unit, 90s)."""
    _add_action(lambda name: Wait(name, seconds), "wait")


@add_step.command("wait-input", short_help="Wait until a digital input is on/off.")
@click.argument("pin", type=int)
@click.argument("value", type=ON_OFF)
@click.option("--timeout", type=WAIT_TIME, default="10s", show_default=True, metavar="TIME",
              help="Fail the run if the input has not changed after this long.")
@click.option("--input", "kind", type=click.Choice(["standard", "tool", "configurable"]), default="standard",
              show_default=True, help="Which digital inputs PIN is one of.")
@display_options
def wait_input(pin: int, value: str, timeout: float, kind: str) -> None:
    """Wait until digital input PIN is on/off."""
    _add_action(lambda name: WaitInput(name, kind, pin, value == "on", timeout), "wait-input")


@add_step.command("message", short_help="Write a line to the controller's log.")
@click.argument("text")
@display_options
def message(text: str) -> None:
    """Write TEXT to the controller's log (shown by the run)."""
    _add_action(lambda name: Message(name, text), "message")
