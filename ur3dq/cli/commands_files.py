"""Commands that turn the store into files: `export-urscript` (a pendant program) and `plot` (a PNG)."""
from __future__ import annotations

from pathlib import Path

import click
from rich.console import Console

from ur3dq.cli.app import Settings, cli, confirm
from ur3dq.cli.display import count_text
from ur3dq.cli.options import (
    DEFAULT_ACCELERATION,
    DEFAULT_SPEED,
    angular_option,
    cell_option,
    check_blend,
    check_max_travel,
    deg_option,
    global_options,
    motion_options,
    speed_and_acceleration,
)
from ur3dq.cli.path_report import check_program, check_replay
from ur3dq.cli.program_workflow import export_program_text
from ur3dq.errors import StoreError
from ur3dq.pose import utc_now_iso
from ur3dq.program.plan import plan_program
from ur3dq.replay import describe_speeds, plan_replay, replay_script
from ur3dq.robot.safety import DEFAULT_MAX_JOINT_TRAVEL
from ur3dq.store import write_atomically
from ur3dq.store_format import PROGRAM_SCHEMA_VERSION


def offline_plan(settings: Settings, names, speed, acceleration, replay_joints, max_travel):
    """(model, plan, a, v) of the stored poses on the nominal model (--model, else the first pose's), no robot."""
    from ur3dq.kinematics import robot_model

    poses = settings.store.select(names)
    if not poses:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    model = robot_model(settings.model or poses[0].robot_model)
    a, v = speed_and_acceleration(model, speed, acceleration, Console(stderr=True, highlight=False))
    return model, plan_replay(model, poses, None, a, v, replay_joints, max_travel), a, v


def _writable_target(path: Path, yes: bool) -> None:
    """Ask before overwriting an existing file (unless --yes)."""
    if path.exists():
        confirm(f"Overwrite {path}?", yes, default=False)


@cli.command("export-urscript")
@click.argument("names", nargs=-1)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=Path("-"),
              show_default=True, help="The .script file to write (`-`: stdout).")
@motion_options
@click.option("--blend", type=float, default=0.0, show_default=True, help="Blend radius between poses, metres.")
@click.option("--loop", "loops", type=click.IntRange(min=1), default=1, show_default=True,
              help="Repeat the sequence this many times.")
@click.option("--joints", "replay_joints", is_flag=True, help="Use the recorded joints instead of solving IK.")
@click.option("--yes", "-y", is_flag=True, help="Overwrite the output file without asking.")
@click.option("--from", "start", metavar="N", help="A cell program: start at the step N.")
@click.option("--to", "end", metavar="N", help="A cell program: end at the step N.")
@deg_option
@click.pass_obj
def export_urscript(settings: Settings, names, output: Path, speed, acceleration, blend, loops, replay_joints,
                    max_travel, yes, start, end):
    """Write a URScript program (.script) that moves through the stored poses (all, or NAMES in order).

    Joint targets are planned as `run-poses` plans them (IK nearest the recorded joints), on the nominal model.
    The program is `def ur3dq_poses(): ... end`: send it to the controller (port 30002) or load it on the
    pendant. Pose names appear only in comments. The first move starts from wherever the arm is: check it.

    \b
    Examples:
      ur3dq export-urscript -o cell.script
      ur3dq export-urscript pick place --speed 0.5 --blend 0.01 --loop 10 \\
          -o cell.script
    """
    check_blend(blend)
    if start or end or settings.store.version() == 2:  # a cell program: the same program run-poses sends
        if names or loops > 1:
            raise click.UsageError("a cell program is exported as a whole or --from/--to: no NAMES, no --loop")
        program, count = export_program_text(
            settings, start, end, angular_option(speed, DEFAULT_SPEED, settings.deg),
            angular_option(acceleration, DEFAULT_ACCELERATION, settings.deg), blend, 1.0, replay_joints,
            check_max_travel(angular_option(max_travel, DEFAULT_MAX_JOINT_TRAVEL, settings.deg)))
        _write_program(output, program, yes, count_text(count, "step"))
        return
    model, steps, a, v = offline_plan(settings, names, angular_option(speed, DEFAULT_SPEED, settings.deg),
                                      angular_option(acceleration, DEFAULT_ACCELERATION, settings.deg),
                                      replay_joints, check_max_travel(angular_option(max_travel, DEFAULT_MAX_JOINT_TRAVEL,
                                                                                     settings.deg)))
    offsets = {step.pose.tcp_offset for step in steps}
    header = [
        f"ur3dq export-urscript: {count_text(len(steps), 'pose')} from {settings.store_path} for a {model.name}",
        f"generated {utc_now_iso()}",
        describe_speeds(a, v, blend),
        "the first move starts wherever the arm is: check it at low speed first",
    ]
    program = replay_script(steps, a, v, blend, loops, tcp_offset=offsets.pop() if len(offsets) == 1 else None,
                            header=header)
    _write_program(output, program, yes, count_text(len(steps), 'pose') + (f" × {loops}" if loops > 1 else ""))


def _write_program(output: Path, program: str, yes: bool, what: str) -> None:
    """The program on stdout (`-`) or into `output` (asking before overwriting), atomically."""
    if str(output) == "-":
        click.echo(program, nl=False)
        return
    _writable_target(output, yes)
    write_atomically(output, program)
    click.echo(f"Wrote {output}: {what}.")


@cli.command()
@click.argument("names", nargs=-1)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=Path("poses.png"),
              show_default=True, help="The PNG to write.")
@click.option("--yes", "-y", is_flag=True, help="Overwrite the output file without asking.")
@global_options
@cell_option
@click.pass_obj
def plot(settings: Settings, names, output: Path, yes, cell_path):
    """A PNG of the recorded TCP path and the arm at each pose (all, or NAMES in order), on the nominal model.

    \b
    Examples:
      ur3dq plot -o path.png
      ur3dq plot pick place -o two.png --yes
    """
    from ur3dq.plot import plot_poses

    model, steps, _, _ = offline_plan(settings, names, DEFAULT_SPEED, DEFAULT_ACCELERATION, False,
                                      float("inf"))
    _writable_target(output, yes)
    check = None
    if settings.store.version() == PROGRAM_SCHEMA_VERSION and not names:  # the program's own moves are checked
        check, cell = check_program(model, plan_program(model, settings.store.load_program()), cell_path)
    if check is None:
        check, cell = check_replay(model, steps, cell_path)
    plot_poses(output, model, steps, title=f"{count_text(len(steps), 'pose')} from {settings.store_path.name} on a "
               f"{model.name}", path_check=check, cell=cell)
    click.echo(f"Wrote {output}. Path check: {check.summary()}")
