#!/usr/bin/env python3
"""Count, per module group, the share of functions that are fully annotated.

A function (a method, a nested function) is fully annotated when every parameter has an annotation (the first
parameter of a method, ``self`` or ``cls``, excepted) and it declares its return type; ``__init__`` may leave the
return out when a parameter is annotated, as mypy allows. Lambdas are not counted. The groups are the public API
modules that ``mypy --strict`` is meant to cover, then the rest of ``ur3dq``, ``sim_ursim`` and ``polyscope_format``.

Not part of the test suite (mypy enforces the strict modules). Usage::

    scripts/annotation_coverage.py            # the table
    scripts/annotation_coverage.py --files    # and every file below 100 %

Exit status: 0.
"""
from __future__ import annotations

import argparse
import ast
from dataclasses import dataclass
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
#: The public API modules, each a module or a package of ur3dq: the ones mypy --strict is to cover.
PUBLIC = ("dualquat", "dqarray", "pose", "store", "kinematics", "robot", "pathcheck", "program")


@dataclass
class Count:
    """Functions seen and how many of them are fully annotated."""

    functions: int = 0
    annotated: int = 0

    def add(self, other: Count) -> None:
        """Add another Count to this one."""
        self.functions += other.functions
        self.annotated += other.annotated

    def share(self) -> str:
        """The annotated share as text, e.g. " 93.5 %" ("-" without functions)."""
        return f"{100 * self.annotated / self.functions:5.1f} %" if self.functions else "    - "


def _is_annotated(node: ast.FunctionDef | ast.AsyncFunctionDef, method: bool) -> bool:
    arguments = node.args
    positional = [*arguments.posonlyargs, *arguments.args]
    is_static = any(isinstance(d, ast.Name) and d.id == "staticmethod" for d in node.decorator_list)
    if method and positional and not is_static:
        positional = positional[1:]   # self / cls
    parameters = [*positional, *arguments.kwonlyargs,
                  *(a for a in (arguments.vararg, arguments.kwarg) if a is not None)]
    if any(parameter.annotation is None for parameter in parameters):
        return False
    return node.returns is not None or (node.name == "__init__" and bool(parameters))


def count_source(source: str) -> Count:
    """The Count of one module's source text."""
    count = Count()

    def visit(node: ast.AST, in_class: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                count.functions += 1
                count.annotated += _is_annotated(child, in_class)
                visit(child, False)
            elif isinstance(child, ast.ClassDef):
                visit(child, True)
            else:
                visit(child, in_class)

    visit(ast.parse(source), False)
    return count


def group_of(path: Path) -> str:
    """The group a file of the repository belongs to: a public API module's name, or "other ur3dq", "sim_ursim",
    "polyscope_format"."""
    parts = path.relative_to(REPOSITORY).with_suffix("").parts
    if parts[0] == "ur3dq" and len(parts) > 1 and parts[1] in PUBLIC:
        return parts[1]
    if parts[0] == "ur3dq" and len(parts) > 1 and parts[1] == "cli":
        return "cli"
    return "other ur3dq" if parts[0] == "ur3dq" else parts[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--files", action="store_true", help="also list every file below 100 %%")
    arguments = parser.parse_args()
    groups: dict[str, Count] = {name: Count() for name in (*PUBLIC, "cli", "other ur3dq", "sim_ursim",
                                                           "polyscope_format")}
    files: list[tuple[Path, Count]] = []
    for path in sorted(path for package in ("ur3dq", "sim_ursim", "polyscope_format")
                       for path in (REPOSITORY / package).rglob("*.py")):
        count = count_source(path.read_text(encoding="utf-8"))
        groups[group_of(path)].add(count)
        files.append((path, count))
    public = Count()
    for name in PUBLIC:
        public.add(groups[name])
    print(f"{'group':<16} {'functions':>9} {'annotated':>9} {'share':>7}")
    for name, count in [*groups.items(), ("public API", public)]:
        print(f"{name:<16} {count.functions:>9} {count.annotated:>9} {count.share():>7}")
    if arguments.files:
        print()
        for path, count in files:
            if count.annotated < count.functions:
                print(f"{str(path.relative_to(REPOSITORY)):<50} {count.annotated:>4}/{count.functions:<4} "
                      f"{count.share()}")


if __name__ == "__main__":
    main()
