"""`ur3dq plot`: a PNG of the recorded TCP path and the arm, with the path check."""
from __future__ import annotations

from pathlib import Path

import click

from ur3dq.cli.app import Settings, cli, prepare_output, report
from ur3dq.cli.display import count_text
from ur3dq.cli.offline_plans import offline_plan
from ur3dq.cli.options import DEFAULT_ACCELERATION, DEFAULT_SPEED, cell_option, display_options
from ur3dq.cli.path_report import check_program, check_replay, kept_script_warnings
from ur3dq.program.plan import plan_program
from ur3dq.store_format import PROGRAM_SCHEMA_VERSION


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

    \b
    Examples:
      ur3dq plot -o path.png
      ur3dq plot pick place -o two.png --yes
    """
    from ur3dq.plot import plot_poses

    model, steps, _, _ = offline_plan(settings, names, DEFAULT_SPEED, DEFAULT_ACCELERATION, False,
                                      float("inf"))
    prepare_output(settings, output, yes)
    check = None
    if settings.store.version() == PROGRAM_SCHEMA_VERSION and not names:  # the program's own moves are checked
        plan = plan_program(model, settings.store.load_program())
        for line in kept_script_warnings(plan):
            click.echo(f"Warning: {line}", err=True)
        check, cell = check_program(model, plan, cell_path)
    if check is None:
        check, cell = check_replay(model, steps, cell_path)
    plot_poses(output, model, steps, title=f"{count_text(len(steps), 'pose')} from {settings.store_path.name} on a "
               f"{model.name}", path_check=check, cell=cell)
    report(settings, {"file": str(output), "path_check": check.to_dict()},
           f"Wrote {output}. Path check: {check.summary(settings.units)}")
