"""JSON text read from a file a person gave (the pose store, a cell file): parsed with bounds, every problem a
StoreError naming `file:line`.

Python's json parser recurses once per nesting level and gives up with RecursionError near its recursion limit;
a file nested deeper than any ur3dq file needs (MAX_NESTING) is reported at the line where it passes that depth.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ur3dq.errors import StoreError

#: Deeper than any file ur3dq reads needs (a pose store entry is 3 levels, a cell's tool 4).
MAX_NESTING = 20


def nesting_line(text: str, limit: int = MAX_NESTING) -> int:
    """The 1-based line where the JSON `text` first opens more than `limit` arrays or objects (its last line if
    it never does).

    Examples
    --------
    >>> nesting_line('{"a":\\n [[[1]]]}', limit=3)
    2
    """
    depth, line, in_string, escaped = 0, 1, False, False
    for char in text:
        if char == "\n":
            line += 1
        if in_string:
            escaped = char == "\\" and not escaped
            if char == '"' and not escaped:
                in_string = False
            continue
        if char == '"':
            in_string = True
        elif char in "[{":
            depth += 1
            if depth > limit:
                break
        elif char in "]}":
            depth -= 1
    return line


def decoded(raw: bytes, source: str) -> str:
    """`raw` as UTF-8 text; StoreError naming `source:line` and the first byte that is not UTF-8.

    Examples
    --------
    >>> decoded(b'{"a": 1}', "cell.json")
    '{"a": 1}'
    """
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw.count(b"\n", 0, error.start) + 1
        raise StoreError(f"{source}:{line}: not UTF-8 text (byte 0x{raw[error.start]:02x} at offset {error.start}); "
                         "save it as UTF-8") from None


def read_utf8(path: Path) -> str:
    """The text of `path` as Path.read_text gives it (UTF-8, universal newlines); StoreError naming `path:line` and
    the first byte that is not UTF-8 (``decoded``); OSError as read_text raises it."""
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        decoded(path.read_bytes(), str(path))   # raises, naming the line and the byte
        raise


def decode_error_text(error: json.JSONDecodeError) -> str:
    """json's reason without its dangling position words, which the caller gives as line and column.

    >>> decode_error_text(json.JSONDecodeError("Unterminated string starting at", '"abc', 0))
    'unterminated string'
    """
    reason = error.msg.removesuffix(" at").removesuffix(" starting")
    return reason[:1].lower() + reason[1:]


def parse_json(text: str, source: str) -> Any:
    """The JSON value of `text`; StoreError naming `source:line` when it is not JSON or nests deeper than
    MAX_NESTING levels where Python's parser gives up."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise StoreError(f"{source}:{error.lineno}: not valid JSON ({decode_error_text(error)})") from None
    except RecursionError:
        raise StoreError(f"{source}:{nesting_line(text)}: JSON nested deeper than {MAX_NESTING} levels") from None
    except ValueError as error:  # e.g. an integer with more digits than Python converts
        raise StoreError(f"{source}: not valid JSON ({error})") from None
