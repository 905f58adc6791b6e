"""`ur3dq export-urp`: the cell program as a PolyScope program (.urp) the pendant opens."""
from __future__ import annotations

from pathlib import Path

import click

from ur3dq.cli.app import Settings, cli, prepare_output, report, robot_session, solving_poses
from ur3dq.cli.display import count_text
from ur3dq.cli.export_plans import checked_program_plan, clamped_joint_defaults
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
from ur3dq.polyscope.urp_export import MoveDefaults, export_bytes, is_e_series
from ur3dq.program.plan import Defaults
from ur3dq.program.steps import Step, Waypoint
from ur3dq.robot.safety import DEFAULT_MAX_JOINT_TRAVEL
from ur3dq.store import write_atomically


@cli.command("export-urp", short_help="Write the program as a PolyScope program (.urp).")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="The .urp file to write (required).")
@motion_options
@click.option("--blend", type=SMALL_LENGTH, default=0.0, metavar="R",
              help="Blend radius of waypoints that set none, e.g. 10mm [default: 0].")
@click.option("--joints", "replay_joints", is_flag=True, help="Write the recorded joints instead of solving IK.")
@click.option("--yes", "-y", is_flag=True, help="Overwrite the output file without asking.")
@click.option("--from", "start", metavar="N", help="Start at the step N.")
@click.option("--to", "end", metavar="N", help="End at the step N.")
@click.option("--calibration", type=click.Choice(["nominal", "robot"]), default="nominal", show_default=True,
              help="Plan on the model's catalogue kinematics, or on the connected arm's calibration.")
@cell_option
@display_options
@click.pass_obj
def export_urp(settings: Settings, output: Path | None, speed: float | None, acceleration: float | None, blend: float,
               replay_joints: bool, max_travel: float | None, yes: bool, start: str | None, end: str | None,
               calibration: str, cell_path: Path | None) -> None:
    """Write the cell program (or its --from/--to part) as a PolyScope program the pendant opens.

    The tree mirrors the program: a MoveJ, MoveL or MoveP per run of waypoints of one move type, each waypoint
    named as in the store with the joints run-poses would move to and its taught TCP; Set, Wait and Popup nodes
    for outputs, waits and messages; comments. The calibration of the arm it is planned on (--calibration) goes
    with it. The same program always gives the same file, and `ur3dq import-urp` reads it back as the same
    program (docs/polyscope.md says what maps to what). e-series arms get a gzip file (PolyScope 5), CB3 arms
    plain XML (PolyScope 3).

    Planned and checked as `run-poses --dry-run` plans and checks it: speeds and accelerations above the model's
    limits are lowered to them (the Move nodes' too), with the same warnings; a program whose path check fails
    (in the --cell cell if given) is not written: the check's one-line error, exit code 4.

    \b
    Examples:
      ur3dq export-urp -o cell.urp --cell cell.json
      ur3dq export-urp -o part.urp --from approach --to place --speed 60deg/s
      ur3dq export-urp -o cell.urp --calibration robot --host 192.168.0.10
    """
    output = urp_output(output)
    check_blend(blend)
    prepare_output(settings, output, yes)
    steps, part, _ = program_part(settings, start, end)
    defaults = Defaults(joint_acceleration=or_default(acceleration, DEFAULT_ACCELERATION),
                        joint_speed=or_default(speed, DEFAULT_SPEED), blend=blend)
    travel = check_max_travel(or_default(max_travel, DEFAULT_MAX_JOINT_TRAVEL))
    warnings = []
    if calibration == "robot":
        with robot_session(settings, max_joint_travel=travel) as robot:
            model = robot.model
            other_arm = taught_elsewhere(part, model.name, robot.serial_number)
        if other_arm:
            warnings.append(other_arm)
            click.echo(f"Warning: {other_arm}", err=True)
    else:
        model = program_model(settings, steps)
    solving_poses(len(part), model)
    plan, plan_lines = checked_program_plan(settings, model, steps, part, defaults, replay_joints, travel, cell_path)
    warnings += plan_lines
    # a waypoint that sets no speed of its own takes its Move's: the Move carries what the plan lowered it to
    move_defaults = MoveDefaults(*clamped_joint_defaults(model, defaults), defaults.tcp_speed,
                                 defaults.tcp_acceleration)
    data = export_bytes(plan, steps, output.stem, model, move_defaults)
    write_atomically(output, data)
    kind = "PolyScope 5, gzip" if is_e_series(model) else "PolyScope 3, XML"
    report(settings, {"program": output.stem, "file": str(output), "steps": [p.step.name for p in plan],
                      "model": model.name, "calibration": calibration, "warnings": warnings},
           f"Wrote {output}: {count_text(len(plan), 'step')} for a {model.name} ({kind}, "
           f"{'calibrated' if model.calibrated else 'nominal'} kinematics).")


def urp_output(output: Path | None) -> Path:
    """The file `-o` names; UsageError (exit 2) with the fix when there is none or it is stdout (`-`, which
    export-urscript takes for stdout): a .urp is a file for the pendant, not text."""
    if output is None or str(output) == "-":
        raise click.UsageError("export-urp writes a .urp file for the pendant, not to stdout: name it with -o, "
                               "e.g. `ur3dq export-urp -o cell.urp`")
    return output


def taught_elsewhere(steps: list[Step], model_name: str, serial: str | None) -> str | None:
    """A warning when waypoints of `steps` were recorded on another model, or on an arm of another serial number
    (when both are known), than the connected arm `model_name` (`serial`); else None.

    >>> taught_elsewhere([], "ur5e", None) is None
    True
    """
    poses = [step.pose for step in steps if isinstance(step, Waypoint)]
    models = sorted({pose.robot_model for pose in poses} - {model_name})
    serials = sorted({pose.robot_serial for pose in poses if pose.robot_serial} - {serial}) if serial else []
    if not models and not serials:
        return None
    where = [f"on a {'/'.join(name.upper() for name in models)}"] if models else []
    where += [f"on the arm with serial number {', '.join(serials)}"] if serials else []
    connected = f"the connected {model_name.upper()}" + (f" (serial number {serial})" if serial else "")
    return (f"poses of the program were taught {' and '.join(where)}, not on {connected}: the file carries the "
            "connected arm's calibration and its IK joints")
