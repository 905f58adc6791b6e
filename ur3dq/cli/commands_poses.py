"""`ur3dq poses ...`: look after the pose store (list, show, rm, rename, import, export)."""
from __future__ import annotations

from pathlib import Path

import click
from rich.markup import escape
from rich.text import Text

from ur3dq.cli.app import Settings, confirm, emit_json, emit_json_list, poses
from ur3dq.cli.options import NUMBERS_CONTEXT, display_options, ur_pose_from_input
from ur3dq.cli.program_workflow import list_program
from ur3dq.cli.display import (
    NARROW_WIDTH, Column, angles_text, coefficients_text, compact_pose_text, count_text, fitted_table,
    key_value_table, pose_vector_text,
)
from ur3dq.errors import StoreError
from ur3dq.store import format_store, format_thesis_lines, parse_store, pose_to_dict, write_atomically


PLAIN_LIST_ROWS = 2000


@poses.command("list")
@display_options
@click.pass_obj
def list_poses(settings: Settings):
    """Every stored pose: name, time, model, TCP position and orientation, whether joints are known; for a cell
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
    """Add the poses of FILE: the thesis' text lines (`q.w q.x q.y q.z 0 p.x p.y p.z`, one pose a line,
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
        click.echo(f"Imported {count_text(len(added), 'pose')} into {settings.store_path}: {', '.join(p.name for p in added)}")


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
