"""The robot cell the path must stay clear of: a floor plane, keep-out boxes, an optional keep-in box, the tool.

File format (JSON, metres, base frame, boxes axis-aligned; documented in docs/cell-file.md):
    {"floor": {"z": 0.0},
     "boxes": [{"name": "fixture", "min": [x, y, z], "max": [x, y, z]}],
     "keep_in": {"min": [x, y, z], "max": [x, y, z]},
     "margin": 0.01,
     "tool": {"capsule": {"from": [x, y, z], "to": [x, y, z], "radius": r}}   # or {"box": {"min": .., "max": ..}}
    }
Every key is optional; `margin` defaults to DEFAULT_CELL_MARGIN. The tool is given in the flange frame.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ur3dq.array_types import FloatArray
from ur3dq.dqarray import MAX_POSE_COORDINATE
from ur3dq.errors import StoreError
from ur3dq.json_text import decoded, parse_json
from ur3dq.real_numbers import is_number

DEFAULT_CELL_MARGIN = 0.01
#: A cell file larger than this is refused unread (a thousand boxes take about 100 KiB).
MAX_CELL_FILE_BYTES = 1024 * 1024
_KEYS = {"floor", "boxes", "keep_in", "margin", "tool"}


@dataclasses.dataclass(frozen=True)
class Box:
    """An axis-aligned box [lo, hi] (each (3,), metres)."""

    name: str
    lo: FloatArray
    hi: FloatArray


@dataclasses.dataclass(frozen=True)
class ToolShape:
    """The tool as a capsule in the flange frame: segment a→b (each (3,)) swept by `radius`.

    A box tool is stored as the smallest capsule along its longest edge that contains it (conservative)."""

    a: FloatArray
    b: FloatArray
    radius: float

    @classmethod
    def capsule(cls, a: Sequence[float], b: Sequence[float], radius: float) -> ToolShape:
        """A capsule tool from `a` to `b` (flange frame, m) with `radius` (m)."""
        return cls(_point(a, "tool capsule 'from'"), _point(b, "tool capsule 'to'"), _length(radius, "tool radius"))

    @classmethod
    def box(cls, lo: Sequence[float], hi: Sequence[float]) -> ToolShape:
        """A box tool between corners `lo` and `hi` (flange frame, m), checked as its enclosing capsule."""
        low, high = _ordered(_point(lo, "tool box 'min'"), _point(hi, "tool box 'max'"), "tool box")
        size = high - low
        axis = int(np.argmax(size))
        others = [i for i in range(3) if i != axis]
        centre = (low + high) / 2
        a, b = centre.copy(), centre.copy()
        a[axis], b[axis] = low[axis], high[axis]
        # Every corner lies within half the cross-section's diagonal of the segment's end points.
        return cls(a, b, float(0.5 * np.hypot(size[others[0]], size[others[1]])))


@dataclasses.dataclass(frozen=True)
class Cell:
    """floor_z (None = no floor), keep-out boxes, keep_in (Box or None), margin (m), tool (ToolShape or None)."""

    floor_z: float | None = None
    boxes: tuple[Box, ...] = ()
    keep_in: Box | None = None
    margin: float = DEFAULT_CELL_MARGIN
    tool: ToolShape | None = None

    def with_margin(self, margin: float) -> Cell:
        """The same cell with another clearance margin (m)."""
        return dataclasses.replace(self, margin=_length(margin, "cell margin"))


#: A cell file to start from, shown when the named one does not exist: a 2 m table whose top is the base's foot.
STARTER_CELL = '{"boxes": [{"name": "table", "min": [-1, -1, -0.05], "max": [1, 1, 0]}], "margin": 0.01}'


def cell_from_dict(data: object, origin: str = "cell") -> Cell:
    """A Cell from the decoded JSON object; ValueError naming `origin` and the bad key."""
    try:
        return _parse(data)
    except ValueError as error:
        raise ValueError(f"{origin}: {error}") from None


def load_cell(path: str | os.PathLike[str]) -> Cell:
    """Read a cell file; StoreError (unreadable, over MAX_CELL_FILE_BYTES, not UTF-8, not JSON, nested deeper
    than json_text.MAX_NESTING) or ValueError (bad content), each naming the file."""
    source = f"cell file {Path(path)}"
    try:
        with open(path, "rb") as stream:
            raw = stream.read(MAX_CELL_FILE_BYTES + 1)   # never more: a huge file is refused, not read
    except FileNotFoundError:
        raise StoreError(f"{source}: no such file. Write it (JSON, metres, the base frame; docs/cell-file.md), e.g. "
                         f"a table top at the arm's foot: {STARTER_CELL}") from None
    except OSError as error:
        raise StoreError(f"{source}: cannot read it ({error.strerror or error})") from None
    if len(raw) > MAX_CELL_FILE_BYTES:
        raise StoreError(f"{source}: larger than {MAX_CELL_FILE_BYTES // 1024} KiB; a cell file holds a floor, "
                         "boxes, a keep-in box and a tool (docs/cell-file.md)")
    return cell_from_dict(parse_json(decoded(raw, source), source), source)


def _parse(data: object) -> Cell:
    if not isinstance(data, dict):
        raise ValueError("the cell must be a JSON object")
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        raise ValueError(f"unknown key {unknown[0]!r} (known: {', '.join(sorted(_KEYS))})")
    floor = data.get("floor")
    floor_z = None
    if floor is not None:
        if not isinstance(floor, dict) or set(floor) != {"z"}:
            raise ValueError('"floor" must be {"z": height}')
        floor_z = _number(floor["z"], "floor z")
    boxes = data.get("boxes", [])
    if not isinstance(boxes, list):
        raise ValueError('"boxes" must be a list')
    parsed = []
    for index, box in enumerate(boxes):
        if not isinstance(box, dict) or not {"min", "max"} <= set(box) <= {"name", "min", "max"}:
            raise ValueError(f'box {index + 1} must be {{"name": ..., "min": [x, y, z], "max": [x, y, z]}}')
        name = box.get("name", f"box {index + 1}")
        if not isinstance(name, str) or not name:
            raise ValueError(f"box {index + 1}: name must be a non-empty string")
        lo, hi = _ordered(_point(box["min"], f'box "{name}" min'), _point(box["max"], f'box "{name}" max'),
                          f'box "{name}"')
        parsed.append(Box(name, lo, hi))
    keep_in = data.get("keep_in")
    if keep_in is not None:
        if not isinstance(keep_in, dict) or set(keep_in) != {"min", "max"}:
            raise ValueError('"keep_in" must be {"min": [x, y, z], "max": [x, y, z]}')
        keep_in = Box("keep-in", *_ordered(_point(keep_in["min"], "keep_in min"), _point(keep_in["max"], "keep_in max"),
                                           "keep_in"))
    margin = _length(data.get("margin", DEFAULT_CELL_MARGIN), "margin")
    return Cell(floor_z, tuple(parsed), keep_in, margin, _tool(data.get("tool")))


def _tool(tool: object) -> ToolShape | None:
    if tool is None:
        return None
    if isinstance(tool, dict) and set(tool) == {"capsule"} and isinstance(tool["capsule"], dict) \
            and set(tool["capsule"]) == {"from", "to", "radius"}:
        capsule = tool["capsule"]
        return ToolShape.capsule(capsule["from"], capsule["to"], capsule["radius"])
    if isinstance(tool, dict) and set(tool) == {"box"} and isinstance(tool["box"], dict) \
            and set(tool["box"]) == {"min", "max"}:
        return ToolShape.box(tool["box"]["min"], tool["box"]["max"])
    raise ValueError('"tool" must be {"capsule": {"from": [..], "to": [..], "radius": r}} or '
                     '{"box": {"min": [..], "max": [..]}} (flange frame, metres)')


def _number(value: object, what: str) -> float:
    # is_number refuses bools and text; the isinstance tells the type checker what it let through
    if not (is_number(value) and isinstance(value, numbers.Real) and math.isfinite(value)):
        raise ValueError(f"{what} must be a finite number, got {value!r}")
    number = float(value)
    if abs(number) > MAX_POSE_COORDINATE:   # metres: a cell this far out is millimetres typed as metres
        raise ValueError(f"{what} must be within ±{MAX_POSE_COORDINATE:g} m of the base, got {number:.6g} m "
                         "(the cell file is in metres)")
    return number


def _length(value: object, what: str) -> float:
    length = _number(value, what)
    if length < 0:
        raise ValueError(f"{what} must be ≥ 0 metres, got {length!r}")
    return length


def _point(value: object, what: str) -> FloatArray:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError(f"{what} must be 3 numbers [x, y, z], got {value!r}")
    return np.array([_number(v, what) for v in value])


def _ordered(lo: FloatArray, hi: FloatArray, what: str) -> tuple[FloatArray, FloatArray]:
    if np.any(lo >= hi):
        raise ValueError(f"{what}: every min must be below its max, got min {lo.tolist()} max {hi.tolist()}")
    return lo, hi
