"""A recorded pose: what the pose store keeps for each pose, validated on construction.

A pose is the TCP's transform in the robot's base frame, kept three ways that must agree: the unit dual quaternion
σ = r + ε·½·t·r (8 coefficients [rw rx ry rz dw dx dy dz]), the UR pose vector [x, y, z, rx, ry, rz], and, when the
pose came from a robot, the six joint angles that produced it. Metres and radians.
"""
from __future__ import annotations

import dataclasses
import difflib
import unicodedata
from collections.abc import Iterable, Sequence
from datetime import datetime, timedelta, timezone
from typing import Any

import numpy as np

from ur3dq.dqarray import MAX_POSE_COORDINATE
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics.models import MODEL_NAMES
from ur3dq.real_numbers import real_array

# How far the stored UR pose vector may drift from the dual quaternion (JSON floats round-trip exactly, so only
# hand edits can exceed this).
POSE_AGREEMENT_TOLERANCE = 1e-6
# A unit dual quaternion has |r| = 1 and r·d = 0; 1e-6 accepts any value printed with 7+ significant digits.
UNIT_TOLERANCE = 1e-6
MAX_NAME_LENGTH = 100
# Plausible magnitudes: beyond these a reading or a hand edit went wrong (1e308 would overflow in later maths).
MAX_JOINT_ABS = 100.0        # rad: the UR3's wrist 3 turns without limit, but no arm is wound up 16 turns
MAX_TRANSLATION_ABS = MAX_POSE_COORDINATE  # m (and rad for rotation-vector components) in ur_pose and tcp_offset
_NO_OFFSET = timedelta(0)  # the UTC offset a pose's time must have


def utc_now_iso() -> str:
    """The current time as ISO 8601 UTC with milliseconds and a `Z` suffix, e.g. 2026-11-22T01:02:03.456Z."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def parse_iso_time(text: str) -> datetime:
    """The datetime of ISO 8601 `text`, a `Z` suffix meaning UTC on every supported Python (3.10's
    datetime.fromisoformat refuses it); ValueError when it is not ISO 8601."""
    return datetime.fromisoformat(text[:-1] + "+00:00" if text.endswith("Z") else text)


def name_problem(name: object) -> str | None:
    """Why `name` cannot name a pose, or None if it can.

    Why `name` cannot name a pose (None if it can): non-empty text, ≤ 100 characters, no control characters,
    no leading or trailing blanks."""
    if not isinstance(name, str):
        return f"a pose name must be text, got {type(name).__name__}"
    if not name:
        return "a pose name must not be empty"
    if len(name) > MAX_NAME_LENGTH:
        return f"pose name {name[:20]!r}... is longer than {MAX_NAME_LENGTH} characters"
    if name != name.strip():
        return f"pose name {name!r} starts or ends with blanks"
    if not (name.isascii() and name.isprintable()) and any(unicodedata.category(ch).startswith("C") for ch in name):
        return f"pose name {name!r} contains control characters"
    return None


def unstorable_text_problem(text: str | None, field: str) -> str | None:
    """Why the text `text` of `field` cannot be written to a UTF-8 store (None if it can, or if it is None).

    JSON's \\u escapes can spell a lone UTF-16 surrogate (a hand edit, another tool's export); Python reads it, but
    no UTF-8 file can hold it, so the next save of the store would fail. Refused when read instead."""
    if text is None or text.isascii():
        return None
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as error:
        return f"{field} holds a lone UTF-16 surrogate ({text[error.start]!r}), which a UTF-8 file cannot hold"
    return None


def _finite_vector(value: object, length: int, field: str, who: str) -> tuple[float, ...]:
    """`value` as a tuple of `length` finite floats, or ValueError naming `who` and `field`."""
    try:
        array = real_array(value)
    except OverflowError:
        raise ValueError(f"{who}: {field} holds a number too large for a float") from None
    except (TypeError, ValueError):
        raise ValueError(f"{who}: {field} must be {length} numbers, got {value!r}") from None
    if array.shape != (length,):
        raise ValueError(f"{who}: {field} must be {length} numbers, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{who}: {field} contains NaN or infinity: {array.tolist()}")
    bound = MAX_JOINT_ABS if field == "joints" else MAX_TRANSLATION_ABS
    if np.any(np.abs(array) > bound):
        raise ValueError(f"{who}: {field} {array.tolist()} is not plausible (a value beyond ±{bound:g})")
    return tuple(float(x) for x in array)


def _check_utc_time(time: object, who: str) -> None:
    """Raise ValueError naming `who` unless `time` is ISO 8601 with a UTC offset of zero."""
    try:
        if not isinstance(time, str):
            raise TypeError
        parsed = parse_iso_time(time)
    except (TypeError, ValueError):
        raise ValueError(f"{who}: time {time!r} is not ISO 8601 (e.g. 2026-11-22T01:02:03Z)") from None
    if parsed.utcoffset() != _NO_OFFSET:  # also a time without an offset (None)
        raise ValueError(f"{who}: time {time!r} must be in UTC (end it with Z)")


def _check_unit_dual_quaternion(coefficients: tuple[float, ...], who: str) -> None:
    """Raise ValueError naming `who` unless [r | d] is a unit dual quaternion: |r| = 1 and r·d = 0."""
    real, dual = np.array(coefficients[:4]), np.array(coefficients[4:])
    norm = float(np.linalg.norm(real))
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        raise ValueError(f"{who}: dual_quaternion rotation part has norm {norm:.9g}, not 1 (not a rigid transform)")
    if abs(float(real @ dual)) > UNIT_TOLERANCE:
        raise ValueError(f"{who}: dual_quaternion is not a rigid transform (r·d = {float(real @ dual):.3g}, not 0)")


def check_pose_text_fields(name: object, time: object, robot_model: object, robot_serial: object,
                           note: object) -> None:
    """Check the text fields of a pose; ValueError naming the pose.

    ValueError (naming the pose) unless the text fields of a pose are valid: name, UTC time, known model,
    serial text or null, note text."""
    problem = name_problem(name)
    if problem:
        raise ValueError(problem)
    who = f"pose {name!r}"
    if robot_model not in MODEL_NAMES:
        raise ValueError(f"{who}: robot_model {robot_model!r} is not one of {', '.join(MODEL_NAMES)}")
    if robot_serial is not None and not isinstance(robot_serial, str):
        raise ValueError(f"{who}: robot_serial must be text or null")
    if not isinstance(note, str):
        raise ValueError(f"{who}: note must be text")
    for field, text in (("robot_serial", robot_serial), ("note", note)):
        problem = unstorable_text_problem(text, field)
        if problem:
            raise ValueError(f"{who}: {problem}")
    _check_utc_time(time, who)


_MODEL_NAME_SET = frozenset(MODEL_NAMES)


def text_fields_all_valid(names: Sequence[Any], times: Sequence[Any], robot_models: Sequence[Any],
                          robot_serials: Sequence[Any], notes: Sequence[Any]) -> bool:
    """Whether check_pose_text_fields passes for every pose of the lists.

    True only if check_pose_text_fields passes for every pose (the i-th of each list), decided on the lists at
    once: a big store's 10⁵ poses in a few C passes instead of a call each. False means some pose may fail (or
    has non-ASCII text, which this does not inspect): check them one by one for the message."""
    if not (all(type(name) is str for name in names) and all(type(note) is str for note in notes)
            and all(serial is None or type(serial) is str for serial in robot_serials)
            and _MODEL_NAME_SET.issuperset(robot_models)):
        return False
    # ASCII text holds no lone surrogate, and printable ASCII no control character
    joined = "".join(names)
    if not (joined.isascii() and joined.isprintable() and "".join(notes).isascii()
            and "".join(serial for serial in robot_serials if serial is not None).isascii()):
        return False
    if not (0 < min(map(len, names), default=1) and max(map(len, names), default=0) <= MAX_NAME_LENGTH
            and all(name == name.strip() for name in names)):
        return False
    try:
        return all(type(time) is str and parse_iso_time(time).utcoffset() == _NO_OFFSET for time in times)
    except ValueError:
        return False


@dataclasses.dataclass(frozen=True, slots=True)  # slots: a big store holds 10⁵ of them
class Pose:
    """One recorded TCP pose in the base frame (metres, radians); validated when built, so a Pose is always sound.

    `joints` is None for poses that did not come from a robot (e.g. imported thesis lines).

    Examples
    --------
    >>> from ur3dq.kinematics import robot_model
    >>> q = (0.0, -1.2, 1.0, -1.4, -1.57, 0.0)
    >>> pose = Pose.from_dual_quaternion("pick", robot_model("ur3").fk(q), "ur3", joints=q)
    >>> pose.name, len(pose.ur_pose), pose.joints == q
    ('pick', 6, True)
    >>> Pose.from_dual_quaternion("", pose.dq, "ur3")
    Traceback (most recent call last):
    ...
    ValueError: a pose name must not be empty
    """

    name: str
    time: str
    robot_model: str
    dual_quaternion: tuple[float, ...]
    ur_pose: tuple[float, ...]
    tcp_offset: tuple[float, ...] = (0.0,) * 6
    joints: tuple[float, ...] | None = None
    robot_serial: str | None = None
    note: str = ""

    def __post_init__(self) -> None:
        check_pose_text_fields(self.name, self.time, self.robot_model, self.robot_serial, self.note)
        who = f"pose {self.name!r}"
        set_field = object.__setattr__  # frozen dataclass: normalise fields once, here
        set_field(self, "dual_quaternion", _finite_vector(self.dual_quaternion, 8, "dual_quaternion", who))
        set_field(self, "ur_pose", _finite_vector(self.ur_pose, 6, "ur_pose", who))
        set_field(self, "tcp_offset", _finite_vector(self.tcp_offset, 6, "tcp_offset", who))
        if self.joints is not None:
            set_field(self, "joints", _finite_vector(self.joints, 6, "joints", who))
        _check_unit_dual_quaternion(self.dual_quaternion, who)
        from_vector = DualQuaternion.from_ur_pose(self.ur_pose)
        if not from_vector.is_close(self.dq, POSE_AGREEMENT_TOLERANCE, POSE_AGREEMENT_TOLERANCE):
            metres, radians = from_vector.distance(self.dq)
            raise ValueError(
                f"{who}: ur_pose and dual_quaternion disagree by {metres:.3g} m and {radians:.3g} rad"
            )

    @classmethod
    def checked(cls, name: str, time: str, robot_model: str, dual_quaternion: tuple[float, ...],
                ur_pose: tuple[float, ...], tcp_offset: tuple[float, ...], joints: tuple[float, ...] | None,
                robot_serial: str | None, note: str) -> Pose:
        """A Pose from fields the caller has already validated.

        A Pose whose fields the caller has already validated exactly as __post_init__ would, built without
        running those checks again.

        The store checks the numbers of a whole file as arrays, then the text with check_pose_text_fields: one
        Pose's own checks cost hundreds of times more than building it. Tuples of floats expected.
        """
        pose = object.__new__(cls)
        values = (name, time, robot_model, dual_quaternion, ur_pose, tcp_offset, joints, robot_serial, note)
        for field, value in zip(_FIELD_NAMES, values, strict=True):
            object.__setattr__(pose, field, value)   # the frozen dataclass's own way to set a field
        return pose

    @property
    def dq(self) -> DualQuaternion:
        """The pose as a DualQuaternion (σ = r + ε·½·t·r, TCP in the base frame)."""
        return DualQuaternion.from_array(self.dual_quaternion)

    @classmethod
    def from_dual_quaternion(cls, name: str, pose: DualQuaternion, robot_model: str, **fields: Any) -> Pose:
        """A Pose from a DualQuaternion (TCP in base); the UR pose vector is derived, the time defaults to now."""
        fields.setdefault("time", utc_now_iso())
        return cls(
            name=name,
            robot_model=robot_model,
            dual_quaternion=tuple(pose.to_array()),
            ur_pose=tuple(pose.to_ur_pose()),
            **fields,
        )

    def renamed(self, name: str) -> Pose:
        """The same pose under another name (validated)."""
        return dataclasses.replace(self, name=name)


_FIELD_NAMES = tuple(field.name for field in dataclasses.fields(Pose))


def next_free_name(prefix: str, taken: Iterable[str]) -> str:
    """`prefix-N` with N one more than the largest N already used with that prefix (1 if none)."""
    used = [0]
    for name in taken:
        head, dash, tail = name.rpartition("-")
        if dash and head == prefix and tail.isdigit():
            used.append(int(tail))
    return f"{prefix}-{max(used) + 1}"


def closest_name_text(name: str, names: Iterable[str], otherwise: str = "") -> str:
    """"; did you mean 'pick'?" when one of `names` is close to the mistyped `name`, else `otherwise`.

    >>> closest_name_text("pik", ["home", "pick", "place"])
    "; did you mean 'pick'?"
    """
    close = difflib.get_close_matches(name, list(names), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else otherwise


def numbering_prefix(name: str) -> str:
    """The name without a trailing `-N`, the stem that `next_free_name` numbers."""
    head, dash, tail = name.rpartition("-")
    return head if dash and head and tail.isdigit() else name

