"""The layering docs/architecture.md promises, checked on the source: no import cycle between ur3dq's packages or
modules (imports inside functions count), no module over 700 lines, and the PolyScope file format package
(polyscope_format, shared by ur3dq and sim_ursim) imports neither of them."""
from __future__ import annotations

import ast
from pathlib import Path

import polyscope_format
import ur3dq

ROOT = Path(ur3dq.__file__).parent
SOURCES = sorted(ROOT.rglob("*.py"))
FORMAT_SOURCES = sorted(Path(polyscope_format.__file__).parent.rglob("*.py"))


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(path): path for path in SOURCES}


def imported_modules(path: Path) -> set[str]:
    return imports_of(path.read_text(encoding="utf-8"), module_name(path), path.name == "__init__.py")


def imports_of(source: str, name: str, is_package: bool) -> set[str]:
    """The ur3dq modules module `name` imports anywhere in `source` (a function's deferred import included)."""
    package = name.split(".") if is_package else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = ".".join(package[:len(package) - node.level + 1] + [node.module or ""]).strip(".") \
                if node.level else node.module or ""
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base for alias in node.names]
        else:
            continue
        for target in targets:
            while target not in MODULES and "." in target:
                target = target.rsplit(".", 1)[0]
            if target in MODULES and target != name:
                found.add(target)
    return found


def package_of(module: str) -> str:
    """`ur3dq.robot.robot` -> `ur3dq.robot`; a top-level module is its own package (`ur3dq.store`)."""
    return ".".join(module.split(".")[:2])


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one node (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in edges.get(node, ()):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(edges):
        if node not in index:
            visit(node)
    return found


MODULE_EDGES = {name: imported_modules(path) for name, path in MODULES.items()}


def test_no_import_cycle_between_packages():
    edges: dict[str, set[str]] = {}
    for module, targets in MODULE_EDGES.items():
        edges.setdefault(package_of(module), set()).update(
            package_of(target) for target in targets if package_of(target) != package_of(module))
    assert cycles(edges) == []


def test_no_import_cycle_between_modules():
    assert cycles(MODULE_EDGES) == []


def test_the_cycle_finder_finds_a_deferred_import_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    deferred = "def f():\n    from ur3dq.program.runner import run\n    from . import heartbeat\n"
    assert imports_of(deferred, "ur3dq.robot.robot", False) == {"ur3dq.program.runner", "ur3dq.robot.heartbeat"}


def test_the_driver_knows_no_cell_program():
    driver = {target for module, targets in MODULE_EDGES.items() if package_of(module) == "ur3dq.robot"
              for target in targets}
    assert not any(package_of(target) == "ur3dq.program" for target in driver)


def project_files() -> list[Path]:
    """Every Python file of the project: the packages, the simulator, the tests, the benchmarks and the scripts."""
    project = ROOT.parent
    return [path for folder in ("ur3dq", "polyscope_format", "sim_ursim", "tests", "benchmarks", "scripts")
            for path in sorted((project / folder).rglob("*.py"))]


def test_no_module_is_over_700_lines():
    paths = project_files()
    assert len(paths) > len(SOURCES + FORMAT_SOURCES)
    long = {str(path.relative_to(ROOT.parent)): n for path in paths
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > 700}
    assert long == {}


def test_no_function_body_is_over_60_lines():
    """Counted from the first statement after the docstring: a numpydoc docstring with examples may be long."""
    long = {}
    for path in project_files():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                body = node.body[1:] if ast.get_docstring(node) and len(node.body) > 1 else node.body
                if (lines := node.end_lineno - body[0].lineno + 1) > 60:
                    long[f"{path.relative_to(ROOT.parent)}:{node.name}"] = lines
    assert long == {}


def top_level_imports(source: str) -> set[str]:
    """The top-level packages `source` imports anywhere (a function's deferred import included; relative imports
    stay inside the package and are left out)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module.split(".")[0])
    return found


def test_the_polyscope_format_package_imports_neither_ur3dq_nor_sim_ursim():
    found = {str(path.relative_to(ROOT.parent)): sorted(packages) for path in FORMAT_SOURCES
             if (packages := top_level_imports(path.read_text(encoding="utf-8")) & {"ur3dq", "sim_ursim"})}
    assert found == {}
    assert top_level_imports("def f():\n    from ur3dq.errors import StoreError\nimport sim_ursim.launch\n") == {
        "ur3dq", "sim_ursim"}


PROCESS_WIDE = {("gc", "disable"), ("gc", "freeze"), ("gc", "set_threshold")}


def process_wide_tricks(source: str) -> list[str]:
    """The calls in `source` that change the whole process or run generated code: gc.disable/freeze/set_threshold,
    exec(...), eval(...) (a method of that name, such as an interpreter's own `self.eval`, is not one)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        function = node.func
        if isinstance(function, ast.Name) and function.id in ("exec", "eval"):
            found.append(f"{function.id}(")
        elif (isinstance(function, ast.Attribute) and isinstance(function.value, ast.Name)
              and (function.value.id, function.attr) in PROCESS_WIDE):
            found.append(f"{function.value.id}.{function.attr}(")
    return found


def test_no_process_wide_tricks_in_library_code():
    import sim_ursim

    sources = SOURCES + FORMAT_SOURCES + sorted(Path(sim_ursim.__file__).parent.rglob("*.py"))
    found = {str(path.relative_to(ROOT.parent)): tricks for path in sources
             if (tricks := process_wide_tricks(path.read_text(encoding="utf-8")))}
    assert found == {}
    assert process_wide_tricks("import gc\ngc.freeze()\nexec('x = 1')\nself.eval(node)\n") == ["gc.freeze(", "exec("]
