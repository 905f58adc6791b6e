"""URScript generation: one pure function per statement, every number lossless, no user text unescaped.

Numbers are written in positional notation with the shortest digits that read back to the same float, so
what the controller executes is exactly what was checked (no rounding as urx's 6-decimal format does, and no
exponent notation, which not every URScript parser accepts). Program names are generated identifiers; free text
(messages, pose names) is reduced to a safe character set because URScript string literals have no escape
syntax a driver can rely on.
"""
import itertools
import math
import re

import numpy as np

from ur3dq.real_numbers import is_number

_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,62}$")
_SAFE_TEXT_CHARACTERS = frozenset(chr(code) for code in range(0x20, 0x7F)) - {'"', "\\"}
_program_counter = itertools.count(1)


def format_number(value, name="value"):
    """A finite real as URScript text: positional, shortest digits that parse back to exactly `value`."""
    if not is_number(value):   # float() would read "1.5" and True
        raise ValueError(f"{name} must be a real number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {number!r}")
    return np.format_float_positional(number, unique=True, trim="0")


def format_vector(values, length=6, name="vector"):
    """A list of `length` finite reals as URScript `[a, b, ...]` (joint vector), lossless."""
    items = _finite_items(values, length, name)
    return "[" + ", ".join(format_number(item, f"{name}[{index}]") for index, item in enumerate(items)) + "]"


def format_pose(pose, name="pose"):
    """A UR pose vector [x, y, z, rx, ry, rz] (metres, rotation vector) as URScript `p[...]`, lossless."""
    return "p" + format_vector(pose, 6, name)


def sanitise_text(text, name="text", max_length=255):
    """A URScript string literal (with quotes) of `text`: characters outside printable ASCII, `"` and `\\` become `?`."""
    if not isinstance(text, str):
        raise ValueError(f"{name} must be a string, got {type(text).__name__}")
    if len(text) > max_length:
        raise ValueError(f"{name} is {len(text)} characters long; at most {max_length} reach the controller")
    return '"' + "".join(char if char in _SAFE_TEXT_CHARACTERS else "?" for char in text) + '"'


def check_identifier(name):
    """`name` unchanged if it is a URScript identifier (letter or _, then letters, digits, _; ≤ 63), else ValueError."""
    if not isinstance(name, str) or not _IDENTIFIER.match(name):
        raise ValueError(f"program name {name!r} is not a URScript identifier ([A-Za-z_][A-Za-z0-9_]*, ≤ 63 chars)")
    return name


def new_program_name(purpose):
    """A fresh identifier `ur3dq_<purpose>_<n>` (n counts up per process) so each sent program can be recognised."""
    return check_identifier(f"ur3dq_{purpose}_{next(_program_counter)}")


def movej_statement(q, a, v, r=0.0):
    """`movej([q], a=, v=, r=)`: joint-space move; a rad/s², v rad/s (leading axis), r blend radius in metres."""
    return (
        f"movej({format_vector(q, 6, 'q')}, a={format_number(a, 'a')}, "
        f"v={format_number(v, 'v')}, r={format_number(r, 'r')})"
    )


def stopj_statement(a):
    """`stopj(a)`: decelerate every joint to rest at a rad/s²."""
    return f"stopj({format_number(a, 'a')})"


def set_tcp_statement(pose):
    """`set_tcp(p[...])`: the TCP offset as a UR pose vector in the flange frame (metres, rotation vector)."""
    return f"set_tcp({format_pose(pose, 'tcp')})"


def textmsg_statement(text):
    """`textmsg("...")`: a message to the controller log, text sanitised."""
    return f"textmsg({sanitise_text(text)})"


def freedrive_statements(seconds):
    """Statements that hold freedrive (hand guiding) for `seconds`: `freedrive_mode()`, `sleep(s)`, `end_freedrive_mode()`."""
    return ["freedrive_mode()", f"sleep({format_number(seconds, 'seconds')})", "end_freedrive_mode()"]


def end_freedrive_statements():
    """Statements that leave freedrive: `end_freedrive_mode()` (a new program also aborts the holding one)."""
    return ["end_freedrive_mode()"]


def program(name, statements):
    """A complete program `def name():` … `end` with one statement per line and a final newline."""
    check_identifier(name)
    lines = list(statements)
    if not lines:
        raise ValueError("a program needs at least one statement")
    for line in lines:
        if not isinstance(line, str) or "\n" in line or "\r" in line:
            raise ValueError(f"statement {line!r} must be a single line of text")
    return f"def {name}():\n" + "".join(f"  {line}\n" for line in lines) + "end\n"


def movej_program(name, targets, a, v, blend=0.0):
    """One program moving through joint `targets` in order; every target but the last blends with radius `blend`."""
    targets = list(targets)
    if not targets:
        raise ValueError("targets must hold at least one joint vector")
    statements = [
        movej_statement(q, a, v, blend if index < len(targets) - 1 else 0.0) for index, q in enumerate(targets)
    ]
    return program(name, statements)


def _finite_items(values, length, name):
    """The items of `values` as floats, checked: exactly `length` of them, all finite."""
    try:
        items = [float(item) for item in values]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a sequence of {length} real numbers, got {values!r}") from None
    if len(items) != length:
        raise ValueError(f"{name} must have {length} values, got {len(items)}")
    for index, item in enumerate(items):
        if not math.isfinite(item):
            raise ValueError(f"{name}[{index}] must be finite, got {item!r}")
    return items
