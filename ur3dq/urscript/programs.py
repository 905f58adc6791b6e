"""The URScript program skeleton: ``def name(): ... end``, header comments, loops, a statement put first."""
from __future__ import annotations

from collections.abc import Iterable

from ur3dq.urscript.statements import movej_statement
from ur3dq.urscript.text import check_identifier, comment_text

INDENT = "  "


def program(name: str, statements: Iterable[str], header: Iterable[str] = ()) -> str:
    """A complete program: `header` lines as ``#`` comments, then ``def name():``, one statement a line, ``end``.

    Parameters
    ----------
    name : str
        The program's identifier (ur3dq.urscript.new_program_name gives fresh ones).
    statements : iterable of str
        Single lines, unindented (a block's inner lines carry their own extra indentation).
    header : iterable of str
        Free text, written as comments above the program (escaped by comment_text).

    Raises
    ------
    ValueError
        `name` is not an identifier, there is no statement, or a statement spans lines.

    Examples
    --------
    >>> print(program("p", ["stopj(2.0)"], header=["stop now"]), end="")
    # stop now
    def p():
      stopj(2.0)
    end
    """
    check_identifier(name)
    lines = list(statements)
    if not lines:
        raise ValueError("a program needs at least one statement")
    for line in lines:
        if not isinstance(line, str) or "\n" in line or "\r" in line:
            raise ValueError(f"statement {line!r} must be a single line of text")
    comments = "".join(f"# {comment_text(line)}\n" for line in header)
    return comments + f"def {name}():\n" + "".join(f"{INDENT}{line}\n" for line in lines) + "end\n"


def repeat(count: int, statements: Iterable[str], counter: str = "ur3dq_loop") -> list[str]:
    """`statements` as a block run `count` times (a ``while`` on the variable `counter`)."""
    if not (isinstance(count, int) and not isinstance(count, bool) and count >= 1):
        raise ValueError(f"loops must be a whole number ≥ 1, got {count!r}")
    check_identifier(counter)
    return [f"{counter} = 0", f"while {counter} < {count}:", *(f"{INDENT}{line}" for line in statements),
            f"{INDENT}{counter} = {counter} + 1", "end"]


def movej_program(name: str, targets: Iterable[Iterable[object]], a: float, v: float, blend: float = 0.0) -> str:
    """One program moving through joint `targets` in order.

    One program moving through joint `targets` in order; every target but the last blends with radius `blend`
    (the last move ends at rest)."""
    targets = list(targets)
    if not targets:
        raise ValueError("targets must hold at least one joint vector")
    last = len(targets) - 1
    return program(name, [movej_statement(q, a, v, blend if index < last else 0.0) for index, q in enumerate(targets)])


def first_statement_added(text: str, name: str, statement: str) -> str:
    """The program `text` (holding exactly one ``def name():``) with `statement` run before its others."""
    head = f"def {name}():\n"
    at = text.find(head)
    if at < 0 or text.count(head) != 1:
        raise ValueError(f"program {name!r}: expected exactly one line `def {name}():`")
    if "\n" in statement or "\r" in statement:
        raise ValueError(f"statement {statement!r} must be a single line of text")
    at += len(head)
    return text[:at] + f"{INDENT}{statement}\n" + text[at:]
