"""The CLI's layout rule (docs/architecture.md): a command module never imports another command module; what
several commands share lives in app.py, options.py, display.py, path_report.py or program_workflow.py."""
import ast
import os
import subprocess
import sys
from pathlib import Path

import ur3dq.cli

CLI = Path(ur3dq.cli.__file__).parent


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


def test_no_command_module_imports_another():
    commands = sorted(CLI.glob("commands_*.py"))
    assert len(commands) >= 8
    offenders = {path.name: sorted(name for name in imported_modules(path) if name.startswith("ur3dq.cli.commands_"))
                 for path in commands}
    assert {name: found for name, found in offenders.items() if found} == {}


def test_shared_cli_modules_import_no_command_module():
    shared = [path for path in CLI.glob("*.py") if not path.name.startswith("commands_") and path.name != "__init__.py"]
    offenders = {path.name: sorted(name for name in imported_modules(path) if name.startswith("ur3dq.cli.commands_"))
                 for path in shared}
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
