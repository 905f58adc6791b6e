"""The CLI's layout rule (docs/architecture.md): a command module never imports another command module; what
several commands share lives in app.py, options.py, display.py, path_report.py or program_workflow.py."""
import ast
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
