"""`ur3dq export-urscript`: a URScript program (.script) of the stored poses or cell program."""
from __future__ import annotations

from pathlib import Path

import click

from ur3dq.cli.app import Settings, cli, emit_json, prepare_output, report, solving_poses
from ur3dq.cli.display import count_text
from ur3dq.cli.export_plans import check_replay_export, checked_program_plan
from ur3dq.cli.offline_plans import offline_plan
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
)
from ur3dq.cli.program_workflow import program_model, program_part
from ur3dq.pose import utc_now_iso
from ur3dq.program.plan import Defaults
from ur3dq.program.script import program_script
from ur3dq.replay import describe_speeds, replay_script
from ur3dq.robot.safety import DEFAULT_MAX_JOINT_TRAVEL
from ur3dq.store import write_atomically


@cli.command("export-urscript", short_help="Write the program as a URScript .script file.")
@click.argument("names", nargs=-1)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=Path("-"),
              show_default=True, help="The .script file to write (`-`: stdout).")
@motion_options
@click.option("--blend", type=SMALL_LENGTH, default=0.0, metavar="R",
              help="Blend radius between poses, e.g. 10mm [default: 0].")
@click.option("--loop", "loops", type=click.IntRange(min=1), default=1, show_default=True,
              help="Repeat the sequence this many times.")
@click.option("--joints", "replay_joints", is_flag=True, help="Use the recorded joints instead of solving IK.")
@click.option("--yes", "-y", is_flag=True, help="Overwrite the output file without asking.")
@click.option("--from", "start", metavar="N", help="A cell program: start at the step N.")
@click.option("--to", "end", metavar="N", help="A cell program: end at the step N.")
@cell_option
@display_options
@click.pass_obj
def export_urscript(settings: Settings, names: tuple[str, ...], output: Path, speed: float | None,
                    acceleration: float | None, blend: float, loops: int, replay_joints: bool,
                    max_travel: float | None, yes: bool, start: str | None, end: str | None,
                    cell_path: Path | None) -> None:
    """Write a URScript program (.script) of the cell program, or of the stored poses (all, or NAMES in order).

    Joint targets are planned as `run-poses` plans them (IK nearest the recorded joints), on the nominal model.
    A cell program is `def ur3dq_program(): ... end`; it writes the step number to general-purpose integer output
    register 22 (RTDE output_int_register_22) and a "ur3dq_step:" log line before every step (a PLC or the
    pendant can follow it; -N when step N's wait for an input timed out). Stored poses without a program are
    `def ur3dq_poses(): ... end`. Send it to the controller (port 30002) or load it on the pendant. Pose names
    appear only in comments. The first move starts from wherever the arm is: check it at low speed.

    Planned and checked as `run-poses --dry-run` plans and checks it: speeds and accelerations above the model's
    limits are lowered to them, with the same warnings; a program whose path check fails (in the --cell cell if
    given) is not written: the check's one-line error, exit code 4.

    \b
    Examples:
      ur3dq export-urscript -o cell.script --cell cell.json
      ur3dq export-urscript pick place --speed 30deg/s --blend 10mm \\
          --loop 10 -o cell.script
    """
    check_blend(blend)
    files = [name for name in names if Path(name).suffix.lower() in (".script", ".urscript")]
    if files and str(output) == "-":
        raise click.UsageError(f"{files[0]!r} is a file, not a step name: use -o {files[0]}")
    if start or end or settings.store.version() == 2:  # a cell program: the same program run-poses sends
        if names or loops > 1:
            raise click.UsageError("a cell program is exported as a whole or --from/--to: no NAMES, no --loop")
        travel = check_max_travel(or_default(max_travel, DEFAULT_MAX_JOINT_TRAVEL))
        defaults = Defaults(joint_acceleration=or_default(acceleration, DEFAULT_ACCELERATION),
                            joint_speed=or_default(speed, DEFAULT_SPEED), blend=blend)
        program, count, warnings = _program_text(settings, start, end, defaults, replay_joints, travel, cell_path)
        _write_program(settings, output, program, yes, count_text(count, "step"), "ur3dq_program", warnings)
        return
    model, steps, a, v = offline_plan(settings, names, or_default(speed, DEFAULT_SPEED),
                                      or_default(acceleration, DEFAULT_ACCELERATION), replay_joints,
                                      check_max_travel(or_default(max_travel, DEFAULT_MAX_JOINT_TRAVEL)))
    check_replay_export(settings, model, steps, blend, loops, cell_path)
    offsets = {step.pose.tcp_offset for step in steps}
    header = [
        f"ur3dq export-urscript: {count_text(len(steps), 'pose')} from {settings.store_path} for a {model.name}",
        f"generated {utc_now_iso()}",
        describe_speeds(a, v, blend),
        "the first move starts wherever the arm is: check it at low speed first",
    ]
    program = replay_script(steps, a, v, blend, loops, tcp_offset=offsets.pop() if len(offsets) == 1 else None,
                            header=header)
    _write_program(settings, output, program, yes,
                   count_text(len(steps), 'pose') + (f" × {loops}" if loops > 1 else ""), "ur3dq_poses")


def _program_text(settings: Settings, start: str | None, end: str | None, defaults: Defaults, replay_joints: bool,
                  max_travel: float, cell_path: Path | None) -> tuple[str, int, list[str]]:
    """(URScript text, number of steps, warning lines) of the stored cell program or its --from/--to part on the
    nominal model: the program run-poses sends, planned and path-checked as its dry run (export_plans)."""
    steps, part, first = program_part(settings, start, end)
    model = program_model(settings, steps)
    solving_poses(len(part), model)
    plan, warnings = checked_program_plan(settings, model, steps, part, defaults, replay_joints, max_travel,
                                          cell_path)
    header = [f"ur3dq export-urscript: steps {first}..{first + len(plan) - 1} of {settings.store_path} for a "
              f"{model.name}", f"generated {utc_now_iso()}",
              "the first move starts wherever the arm is: check it at low speed first"]
    return program_script(plan, header=header, first_position=first), len(plan), warnings


def _write_program(settings: Settings, output: Path, program: str, yes: bool, what: str, name: str,
                   warnings: list[str] | None = None) -> None:
    """The program on stdout (`-`) or into `output` (asking before overwriting), atomically; with --json, what
    was written (and the script itself when it went to stdout), and a cell program's plan `warnings`."""
    extra = {} if warnings is None else {"warnings": warnings}
    if str(output) == "-":
        if settings.json:
            emit_json({"program": name, "script": program, **extra})
        else:
            click.echo(program, nl=False)
        return
    prepare_output(settings, output, yes)
    write_atomically(output, program)
    report(settings, {"program": name, "file": str(output), **extra}, f"Wrote {output}: {what} (def {name}).")
