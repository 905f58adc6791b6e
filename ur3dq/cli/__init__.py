"""The `ur3dq` command line (click): `cli`, whose commands are imported when a command line names them."""
import os

import click

# One BLAS thread, set before numpy is first imported (ur3dq's own package imports none). A command's matrices are
# small; OpenBLAS's extra threads only spin, taking CPU from the heartbeat and state threads of a driver on a small
# cell PC (docs/performance.md). A value the user set is kept.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from ur3dq.cli.app import cli, main  # noqa: E402  (after the thread count)

#: `ur3dq X` lives in cli/X.py (dashes as underscores); importing that module registers the command on `cli`, which
#: happens when a command line names it or a help page lists it.
COMMANDS = ("check", "demo", "export-urp", "export-urscript", "fk", "ik", "import-urp", "jog", "move-to", "plot",
            "poses", "record-pose", "robot", "run-poses", "serve", "sim", "status")
cli.command_modules.update({name: f"ur3dq.cli.{name.replace('-', '_')}" for name in COMMANDS})


def load_all_commands() -> dict[str, click.Command]:
    """Every command, its module imported: `cli.commands` is then complete (for tools that walk it)."""
    context = click.Context(cli)
    return {name: command for name in cli.list_commands(context) if (command := cli.get_command(context, name))}


__all__ = ["COMMANDS", "cli", "load_all_commands", "main"]
