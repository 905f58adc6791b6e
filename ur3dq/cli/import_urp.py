"""`ur3dq import-urp`: a PolyScope program (.urp) read into the store as its cell program."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ur3dq.cli.app import Settings, cli, report, robot_session
from ur3dq.cli.background_simulator import running_simulator_host
from ur3dq.cli.display import count_text
from ur3dq.cli.options import display_options
from ur3dq.errors import RobotError, StoreError
from ur3dq.kinematics import robot_model
from ur3dq.kinematics.models import URModel
from ur3dq.polyscope.kinematics import largest_tcp_difference
from ur3dq.polyscope.urp_file import installation_pin_aliases, read_urp
from ur3dq.polyscope.urp_import import Imported, import_program
from ur3dq.program.steps import Step
from ur3dq.units import LENGTH, Units, show


@cli.command("import-urp", short_help="Read a PolyScope program (.urp) into the store.")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--append", is_flag=True, help="Add the program after the steps already stored.")
@click.option("--keep-script", is_flag=True,
              help="Keep nodes without a ur3dq step (If, Loop, Script, ...) as URScript, not path-checked.")
@display_options
@click.pass_obj
def import_urp(settings: Settings, file: Path, append: bool, keep_script: bool) -> None:
    """Read the PolyScope program FILE into the store as its cell program (into an empty store, or after its
    steps with --append), to check, plot, run and edit it as any other.

    Waypoints come with their recorded joints and TCP offset, move type, speed, acceleration and blend; relative
    waypoints, outputs, waits, message popups and comments come as steps; folders are flattened, their names
    kept as comment steps. A node without a ur3dq step (If, Loop, Script, Thread, variables, URCap nodes, ...)
    is refused by its place in the program tree, or kept with --keep-script as the URScript PolyScope would run
    (marked, and left out of the path check). The program's kinematics are compared with the connected arm's
    (--host, or `ur3dq sim start`'s simulator), else with the model's. Nothing is written unless the whole
    program imports. docs/polyscope.md lists what maps to what.

    \b
    Examples:
      ur3dq import-urp cell.urp
      ur3dq --store new.json import-urp old_cell.urp --keep-script
      ur3dq import-urp second_part.urp --append
    """
    tree = read_urp(file)
    aliases = installation_pin_aliases(tree, file)

    def edit(steps: list[Step]) -> tuple[list[Step], Imported]:
        if steps and not append:
            raise StoreError(f"{settings.store_path} already holds {count_text(len(steps), 'step')}: add the "
                             "program after them with --append, or import into another --store")
        imported = import_program(tree, settings.model, keep_script, [step.name for step in steps], aliases)
        return steps + imported.steps, imported

    imported = settings.store.update_program(edit)
    comparison, facts = compare_kinematics(settings, file, imported)
    for line in [*imported.warnings, comparison]:
        click.echo(f"Warning: {line}" if line is not comparison else line, err=True)
    names = [step.name for step in imported.steps]
    report(settings, {"imported": names, "store": str(settings.store_path), "kept": imported.kept,
                      "warnings": imported.warnings, "kinematics": facts},
           f"Imported {count_text(len(names), 'step')} from {file} into {settings.store_path}"
           + (f" ({len(imported.kept)} kept as URScript)." if imported.kept else "."))


def compare_kinematics(settings: Settings, file: Path, imported: Imported) -> tuple[str, dict[str, Any]]:
    """One line comparing the program's kinematics with the connected arm's (when one is configured and
    answers) or the model's, and the facts for --json."""
    saved_on = imported.model
    other, against = _comparison_model(settings, saved_on)
    facts: dict[str, Any] = {"saved_on": saved_on.name, "calibrated": saved_on.calibrated,
                             "compared_with": against, "model": other.name, "largest_tcp_difference": None}
    what = f"{file.name} was saved on a {saved_on.name.upper()}"
    if other.name != saved_on.name:
        return (f"{what}; the {against} is a {other.name.upper()}: ur3dq moves its TCP to the recorded poses by "
                f"IK on the {other.name.upper()} (check reach with `ur3dq check`)"), facts
    difference = largest_tcp_difference(saved_on, other, imported.joints, imported.tcp_offsets)
    facts["largest_tcp_difference"] = difference
    mm = Units(length="mm")
    if difference <= 1e-6:
        return f"{what} with the same kinematics as the {against}", facts
    return (f"{what} with other kinematics than the {against}: at the recorded joint angles the TCP would be up to "
            f"{show(difference, LENGTH, mm, 2)} apart; ur3dq moves the TCP to the recorded poses (IK on the "
            f"{against}), so the joints differ slightly from the file's"), facts


def _comparison_model(settings: Settings, saved_on: URModel) -> tuple[URModel, str]:
    """The connected arm's model (calibrated) when a robot is configured and answers, else the catalogue model
    of --model or of the program; and how to call it in the message."""
    if settings.host or running_simulator_host():
        try:
            with robot_session(settings) as robot:
                return robot.model, f"connected {robot.model.name.upper()}"
        except (RobotError, OSError) as error:
            click.echo(f"Warning: no robot to compare the kinematics with ({error}); compared with the model's",
                       err=True)
    name = settings.model or saved_on.name
    return robot_model(name), f"nominal {name.upper()} model"
