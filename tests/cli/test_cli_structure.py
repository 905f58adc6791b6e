"""The CLI's layout rules (docs/architecture.md): `ur3dq X ...` lives in cli/X.py (dashes as underscores), every
subcommand of a group in its group's module; a command module never imports another; what several commands share
lives in the shared modules (app.py, options.py, display.py, ...), which import no command module."""
import ast
import os
import subprocess
import sys
from pathlib import Path

import click

import ur3dq.cli
from ur3dq.cli import cli

CLI = Path(ur3dq.cli.__file__).parent


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


def callbacks(command: click.Command):
    """The functions behind `command` and, for a group, every command under it."""
    yield command.callback
    for sub in getattr(command, "commands", {}).values():
        yield from callbacks(sub)


COMMAND_MODULES = {f"ur3dq.cli.{name.replace('-', '_')}" for name in cli.commands}


def test_each_command_lives_in_the_module_its_name_gives():
    misplaced = {name: sorted({f.__module__ for f in callbacks(command)} - {f"ur3dq.cli.{name.replace('-', '_')}"})
                 for name, command in cli.commands.items()}
    assert {name: modules for name, modules in misplaced.items() if modules} == {}
    assert {"ur3dq.cli.robot", "ur3dq.cli.poses", "ur3dq.cli.sim", "ur3dq.cli.demo", "ur3dq.cli.run_poses"} <= \
        COMMAND_MODULES


def test_no_command_module_imports_another():
    offenders = {module: sorted((imported_modules(CLI / f"{module.rsplit('.', 1)[1]}.py") & COMMAND_MODULES) - {module})
                 for module in COMMAND_MODULES}
    assert {name: found for name, found in offenders.items() if found} == {}


def test_shared_cli_modules_import_no_command_module():
    shared = [path for path in CLI.glob("*.py") if f"ur3dq.cli.{path.stem}" not in COMMAND_MODULES
              and path.name not in ("__init__.py", "__main__.py")]
    assert {path.name for path in shared} >= {"app.py", "options.py", "display.py"}
    offenders = {path.name: sorted(imported_modules(path) & COMMAND_MODULES) for path in shared}
    assert {name: found for name, found in offenders.items() if found} == {}


def _python(code: str, **env) -> str:
    blas = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    clean = {key: value for key, value in os.environ.items() if key not in blas}
    done = subprocess.run([sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
                          timeout=60, check=True)
    return done.stdout.strip()


def test_the_command_line_runs_numpy_on_one_blas_thread():
    # The package imports no numpy, so the CLI can set the thread count first: numpy's OpenBLAS then starts no
    # spinning worker thread (this process's only thread is the main one).
    assert _python("import sys, ur3dq; print('numpy' in sys.modules)") == "False"
    code = "import os, ur3dq.cli; print(os.environ['OPENBLAS_NUM_THREADS'], len(os.listdir('/proc/self/task')))"
    assert _python(code) == "1 1"
    assert _python(code, OPENBLAS_NUM_THREADS="2").split()[0] == "2"   # the user's own setting is kept
    if (os.cpu_count() or 1) > 1:   # the control: numpy alone starts its BLAS threads here
        assert int(_python("import os, numpy; print(len(os.listdir('/proc/self/task')))")) > 1


def test_a_command_that_only_reads_never_imports_the_lock_library():
    # filelock (~20 ms of a command's start) is imported by the first write or simulator start, not with the CLI
    assert _python("import sys, ur3dq.cli; print('filelock' in sys.modules)") == "False"


def test_every_command_module_is_named_in_the_lazy_registry():
    # A command line imports only the module of the command it names: a module that registers a command on `cli`
    # but is missing from ur3dq.cli.COMMANDS would never be imported, and its command would silently vanish.
    import re

    from ur3dq.cli import COMMANDS

    registering = {path.stem for path in CLI.glob("*.py")
                   if re.search(r"^@cli\.(command|group)", path.read_text(encoding="utf-8"), re.MULTILINE)}
    assert registering == {name.replace("-", "_") for name in COMMANDS}
