"""`ur3dq plot`: a PNG of the recorded TCP path and the arm, with the path check."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from ur3dq.cli.app import Settings, cli, prepare_output, report, solving_poses
from ur3dq.cli.display import count_text
from ur3dq.cli.offline_plans import offline_plan
from ur3dq.cli.options import DEFAULT_ACCELERATION, DEFAULT_SPEED, cell_option, display_options
from ur3dq.cli.path_report import check_program, check_replay
from ur3dq.cli.plan_warnings import plan_warnings
from ur3dq.cli.program_workflow import program_model
from ur3dq.errors import StoreError
from ur3dq.program.plan import PlannedStep, plan_program
from ur3dq.program.steps import Waypoint
from ur3dq.store_format import PROGRAM_SCHEMA_VERSION

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel


@cli.command(short_help="A PNG of the path, the arm and the check.")
@click.argument("names", nargs=-1)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=Path("poses.png"),
              show_default=True, help="The PNG to write.")
@click.option("--yes", "-y", is_flag=True, help="Overwrite the output file without asking.")
@display_options
@cell_option
@click.pass_obj
def plot(settings: Settings, names: tuple[str, ...], output: Path, yes: bool, cell_path: Path | None) -> None:
    """A PNG of the recorded TCP path and the arm at each pose (all, or NAMES in order), on the nominal model.

    A cell program (a version-2 store, no NAMES) is drawn and checked as run-poses plans it: the arm at each of its
    waypoints, relative ones included, in the joints the program moves to.

    \b
    Examples:
      ur3dq plot -o path.png
      ur3dq plot pick place -o two.png --yes
    """
    from ur3dq.plot import ArmAt, plot_poses

    if settings.store.version() == PROGRAM_SCHEMA_VERSION and not names:  # the program's own moves
        model, plan = _planned_program(settings)
        prepare_output(settings, output, yes)
        check, cell = check_program(model, plan, cell_path)
        assert check is not None, "a plan with a waypoint moves"
        arms = [ArmAt(p.name, p.joints, p.tcp_offset or (0.0,) * 6) for p in plan if p.joints is not None]
        drawn = f"{count_text(len(arms), 'waypoint')} of the cell program in {settings.store_path.name}"
    else:
        model, steps, _, _ = offline_plan(settings, names, DEFAULT_SPEED, DEFAULT_ACCELERATION, False,
                                          float("inf"))
        prepare_output(settings, output, yes)
        check, cell = check_replay(model, steps, cell_path)
        arms = [ArmAt(step.pose.name, step.joints, step.pose.tcp_offset) for step in steps]
        drawn = f"{count_text(len(arms), 'pose')} from {settings.store_path.name}"
    plot_poses(output, model, arms, title=f"{drawn} on a {model.name}", path_check=check, cell=cell)
    report(settings, {"file": str(output), "path_check": check.to_dict(),
                      "arms": [{"name": arm.name, "joints": arm.joints.tolist()} for arm in arms]},
           f"Wrote {output}. Path check: {check.summary(settings.units)}")


def _planned_program(settings: Settings) -> tuple[URModel, list[PlannedStep]]:
    """(nominal model, plan) of the store's cell program, without a robot, its warnings on stderr."""
    program = settings.store.load_program()
    if not any(isinstance(step, Waypoint) for step in program):
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    model = program_model(settings, program)
    solving_poses(len(program), model)   # every step, relative waypoints included, as run-poses counts them
    plan = plan_program(model, program)
    for line in plan_warnings(plan, settings.units):
        click.echo(f"Warning: {line}", err=True)
    return model, plan
