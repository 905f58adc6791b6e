"""The pose store's file format (docs/store-schema.md), pure functions on text: versions 1 and 2 to steps and back.

Version 1 holds recorded poses only (`"poses"`), replayed in order with movej. Version 2 holds a cell program
(`"steps"`): waypoints (a recorded pose plus move type, speed, acceleration, blend), relative waypoints and
actions. Both are written one entry per line, so a JSON error's line number names the entry. A store is only
written as version 2 when it uses a version-2 feature (`needs_version_2`), so today's files keep their form.

Big stores: the numbers of every pose are checked in one vectorised pass (finite, plausible, unit dual
quaternion, UR pose agreeing with it), then the poses are built without repeating those checks per pose.
"""
from __future__ import annotations

import itertools
import json
import re
import sys
from collections.abc import Iterable

import numpy as np
import orjson

from ur3dq import dqarray
from ur3dq.errors import StoreError
from ur3dq.json_text import MAX_NESTING, decode_error_text, nesting_line
from ur3dq.pose import (
    MAX_JOINT_ABS,
    MAX_TRANSLATION_ABS,
    POSE_AGREEMENT_TOLERANCE,
    UNIT_TOLERANCE,
    Pose,
    check_pose_text_fields,
    text_fields_all_valid,
)
from ur3dq.program.resolve import check_program
from ur3dq.program.steps import (
    DEFAULT_MOTION,
    AnalogOut,
    Comment,
    DigitalOut,
    KeptScript,
    Message,
    Motion,
    RelativeWaypoint,
    Step,
    Wait,
    WaitInput,
    Waypoint,
)
from ur3dq.real_numbers import is_number

SCHEMA_NAME = "ur3dq.poses"
SCHEMA_VERSION = 1            # a store of recorded poses only (what every ur3dq writes unless a program needs 2)
PROGRAM_SCHEMA_VERSION = 2    # a cell program: steps with move types, relative waypoints, actions
POSE_FIELDS = (
    "name", "time", "robot_model", "robot_serial", "joints", "dual_quaternion", "ur_pose", "tcp_offset", "note",
)
REQUIRED_POSE_FIELDS = ("name", "time", "robot_model", "dual_quaternion", "ur_pose")
MOTION_FIELDS = ("move", "speed", "acceleration", "blend")
# Field lists of the version-2 step types (besides "type" and "name"), in the order they are written.
ACTION_FIELDS = {
    "digital-out": (DigitalOut, ("output", "pin", "on")),
    "analog-out": (AnalogOut, ("pin", "value")),
    "wait": (Wait, ("seconds",)),
    "wait-input": (WaitInput, ("input", "pin", "on", "timeout")),
    "message": (Message, ("text",)),
    "comment": (Comment, ("text",)),
    "kept-script": (KeptScript, ("script", "origin")),
}
RELATIVE_FIELDS = ("base", "offset", "frame", "note")


# ---------------------------------------------------------------- one pose


def pose_to_dict(pose: Pose) -> dict:
    """The JSON object of one pose, fields in schema order (lists of floats; joints null when unknown)."""
    return {
        "name": pose.name,
        "time": pose.time,
        "robot_model": pose.robot_model,
        "robot_serial": pose.robot_serial,
        "joints": list(pose.joints) if pose.joints is not None else None,
        "dual_quaternion": list(pose.dual_quaternion),
        "ur_pose": list(pose.ur_pose),
        "tcp_offset": list(pose.tcp_offset),
        "note": pose.note,
    }


def _check_pose_fields(obj, who: str, extra=()) -> None:
    if not isinstance(obj, dict):
        raise ValueError(f"{who}: must be a JSON object, got {type(obj).__name__}")
    unknown = sorted(set(obj) - set(POSE_FIELDS) - set(extra))
    if unknown:
        raise ValueError(f"{who}: unknown field {unknown[0]!r} (known: {', '.join((*POSE_FIELDS, *extra))})")
    missing = [field for field in REQUIRED_POSE_FIELDS if field not in obj]
    if missing:
        raise ValueError(f"{who}: missing field {missing[0]!r}")


def pose_from_dict(obj, who: str) -> Pose:
    """A Pose from its JSON object; ValueError naming `who` (e.g. "pose #3 'pick'") and the field at fault."""
    _check_pose_fields(obj, who)
    fields = {key: obj[key] for key in POSE_FIELDS if key in obj}
    fields["tcp_offset"] = fields.get("tcp_offset") if fields.get("tcp_offset") is not None else _ZERO_ROW
    fields["note"] = fields.get("note") or ""
    _check_magnitudes([fields], who)
    return Pose(**fields)


def _vectors(entries, field: str, length: int, who_of) -> np.ndarray:
    """(N, length) floats of `field` of every entry; ValueError naming the first entry that is not numbers.

    A number is a JSON number: np.fromiter and np.array would also take the string "1.5" and the literal true (a
    bool is an int in Python) as 1.5 and 1.0, so a hand-edited or corrupt file would load with them."""
    rows = [entry[field] for entry in entries]
    # The whole column at once when every row is a list of `length` JSON numbers; otherwise the loop below names
    # the first bad row.
    if (all(type(row) is list and len(row) == length for row in rows)
            and set(map(type, itertools.chain.from_iterable(rows))) <= _JSON_NUMBERS):
        try:
            return np.array(rows, dtype=float).reshape(-1, length)
        except OverflowError:   # an integer too large for a float: named below
            pass
    for index, value in enumerate(rows):
        if isinstance(value, (str, dict)) or not hasattr(value, "__len__") or len(value) != length:
            got = len(value) if isinstance(value, (list, tuple)) else repr(value)
            raise ValueError(f"{who_of(index)}: {field} must be {length} numbers, got {got}")
        for item in value:
            if not is_number(item):
                shown = json.dumps(item) if isinstance(item, (str, bool)) or item is None else repr(item)
                raise ValueError(f"{who_of(index)}: {field} must be {length} numbers, got {shown} among them")
            if isinstance(item, int) and abs(item) > sys.float_info.max:
                raise ValueError(f"{who_of(index)}: {field} holds a number too large for a float")
    return np.array(rows, dtype=float).reshape(-1, length)   # numbers all; some rows tuples, not lists


#: The item types of a JSON number array as parsed (orjson and json alike): never bool, never str.
_JSON_NUMBERS = {int, float}


def _first_bad(mask: np.ndarray | np.bool_) -> int | None:
    rows = np.flatnonzero(mask)
    return int(rows[0]) if rows.size else None


def _check_magnitudes(fields_list, who, who_of=None) -> tuple:
    """Check the numbers of many pose field dicts at once (vectorised); ValueError naming the pose at fault.

    Returns (dual_quaternion (N, 8), ur_pose (N, 6), tcp_offset (N, 6)) arrays and the joints of each pose: a
    tuple of 6 floats, or None."""
    who_of = who_of or (lambda index: who)
    dq = _vectors(fields_list, "dual_quaternion", 8, who_of)
    ur = _vectors(fields_list, "ur_pose", 6, who_of)
    tcp = _vectors(fields_list, "tcp_offset", 6, who_of)
    with_joints = [i for i, f in enumerate(fields_list) if f.get("joints") is not None]
    joints = _vectors([fields_list[i] for i in with_joints], "joints", 6,
                      lambda k: who_of(with_joints[k])) if with_joints else np.zeros((0, 6))
    for field, array, index_of in (("dual_quaternion", dq, None), ("ur_pose", ur, None), ("tcp_offset", tcp, None),
                                   ("joints", joints, with_joints)):
        bad = _first_bad(~np.isfinite(array).all(axis=1))
        if bad is not None:
            at = index_of[bad] if index_of else bad
            raise ValueError(f"{who_of(at)}: {field} contains NaN or infinity: {array[bad].tolist()}")
    bad = _first_bad((np.abs(joints) > MAX_JOINT_ABS).any(axis=1))
    if bad is not None:
        raise ValueError(f"{who_of(with_joints[bad])}: joints {joints[bad].tolist()} are not plausible "
                         f"(|joint| > {MAX_JOINT_ABS:g} rad)")
    for field, array in (("ur_pose", ur), ("tcp_offset", tcp)):
        bad = _first_bad((np.abs(array) > MAX_TRANSLATION_ABS).any(axis=1))
        if bad is not None:
            raise ValueError(f"{who_of(bad)}: {field} {array[bad].tolist()} is not plausible "
                             f"(a coordinate beyond {MAX_TRANSLATION_ABS:g} m or rad)")
    real, dual = dq[:, :4], dq[:, 4:]
    norms = np.linalg.norm(real, axis=1)
    bad = _first_bad(np.abs(norms - 1.0) > UNIT_TOLERANCE)
    if bad is not None:
        raise ValueError(f"{who_of(bad)}: dual_quaternion rotation part has norm {norms[bad]:.9g}, not 1 "
                         "(not a rigid transform)")
    dots = np.einsum("ij,ij->i", real, dual)
    bad = _first_bad(np.abs(dots) > UNIT_TOLERANCE)
    if bad is not None:
        raise ValueError(f"{who_of(bad)}: dual_quaternion is not a rigid transform (r·d = {dots[bad]:.3g}, not 0)")
    from_vector = dqarray.from_ur_pose(ur)
    metres, radians = dqarray.pose_distance(from_vector, dq / norms[:, None])
    bad = _first_bad((metres > POSE_AGREEMENT_TOLERANCE) | (radians > POSE_AGREEMENT_TOLERANCE))
    if bad is not None:
        raise ValueError(f"{who_of(bad)}: ur_pose and dual_quaternion disagree by {metres[bad]:.3g} m and "
                         f"{radians[bad]:.3g} rad")
    joint_rows = [None] * len(fields_list)
    for index, row in zip(with_joints, _tuples(joints)):
        joint_rows[index] = row
    return dq, ur, tcp, joint_rows


_NO_TCP_OFFSET = (0.0,) * 6
#: A missing tcp_offset's numbers, a list as JSON gives them (_vectors' fast path takes lists only); never mutated.
_ZERO_ROW = [0.0] * 6
_WAYPOINT_KEYS = frozenset(POSE_FIELDS) | {"type"} | frozenset(MOTION_FIELDS)
_REQUIRED_KEYS = frozenset(REQUIRED_POSE_FIELDS)
CHUNK = 4096  # entries parsed and checked per vectorised pass: big enough for numpy, small enough to bound memory
#: lines of ur3dq's own layout parsed by one orjson call: a call per line costs as much as the parse, and bigger
#: batches leave the allocator fragmented (more peak memory)
PARSED_LINES = 256


def _poses_of_chunk(entries, chunk, who_of) -> list[Pose]:
    """Poses from the JSON objects `entries[i]` for i in `chunk`, numbers checked in one vectorised pass, then
    the text fields; ValueError naming the entry (who_of(i))."""
    fields_list = []
    for index in chunk:
        fields = entries[index]  # a freshly parsed object: completed in place with the defaults
        if not (type(fields) is dict and fields.keys() <= _WAYPOINT_KEYS and _REQUIRED_KEYS <= fields.keys()):
            _check_pose_fields(fields, who_of(index), extra=("type", *MOTION_FIELDS))  # says what is wrong
        if fields.get("tcp_offset") is None:
            fields["tcp_offset"] = _ZERO_ROW
        if not fields.get("note"):
            fields["note"] = ""
        fields_list.append(fields)
    if not fields_list:
        return []
    dq, ur, tcp, joints = _check_magnitudes(fields_list, None, lambda k: who_of(chunk[k]))
    names = [fields["name"] for fields in fields_list]
    times = [fields["time"] for fields in fields_list]
    models = [fields["robot_model"] for fields in fields_list]
    serials = [fields.get("robot_serial") for fields in fields_list]
    notes = [fields["note"] for fields in fields_list]
    if not text_fields_all_valid(names, times, models, serials, notes):
        for k, text in enumerate(zip(names, times, models, serials, notes)):   # the first at fault, by name
            try:
                check_pose_text_fields(*text)
            except ValueError as error:
                raise ValueError(f"{who_of(chunk[k])}: {_strip_pose_prefix(str(error))}") from None
    # One shared zero TCP and model name: most poses of a store have them, and a big store would hold 10⁵ copies.
    tcp = [_NO_TCP_OFFSET if zero else row for zero, row in zip((~tcp.any(axis=1)).tolist(), _tuples(tcp))]
    models = [sys.intern(model) for model in models]
    return list(map(Pose.checked, names, times, models, _tuples(dq), _tuples(ur), tcp, joints, serials, notes))


def _tuples(rows: np.ndarray) -> list:
    """The rows of a 2-D array as tuples of floats."""
    return list(map(tuple, rows.tolist()))


def _strip_pose_prefix(message: str) -> str:
    """`message` without a leading "pose '...': " (the caller names the entry itself)."""
    if message.startswith("pose ") and "': " in message:
        return message.split("': ", 1)[1]
    return message


# ---------------------------------------------------------------- one step


def _motion_from(obj, who: str) -> Motion:
    if not any(key in obj for key in MOTION_FIELDS):
        return DEFAULT_MOTION
    try:
        return Motion(obj.get("move", "joint"), obj.get("speed"), obj.get("acceleration"), obj.get("blend"))
    except ValueError as error:
        raise ValueError(f"{who}: {str(error).removeprefix('motion: ')}") from None


def _motion_fields(motion: Motion) -> dict:
    fields = {"move": motion.move}
    for key in ("speed", "acceleration", "blend"):
        if getattr(motion, key) is not None:
            fields[key] = getattr(motion, key)
    return fields


def step_to_dict(step) -> dict:
    """The version-2 JSON object of one step."""
    if isinstance(step, Waypoint):
        return {"type": "waypoint", **pose_to_dict(step.pose), **_motion_fields(step.motion)}
    if isinstance(step, RelativeWaypoint):
        return {"type": "relative", "name": step.name, "base": step.base, "offset": list(step.offset),
                "frame": step.frame, **_motion_fields(step.motion), "note": step.note}
    _, fields = ACTION_FIELDS[step.kind]
    return {"type": step.kind, "name": step.name, **{field: getattr(step, field) for field in fields}}


def step_from_dict(obj, who: str):
    """A non-waypoint step (relative waypoint or action) from its JSON object; ValueError naming `who`."""
    kind = obj.get("type")
    name = obj.get("name")
    if kind == "relative":
        allowed = {"type", "name", *RELATIVE_FIELDS, *MOTION_FIELDS}
    elif kind in ACTION_FIELDS:
        allowed = {"type", "name", *ACTION_FIELDS[kind][1]}
    else:
        raise ValueError(f"{who}: unknown step type {kind!r} (known: waypoint, relative, "
                         f"{', '.join(ACTION_FIELDS)})")
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise ValueError(f"{who}: unknown field {unknown[0]!r} for a {kind} step")
    if not isinstance(name, str):
        raise ValueError(f"{who}: missing or non-text \"name\"")
    if kind == "relative":
        return RelativeWaypoint(name, obj.get("base"), obj.get("offset", (0.0,) * 6), obj.get("frame", "tool"),
                                _motion_from(obj, who), obj.get("note", ""))
    cls, fields = ACTION_FIELDS[kind]
    missing = [field for field in fields if field not in obj and field not in ("output", "input", "timeout")]
    if missing:
        raise ValueError(f"{who}: missing field {missing[0]!r}")
    return cls(name, **{field: obj[field] for field in fields if field in obj})


def needs_version_2(steps) -> bool:
    """True when `steps` use anything version 1 cannot hold (a non-waypoint step or a waypoint's own motion)."""
    return any(not isinstance(step, Waypoint) or not step.motion.is_default for step in steps)


# ---------------------------------------------------------------- whole files


def format_store(poses) -> str:
    """A version-1 file's text: the envelope, one pose per line (so json's line numbers name a pose)."""
    return _envelope(SCHEMA_VERSION, "poses", [pose_to_dict(pose) for pose in poses])


def format_program(steps) -> str:
    """The file text for `steps`: version 1 when they fit it (recorded joint waypoints only), else version 2."""
    steps = list(steps)
    if not needs_version_2(steps):
        return format_store(step.pose for step in steps)
    return format_program_v2(steps)


def format_program_v2(steps) -> str:
    """A version-2 file's text: one step per line."""
    return _envelope(PROGRAM_SCHEMA_VERSION, "steps", [step_to_dict(step) for step in steps])


def _envelope(version: int, key: str, entries) -> str:
    lines = [json.dumps(entry, ensure_ascii=False) for entry in entries]
    body = ",\n    ".join(lines)
    entries_text = f"[\n    {body}\n  ]" if lines else "[]"
    return ("{\n" f'  "schema": {json.dumps(SCHEMA_NAME)},\n' f'  "version": {version},\n'
            f'  {json.dumps(key)}: {entries_text}\n' "}\n")


def _line_of_entry(text: str, name) -> int | None:
    """The 1-based line where the entry called `name` starts, in the one-entry-per-line layout."""
    if not isinstance(name, str):
        return None
    needle = f'"name": {json.dumps(name, ensure_ascii=False)}'
    for number, line in enumerate(text.splitlines(), start=1):
        if needle in line:
            return number
    return None


def _where(text: str, source: str, name) -> str:
    line = _line_of_entry(text, name)
    return f"{source}:{line}" if line else source


def _too_deep(text: str, source: str) -> StoreError:
    """The error for JSON nested deeper than Python's parser goes, at the line where MAX_NESTING is passed."""
    return StoreError(f"{source}:{nesting_line(text)}: not a pose store: JSON nested deeper than {MAX_NESTING} levels")


class _NotOwnLayout(Exception):
    """The text is not in the one-entry-per-line layout ur3dq writes: parse it as a whole instead."""


#: What to do about a store file that cannot be read (added to each such error by parse_document).
UNREADABLE_FIX = "the file is left as it is: correct it there, or use another store file"


class _NewerVersion(StoreError):
    """A store written by a newer ur3dq: its message names its own fix (upgrade)."""


_OWN_HEAD = re.compile(r'\{\n  "schema": "ur3dq\.poses",\n  "version": ([12]),\n  "(poses|steps)": \[\n')
_OWN_TAIL = "\n  ]\n}\n"


def own_layout_version(head: str) -> int | None:
    """The version written in the first lines of a file in ur3dq's own layout, else None."""
    match = _OWN_HEAD.match(head)
    return int(match.group(1)) if match else None


def _own_layout(text: str):
    """(version, key, iterator of (first entry's line number, entry objects)) when `text` has the layout ur3dq
    writes, reading PARSED_LINES lines at a time (so a big file's entries are never all parsed at once);
    _NotOwnLayout otherwise (also raised by the iterator at the first batch of lines that does not fit)."""
    head = _OWN_HEAD.match(text)
    if not head or not text.endswith(_OWN_TAIL):
        raise _NotOwnLayout
    version, key = int(head.group(1)), head.group(2)
    end = len(text) - len(_OWN_TAIL) + 1  # just after the last entry's line break

    def entries():
        position, line = head.end(), 5   # the entries start on the file's 5th line
        while position < end:
            # The next PARSED_LINES lines, one entry each: each opens an object, and all but the file's last end
            # with a comma (checked in place: a copy of each line would cost as much memory as the text).
            stop, count = position, 0
            for count in range(1, PARSED_LINES + 1):   # noqa: B007  (count is read after the loop)
                if not text.startswith("    {", stop):
                    raise _NotOwnLayout
                stop = text.index("\n", stop) + 1
                if (text[stop - 2] == ",") == (stop >= end):
                    raise _NotOwnLayout
                if stop >= end:
                    break
            last = stop >= end
            try:
                # orjson parses the lines as one array: much faster than the stdlib's scanner, and a call per line
                # costs as much again. What it refuses (NaN, a number beyond a double, a lone surrogate,
                # nesting past 1024) sends the file to the stdlib path, with its errors.
                objects = orjson.loads("[" + text[position:stop - (1 if last else 2)] + "]")
            except orjson.JSONDecodeError:
                raise _NotOwnLayout from None
            if len(objects) != count:   # a line that holds two entries
                raise _NotOwnLayout
            yield line, objects
            del objects   # before the next lines are parsed: never two batches of entries at once
            position, line = stop, line + count

    return version, key, entries()


def _whole_document(text: str, source: str):
    """(version, key, iterator of (None, entry objects)) of any JSON store text (no line numbers: the layout is
    not known); StoreError naming `source:line` for invalid JSON or envelope."""
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise StoreError(f"{source}:{error.lineno}:{error.colno}: not valid JSON: {decode_error_text(error)}") from None
    except RecursionError:
        raise _too_deep(text, source) from None
    except ValueError as error:  # e.g. an integer with more digits than Python converts
        raise StoreError(f"{source}: not a pose store: {error}") from None
    if not isinstance(document, dict):
        raise StoreError(f"{source}:1: not a pose store: expected a JSON object with \"schema\": \"{SCHEMA_NAME}\"")
    if document.get("schema") != SCHEMA_NAME:
        found = f"\"schema\" is {json.dumps(document['schema'])[:40]}" if "schema" in document else \
            "it has no \"schema\" key"
        raise StoreError(f"{source}:1: not a pose store: {found}, expected \"schema\": \"{SCHEMA_NAME}\"")
    version = document.get("version")
    if type(version) is not int or version not in (SCHEMA_VERSION, PROGRAM_SCHEMA_VERSION):
        newer = type(version) is int and version > PROGRAM_SCHEMA_VERSION
        problem = (f"{source}:1: store version {version!r} is not supported (this ur3dq reads versions "
                   f"{SCHEMA_VERSION} and {PROGRAM_SCHEMA_VERSION})")
        if newer:
            raise _NewerVersion(f"{problem}; the file was written by a newer ur3dq: upgrade ur3dq to read it")
        raise StoreError(problem)
    key = "poses" if version == SCHEMA_VERSION else "steps"
    other = "steps" if key == "poses" else "poses"
    if other in document:
        raise StoreError(f"{source}:1: a version {version} store has {key!r}, not {other!r}")
    entries = document.get(key)
    if not isinstance(entries, list):
        raise StoreError(f"{source}:1: {json.dumps(key)} must be a list")
    return version, key, iter([(None, entries)])


def parse_document(text: str, source: str) -> tuple[int, list]:
    """(version, steps) of a store file's text; StoreError with `source:line` (where known) and what is wrong.

    Text in ur3dq's own layout is read one entry per line, checked in chunks of CHUNK entries (bounded memory for
    big stores, exact line numbers); anything else (a hand-edited layout) is parsed as one JSON document. The
    error's message ends with what to do (UNREADABLE_FIX, or for a newer store's version: upgrade ur3dq)."""
    try:
        try:
            version, _, entries = _own_layout(text)
            return version, _steps_of(version, entries, text, source)   # its entries may still not fit the layout
        except _NotOwnLayout:
            version, _, entries = _whole_document(text, source)
            return version, _steps_of(version, entries, text, source)
    except _NewerVersion:
        raise
    except StoreError as error:
        raise StoreError(f"{error}; {UNREADABLE_FIX}") from None


class _StepReader:
    """Builds the validated steps of a store's entries, naming each failure by its line (or its name)."""

    def __init__(self, version: int, text: str, source: str) -> None:
        self.version, self.text, self.source = version, text, source
        self.label = "pose" if version == SCHEMA_VERSION else "step"
        self.names: list = []   # every entry's name (None when it has none), in file order
        self.lines: list = []   # every entry's line number, or None
        self.steps: list = []

    def who_of(self, index: int) -> str:
        name = self.names[index]
        return f"{self.label} #{index + 1}" + (f" {name!r}" if isinstance(name, str) else "")

    def fail(self, index: int | None, error: object) -> StoreError:
        if index is not None and self.lines[index] is not None:
            return StoreError(f"{self.source}:{self.lines[index]}: {error}")
        name = self.names[index] if index is not None else None
        return StoreError(f"{_where(self.text, self.source, name)}: {error}")

    def add_entries(self, line: int | None, objects: list) -> None:
        """Note the names and lines of `objects`, entries starting at `line` (None: unknown)."""
        self.names.extend([obj.get("name") if isinstance(obj, dict) else None for obj in objects])
        self.lines.extend(range(line, line + len(objects)) if line is not None else [None] * len(objects))

    def convert(self, objects: list) -> None:
        """Append the steps of `objects`, the entries that follow the steps built so far."""
        first = len(self.steps)
        if self.version == SCHEMA_VERSION:   # poses only: the chunk's steps are its waypoints
            indices = list(range(first, first + len(objects)))
            self.steps.extend(map(Waypoint.of_checked_pose, self._poses(objects, indices)))
            return
        is_pose = [isinstance(obj, dict) and obj.get("type") == "waypoint" for obj in objects]
        pose_indices = [first + k for k, flag in enumerate(is_pose) if flag]
        poses = iter(self._poses([obj for obj, flag in zip(objects, is_pose) if flag], pose_indices))
        for index, obj, flag in zip(range(first, first + len(objects)), objects, is_pose):
            try:
                self.steps.append(self._waypoint(next(poses), obj, index) if flag else self._step(obj, index))
            except ValueError as error:
                message = str(error)
                raise self.fail(index, message if message.startswith(self.label)
                                else f"{self.who_of(index)}: {message}") from None

    def _poses(self, objects: list, indices: list[int]) -> list:
        """The checked poses of the waypoint entries `objects`, whose entry indices are `indices`."""
        try:
            return _poses_of_chunk(objects, range(len(objects)), lambda k: self.who_of(indices[k]))
        except ValueError as error:
            bad = next((i for i in indices if str(error).startswith(self.who_of(i) + ":")), None)
            raise self.fail(bad, error) from None

    def _waypoint(self, pose: Pose, obj: dict, index: int) -> Waypoint:
        motion = _motion_from(obj, self.who_of(index))
        return Waypoint.of_checked_pose(pose) if motion is DEFAULT_MOTION else Waypoint(pose.name, pose, motion)

    def _step(self, obj: object, index: int) -> Step:
        if not isinstance(obj, dict):
            raise ValueError(f"{self.who_of(index)}: must be a JSON object")
        return step_from_dict(obj, self.who_of(index))

    def check(self) -> None:
        """Refuse a repeated name or an unsound program, naming the entry."""
        if len(set(self.names)) != len(self.names):   # every step is built: find the repeat's line
            seen: set = set()
            for index, step in enumerate(self.steps):
                if step.name in seen:
                    raise self.fail(index, f"{self.label} name {step.name!r} appears twice")
                seen.add(step.name)
        try:
            check_program(self.steps)
        except ValueError as error:
            bad = next((i for i, step in enumerate(self.steps) if str(error).startswith(step.who)), None)
            raise self.fail(bad, error) from None


def _steps_of(version: int, batches: Iterable[tuple[int | None, list]], text: str, source: str) -> list:
    """The validated steps of `batches` ((first entry's line number or None, entry objects) in file order),
    converted CHUNK entries at a time."""
    reader = _StepReader(version, text, source)
    pending: list = []   # entries read, not yet converted
    for line, objects in batches:
        reader.add_entries(line, objects)
        pending.extend(objects)
        while len(pending) >= CHUNK:
            reader.convert(pending[:CHUNK])
            del pending[:CHUNK]
    reader.convert(pending)
    reader.check()
    return reader.steps


def parse_store(text: str, source: str) -> list[Pose]:
    """The recorded poses of a store file's text (every version), in program order."""
    return [step.pose for step in parse_document(text, source)[1] if isinstance(step, Waypoint)]
