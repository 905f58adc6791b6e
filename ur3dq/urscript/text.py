"""Values as URScript source text: lossless numbers, escaped literals, comments, identifiers.

Numbers are written in positional notation with the shortest digits that read back to the same float, so what the
controller executes is exactly what was checked (no rounding, as urx's 6-decimal format does, and no exponent
notation, which not every URScript parser accepts). Free text (messages, pose names) is reduced to a safe character
set, because URScript string literals have no escape syntax a driver can rely on.
"""
from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterable

import numpy as np

from ur3dq.real_numbers import is_number

COMMENT_MAX_LENGTH = 100
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,62}$")
_PRINTABLE_ASCII = frozenset(chr(code) for code in range(0x20, 0x7F))
_SAFE_TEXT_CHARACTERS = _PRINTABLE_ASCII - {'"', "\\"}
_program_counter = itertools.count(1)


def format_number(value: object, name: str = "value") -> str:
    """A finite real number as URScript text: positional, the shortest digits that parse back to `value`.

    Parameters
    ----------
    value : float or int
        The number; text such as ``"1.5"`` and bools are refused, although ``float()`` would read them.
    name : str
        What the number is, for the error message.

    Raises
    ------
    ValueError
        `value` is not a real number or not finite.

    Examples
    --------
    >>> format_number(2), format_number(1e-7), format_number(0.1 + 0.2)
    ('2.0', '0.0000001', '0.30000000000000004')
    """
    if not is_number(value):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    number = float(value)  # type: ignore[arg-type]  # is_number: a real number
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {number!r}")
    return str(np.format_float_positional(number, unique=True, trim="0"))


def format_vector(values: Iterable[object], length: int = 6, name: str = "vector") -> str:
    """`length` finite reals as a URScript list ``[a, b, ...]`` (a joint vector), lossless.

    Examples
    --------
    >>> format_vector([0, -1.5, 0, 0, 0, 3])
    '[0.0, -1.5, 0.0, 0.0, 0.0, 3.0]'
    """
    items = _finite_items(values, length, name)
    return "[" + ", ".join(format_number(item, f"{name}[{index}]") for index, item in enumerate(items)) + "]"


def format_pose(pose: Iterable[object], name: str = "pose") -> str:
    """A UR pose vector [x, y, z, rx, ry, rz] (metres, rotation vector) as URScript ``p[...]``, lossless."""
    return "p" + format_vector(pose, 6, name)


def sanitise_text(text: object, name: str = "text", max_length: int = 255) -> str:
    """A URScript string literal (quotes included) holding `text`.

    Characters outside printable ASCII, ``"`` and ``\\`` become ``?``: no user text can end the literal.

    Raises
    ------
    ValueError
        `text` is not a string or is longer than `max_length`.

    Examples
    --------
    >>> sanitise_text('a"); powerdown() #')
    '"a?); powerdown() #"'
    """
    if not isinstance(text, str):
        raise ValueError(f"{name} must be a string, got {type(text).__name__}")
    if len(text) > max_length:
        raise ValueError(f"{name} is {len(text)} characters long; at most {max_length} reach the controller")
    return '"' + "".join(char if char in _SAFE_TEXT_CHARACTERS else "?" for char in text) + '"'


def comment_text(text: object) -> str:
    """`text` safe inside a URScript ``#`` comment: printable ASCII only (others become ``?``), ≤ 100 characters.

    Examples
    --------
    >>> comment_text("pick\\nplace")
    'pick?place'
    """
    cleaned = "".join(char if char in _PRINTABLE_ASCII else "?" for char in str(text))
    return cleaned if len(cleaned) <= COMMENT_MAX_LENGTH else cleaned[:COMMENT_MAX_LENGTH - 3] + "..."


def check_identifier(name: object) -> str:
    """`name` unchanged if it is a URScript identifier, else ValueError.

    `name` unchanged if it is a URScript identifier (a letter or _, then letters, digits, _; ≤ 63), else
    ValueError."""
    if not isinstance(name, str) or not _IDENTIFIER.match(name):
        raise ValueError(f"program name {name!r} is not a URScript identifier ([A-Za-z_][A-Za-z0-9_]*, ≤ 63 chars)")
    return name


def new_program_name(purpose: str) -> str:
    """A fresh identifier ``ur3dq_<purpose>_<n>`` (n counts up in this process), to recognise each sent program."""
    return check_identifier(f"ur3dq_{purpose}_{next(_program_counter)}")


def _finite_items(values: Iterable[object], length: int, name: str) -> list[float]:
    """The items of `values` as floats, checked: exactly `length` of them, all finite."""
    try:
        items = [float(item) for item in values]  # type: ignore[arg-type]  # refused below when not a number
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a sequence of {length} real numbers, got {values!r}") from None
    if len(items) != length:
        raise ValueError(f"{name} must have {length} values, got {len(items)}")
    for index, item in enumerate(items):
        if not math.isfinite(item):
            raise ValueError(f"{name}[{index}] must be finite, got {item!r}")
    return items
