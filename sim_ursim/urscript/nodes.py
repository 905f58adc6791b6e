"""URScript syntax tree: plain immutable nodes, each carrying the 1-based line and column where it starts."""
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Node:
    """Base of every node: source position (1-based line, 1-based column)."""

    line: int = field(kw_only=True, default=0)
    column: int = field(kw_only=True, default=0)


# --- expressions -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Literal(Node):
    """A number (int or float), string or boolean."""

    value: object


@dataclass(frozen=True)
class Name(Node):
    """A variable read."""

    name: str


@dataclass(frozen=True)
class ListExpr(Node):
    """`[a, b, ...]` (also the tuple form `(a, b)` that urx sends)."""

    items: tuple


@dataclass(frozen=True)
class PoseExpr(Node):
    """`p[x, y, z, rx, ry, rz]`: a pose literal (metres, rotation vector in radians)."""

    items: tuple


@dataclass(frozen=True)
class Index(Node):
    """`target[index]` on a list, pose or string."""

    target: Node
    index: Node


@dataclass(frozen=True)
class MatrixIndex(Node):
    """`matrix[row, column]` on a list of lists (PolyScope 5 matrices)."""

    target: Node
    row_index: Node
    column_index: Node


@dataclass(frozen=True)
class Unary(Node):
    """`-x`, `+x`, `not x`."""

    op: str
    operand: Node


@dataclass(frozen=True)
class Binary(Node):
    """`left op right` with op one of or xor and == != < <= > >= + - * / %."""

    op: str
    left: Node
    right: Node


@dataclass(frozen=True)
class Call(Node):
    """`name(args, key=value)`: a built-in or script function call."""

    name: str
    args: tuple
    kwargs: tuple  # ((name, expr), ...) in source order


@dataclass(frozen=True)
class Run(Node):
    """`run thread_name()`: starts a thread, evaluates to its handle."""

    thread: str


# --- statements --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExprStatement(Node):
    """An expression evaluated for its effect (usually a call)."""

    expr: Node


@dataclass(frozen=True)
class Assign(Node):
    """`name = value` or `name[i]...[j] = value` (indices empty for a plain name)."""

    name: str
    indices: tuple
    value: Node


@dataclass(frozen=True)
class GlobalDecl(Node):
    """`global name = value`."""

    name: str
    value: Node


@dataclass(frozen=True)
class LocalDecl(Node):
    """`local name = value`."""

    name: str
    value: Node


@dataclass(frozen=True)
class If(Node):
    """`if c: ... elif c: ... else: ... end` as (condition, body) branches plus an optional else body."""

    branches: tuple  # ((condition, body), ...)
    orelse: tuple | None


@dataclass(frozen=True)
class While(Node):
    """`while condition: body end`."""

    condition: Node
    body: tuple


@dataclass(frozen=True)
class Return(Node):
    """`return [value]`."""

    value: Node | None


@dataclass(frozen=True)
class Halt(Node):
    """`halt`: ends the program."""


@dataclass(frozen=True)
class Break(Node):
    """`break`."""


@dataclass(frozen=True)
class Continue(Node):
    """`continue`."""


@dataclass(frozen=True)
class Kill(Node):
    """`kill handle_variable`."""

    handle: str


@dataclass(frozen=True)
class Join(Node):
    """`join handle_variable`."""

    handle: str


@dataclass(frozen=True)
class EnterCritical(Node):
    """`enter_critical`: no other script thread runs until `exit_critical`."""


@dataclass(frozen=True)
class ExitCritical(Node):
    """`exit_critical`."""


@dataclass(frozen=True)
class Param(Node):
    """A function parameter with an optional default value."""

    name: str
    default: Node | None


@dataclass(frozen=True)
class FunctionDef(Node):
    """`def name(params): body end` (a program when it is the whole script)."""

    name: str
    params: tuple
    body: tuple


@dataclass(frozen=True)
class ThreadDef(Node):
    """`thread name(): body end`."""

    name: str
    body: tuple


@dataclass(frozen=True)
class SecDef(Node):
    """`sec name(): body end`: a secondary program."""

    name: str
    body: tuple


@dataclass(frozen=True)
class Script(Node):
    """Everything one client sent: its top-level statements in order."""

    body: tuple
