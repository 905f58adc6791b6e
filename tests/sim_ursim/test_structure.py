"""Structure of sim_ursim that the architecture promises (docs/architecture.md): checked on the source."""
import ast
import pathlib

import sim_ursim

PACKAGE = pathlib.Path(sim_ursim.__file__).parent
SOURCES = sorted(PACKAGE.rglob("*.py"))


def _calls(path, attribute):
    """Line numbers of calls `<something>.<attribute>(...)` in a source file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [node.lineno for node in ast.walk(tree)
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == attribute]


def test_exactly_one_module_listens_and_accepts():
    listening = {path.relative_to(PACKAGE).as_posix() for path in SOURCES
                 if _calls(path, "listen") or _calls(path, "accept")}
    assert listening == {"tcp_server.py"}


def test_no_module_is_over_700_lines():
    long = {path.relative_to(PACKAGE).as_posix(): n for path in SOURCES
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > 700}
    assert long == {}


def test_sim_ursim_never_imports_ur3dq():
    for path in SOURCES:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                assert not any(alias.name.split(".")[0] == "ur3dq" for alias in node.names), path
            elif isinstance(node, ast.ImportFrom) and node.module:
                assert node.module.split(".")[0] != "ur3dq", path


def test_servers_and_interpreter_take_the_vocabulary_not_the_controller():
    for relative in ("dashboard/protocol.py", "primary/server.py", "control_channel.py", "urscript/interpreter.py",
                     "urscript/runtime.py", "urscript/builtins/arguments.py"):
        tree = ast.parse((PACKAGE / relative).read_text(encoding="utf-8"))
        imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module}
        assert not any(module.endswith("controller") for module in imported), relative
