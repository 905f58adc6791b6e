"""The steps of a cell program: waypoints (recorded or relative) and a fixed, typed set of actions (pure data).

A program is an ordered list of steps, each with a unique name (the namespace recorded poses use too). Every step
validates itself when built and names itself in its errors, so a Step is always sound. Units: metres, radians,
seconds; speeds rad/s and rad/s² for joint moves, m/s and m/s² for linear/process moves; blend radius metres.
User text (names, messages) is data only: `ur3dq.program.script` never lets it become URScript code.
"""
from __future__ import annotations

import dataclasses
import math
import unicodedata
from typing import TypeGuard

from ur3dq.dualquat import DualQuaternion
from ur3dq.pose import Pose, name_problem, unstorable_text_problem
from ur3dq.real_numbers import is_number
from ur3dq.units import DURATION, show

MOVE_TYPES = ("joint", "linear", "process")    # movej, movel, movep
FRAMES = ("tool", "base")                       # the frame a relative waypoint's offset is expressed in
OUTPUT_KINDS = ("standard", "tool", "configurable")
# Pins a controller has (CB3 and e-Series): 8 standard and 8 configurable digital I/O, 2 tool digital I/O,
# 2 standard analog outputs.
PIN_COUNT = {"standard": 8, "tool": 2, "configurable": 8}
ANALOG_PIN_COUNT = 2
MAX_BLEND_M = 1.0          # larger than any UR's reach: a bigger radius is a typo (e.g. mm for m)
MAX_WAIT_S = 24 * 3600.0   # a day; longer is a typo
# One e-Series control cycle: a shorter wait is a typo (1e-300 s), and a controller sleeps at least a cycle anyway
# (a CB3's is 8 ms).
MIN_WAIT_S = 0.002
MAX_MESSAGE_LENGTH = 200   # URScript strings reach the controller log; the sanitiser allows ≤ 255
MAX_OFFSET_M = 5.0         # a relative waypoint further than this from its base is a typo
DEFAULT_WAIT_INPUT_TIMEOUT_S = 10.0
MAX_COMMENT_LENGTH = 1000  # a PolyScope comment or folder name is one line on the pendant
MAX_KEPT_SCRIPT_BYTES = 1024 * 1024  # URScript kept from a .urp; a controller parses far less in one program


def _positive(value: object, what: str, who: str, allow_none: bool = True,
              upper: float | None = None) -> float | None:
    """`value` as a float > 0 (≤ upper), None when allowed; ValueError naming `who` and `what`."""
    if value is None and allow_none:
        return None
    if not is_number(value):
        raise ValueError(f"{who}: {what} must be a number, got {value!r}")
    try:
        number = float(value)  # type: ignore[arg-type]  # is_number: a real number
    except OverflowError:
        raise ValueError(f"{who}: {what} {value!r} is out of range") from None
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"{who}: {what} must be a finite number > 0, got {value!r}")
    if upper is not None and number > upper:
        raise ValueError(f"{who}: {what} {number:g} is larger than {upper:g}")
    return number


def _pin(value: object, count: int, what: str, who: str) -> int:
    """`value` as a pin number 0..count-1; ValueError naming `who` with the valid range."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < count:
        raise ValueError(f"{who}: {what} pin {value!r} is out of range (0..{count - 1})")
    return value


def _flag(value: object, what: str, who: str) -> bool:
    """`value` if it is a bool (on/off), else ValueError."""
    if not isinstance(value, bool):
        raise ValueError(f"{who}: {what} must be true (on) or false (off), got {value!r}")
    return value


def _kind(value: object, who: str) -> str:
    if not isinstance(value, str) or value not in OUTPUT_KINDS:
        raise ValueError(f"{who}: I/O kind {value!r} is not one of {', '.join(OUTPUT_KINDS)}")
    return value


@dataclasses.dataclass(frozen=True)
class Motion:
    """How the arm gets to a waypoint: `move` (joint|linear|process) and optional speed, acceleration, blend.

    None means "the run's default" (run-poses --speed etc.), which keeps a v1 store replaying exactly as before.
    Checked when built (ValueError: an unknown move type, a speed, acceleration or blend that is not a positive
    finite number); the model's limits are checked where the model is known (ur3dq.program.plan.motion_ranges).

    >>> Motion("linear", speed=0.25).speed
    0.25
    >>> Motion("lin")
    Traceback (most recent call last):
    ...
    ValueError: motion: move 'lin' is not one of joint, linear, process
    """

    move: str = "joint"
    speed: float | None = None
    acceleration: float | None = None
    blend: float | None = None

    def __post_init__(self) -> None:
        if self.move not in MOVE_TYPES:
            raise ValueError(f"motion: move {self.move!r} is not one of {', '.join(MOVE_TYPES)}")
        if self.speed is None and self.acceleration is None and self.blend is None:
            return   # the run's defaults (a big store's plain waypoints): nothing to check
        blend = self.blend
        if blend is not None:
            if not is_number(blend) or not math.isfinite(float(blend)) or not 0 <= float(blend) <= MAX_BLEND_M:
                raise ValueError(f"motion: blend must be a radius 0..{MAX_BLEND_M:g} m, got {blend!r}")
            object.__setattr__(self, "blend", float(blend))
        object.__setattr__(self, "speed", _positive(self.speed, "speed", "motion"))
        object.__setattr__(self, "acceleration", _positive(self.acceleration, "acceleration", "motion"))

    def check(self, who: str) -> Motion:
        """This Motion (checked when built); kept for callers that name the step they check it for."""
        return self

    @property
    def is_default(self) -> bool:
        """True for a v1 waypoint: a joint move with the run's speed, acceleration and blend."""
        return self == DEFAULT_MOTION


DEFAULT_MOTION = Motion()


@dataclasses.dataclass(frozen=True, slots=True)
class Step:
    """Base of every step: a unique name (validated like a pose name)."""

    name: str

    @property
    def who(self) -> str:
        """How errors name this step."""
        return f"step {self.name!r} ({self.kind})"

    kind = "step"

    def _check_name(self) -> None:
        problem = name_problem(self.name)
        if problem:
            raise ValueError(problem.replace("a pose name", "a step name").replace("pose name", "step name"))


@dataclasses.dataclass(frozen=True, slots=True)  # slots: a big store holds 10⁵ of them
class Waypoint(Step):
    """A recorded pose and how to move there."""

    pose: Pose
    motion: Motion = DEFAULT_MOTION
    kind = "waypoint"

    def __post_init__(self) -> None:
        if not isinstance(self.pose, Pose):
            made = f"Pose.from_dual_quaternion({self.name!r}, pose, 'ur3', joints=...)"
            hint = (f"wrap it as {made}" if isinstance(self.pose, DualQuaternion) else
                    f"take one from the store (PoseStore.get(name)) or make one ({made})")
            raise ValueError(f"{self.who}: needs a recorded pose (ur3dq.pose.Pose), got "
                             f"{type(self.pose).__name__}: {hint}")
        if self.pose.name != self.name:
            raise ValueError(f"{self.who}: the pose is called {self.pose.name!r}")
        object.__setattr__(self, "motion", self.motion.check(self.who))

    @classmethod
    def of_checked_pose(cls, pose: Pose) -> Waypoint:
        """The plain joint waypoint of a Pose (its name, the default motion)."""
        return cls(pose.name, pose, DEFAULT_MOTION)


@dataclasses.dataclass(frozen=True)
class RelativeWaypoint(Step):
    """A waypoint at an offset from another waypoint.

    A waypoint at `offset` [dx, dy, dz, rx, ry, rz] (metres, rotation vector) from the waypoint `base`, in
    its tool frame (σ_base · offset) or the base frame (offset · σ_base, the rotation about the TCP's own
    position). It follows `base` when `base` is re-taught."""

    base: str = ""
    offset: tuple[float, ...] = (0.0,) * 6
    frame: str = "tool"
    motion: Motion = DEFAULT_MOTION
    note: str = ""
    kind = "relative waypoint"

    def __post_init__(self) -> None:
        self._check_name()
        if not isinstance(self.base, str) or name_problem(self.base):
            raise ValueError(f"{self.who}: base {self.base!r} is not a step name")
        if self.base == self.name:
            raise ValueError(f"{self.who}: is relative to itself")
        if self.frame not in FRAMES:
            raise ValueError(f"{self.who}: frame {self.frame!r} is not one of {', '.join(FRAMES)}")
        try:
            items = tuple(self.offset)
            offset = tuple(float(v) for v in items)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"{self.who}: offset must be 6 numbers, got {self.offset!r}") from None
        strange = [v for v in items if not is_number(v)]   # float() took "0.1" and True as well
        if strange:
            raise ValueError(f"{self.who}: offset must be 6 numbers, got {strange[0]!r} among them")
        if len(offset) != 6 or not all(math.isfinite(v) for v in offset):
            raise ValueError(f"{self.who}: offset must be 6 finite numbers, got {self.offset!r}")
        if math.dist(offset[:3], (0, 0, 0)) > MAX_OFFSET_M or math.dist(offset[3:], (0, 0, 0)) > 2 * math.pi:
            raise ValueError(f"{self.who}: offset {offset} is larger than {MAX_OFFSET_M} m or 2π rad")
        if not isinstance(self.note, str):
            raise ValueError(f"{self.who}: note must be text")
        problem = unstorable_text_problem(self.note, "note")
        if problem:
            raise ValueError(f"{self.who}: {problem}")
        object.__setattr__(self, "offset", offset)
        object.__setattr__(self, "motion", self.motion.check(self.who))


@dataclasses.dataclass(frozen=True)
class DigitalOut(Step):
    """Set a digital output (standard, tool or configurable) on or off."""

    output: str = "standard"
    pin: int = 0
    on: bool = True
    kind = "digital-out"

    def __post_init__(self) -> None:
        self._check_name()
        _kind(self.output, self.who)
        _pin(self.pin, PIN_COUNT[self.output], self.output, self.who)
        _flag(self.on, "the value", self.who)


@dataclasses.dataclass(frozen=True)
class AnalogOut(Step):
    """Set a standard analog output to `value`, a fraction 0..1 of its range (set_standard_analog_out)."""

    pin: int = 0
    value: float = 0.0
    kind = "analog-out"

    def __post_init__(self) -> None:
        self._check_name()
        _pin(self.pin, ANALOG_PIN_COUNT, "analog", self.who)
        if not is_number(self.value) or not 0.0 <= float(self.value) <= 1.0:
            raise ValueError(f"{self.who}: value must be a fraction 0..1 of the output's range, got {self.value!r}")
        object.__setattr__(self, "value", float(self.value))


@dataclasses.dataclass(frozen=True)
class Wait(Step):
    """Hold the program for `seconds` (MIN_WAIT_S to MAX_WAIT_S)."""

    seconds: float = 0.0
    kind = "wait"

    def __post_init__(self) -> None:
        self._check_name()
        seconds = _positive(self.seconds, "seconds", self.who, False, MAX_WAIT_S)
        if seconds is not None and seconds < MIN_WAIT_S:
            raise ValueError(f"{self.who}: a wait lasts at least {show(MIN_WAIT_S, DURATION)} (one control cycle), "
                             f"got {show(seconds, DURATION)}")
        object.__setattr__(self, "seconds", seconds)


@dataclasses.dataclass(frozen=True)
class WaitInput(Step):
    """Hold the program until a digital input is `on`; fail the run after `timeout` seconds."""

    input: str = "standard"
    pin: int = 0
    on: bool = True
    timeout: float = DEFAULT_WAIT_INPUT_TIMEOUT_S
    kind = "wait-input"

    def __post_init__(self) -> None:
        self._check_name()
        _kind(self.input, self.who)
        _pin(self.pin, PIN_COUNT[self.input], self.input, self.who)
        _flag(self.on, "the value", self.who)
        object.__setattr__(self, "timeout", _positive(self.timeout, "timeout", self.who, False, MAX_WAIT_S))


@dataclasses.dataclass(frozen=True)
class Message(Step):
    """A line of text for the log (textmsg); printable text only, sanitised again when generated."""

    text: str = ""
    kind = "message"

    def __post_init__(self) -> None:
        self._check_name()
        if not isinstance(self.text, str) or not self.text:
            raise ValueError(f"{self.who}: text must be non-empty text")
        if len(self.text) > MAX_MESSAGE_LENGTH:
            raise ValueError(f"{self.who}: text is longer than {MAX_MESSAGE_LENGTH} characters")
        if any(unicodedata.category(char).startswith("C") for char in self.text):
            raise ValueError(f"{self.who}: text contains control characters")


@dataclasses.dataclass(frozen=True)
class Comment(Step):
    """A note between the steps (a PolyScope comment, or the name of a folder whose nodes follow); does nothing.

    A waypoint before a comment keeps its blend: the comment is not an action.
    """

    text: str = ""
    kind = "comment"

    def __post_init__(self) -> None:
        self._check_name()
        if not isinstance(self.text, str) or len(self.text) > MAX_COMMENT_LENGTH:
            raise ValueError(f"{self.who}: text must be text of at most {MAX_COMMENT_LENGTH} characters")
        if any(unicodedata.category(char).startswith("C") for char in self.text):
            raise ValueError(f"{self.who}: text contains control characters")


@dataclasses.dataclass(frozen=True)
class KeptScript(Step):
    """URScript kept from a PolyScope program for nodes that have no step (`ur3dq import-urp --keep-script`).

    It runs as it is, where it stands: its motions are not planned, checked or path-checked, which every plan
    and run says. `origin` names the file and the node (`cell.urp: Robot Program/If digital_in[0]`).
    """

    script: str = ""
    origin: str = ""
    kind = "kept-script"

    def __post_init__(self) -> None:
        self._check_name()
        if not isinstance(self.script, str) or not self.script.strip():
            raise ValueError(f"{self.who}: script must be non-empty URScript text")
        if len(self.script) > MAX_KEPT_SCRIPT_BYTES:
            raise ValueError(f"{self.who}: script is larger than {MAX_KEPT_SCRIPT_BYTES // 1024} KiB")
        if not isinstance(self.origin, str) or len(self.origin) > MAX_COMMENT_LENGTH:
            raise ValueError(f"{self.who}: origin must be text of at most {MAX_COMMENT_LENGTH} characters")
        for what, text in (("script", self.script), ("origin", self.origin)):
            problem = unstorable_text_problem(text, what)
            if problem:
                raise ValueError(f"{self.who}: {problem}")


ACTION_TYPES = {cls.kind: cls for cls in (DigitalOut, AnalogOut, Wait, WaitInput, Message, Comment, KeptScript)}
WAYPOINT_TYPES = (Waypoint, RelativeWaypoint)


def is_waypoint(step: Step) -> TypeGuard[Waypoint | RelativeWaypoint]:
    """True for a step the arm moves to (recorded or relative)."""
    return isinstance(step, WAYPOINT_TYPES)


def describe(step: Step) -> str:
    """One short line saying what the step does (for tables; user text shown as typed)."""
    if isinstance(step, Waypoint):
        return _motion_text(step.motion)
    if isinstance(step, RelativeWaypoint):
        x, y, z = (v * 1000 for v in step.offset[:3])
        turn = "" if not any(step.offset[3:]) else " +rot"
        return f"{_motion_text(step.motion)} {step.base}{x:+.1f},{y:+.1f},{z:+.1f} mm {step.frame}{turn}"
    if isinstance(step, DigitalOut):
        return f"{step.output} DO{step.pin} {'on' if step.on else 'off'}"
    if isinstance(step, AnalogOut):
        return f"AO{step.pin} = {step.value:g}"
    if isinstance(step, Wait):
        return show(step.seconds, DURATION)
    if isinstance(step, WaitInput):
        return f"{step.input} DI{step.pin} {'on' if step.on else 'off'} ≤{show(step.timeout, DURATION)}"
    if isinstance(step, Message):
        return step.text
    if isinstance(step, Comment):
        return step.text
    if isinstance(step, KeptScript):
        lines = len(step.script.splitlines())
        return f"URScript kept from {step.origin} ({lines} lines, not path-checked)"
    raise TypeError(f"unknown step {step!r}")


def _motion_text(motion: Motion) -> str:
    parts = [motion.move]
    if motion.speed is not None:
        parts.append(f"v={motion.speed:g}")
    if motion.acceleration is not None:
        parts.append(f"a={motion.acceleration:g}")
    if motion.blend is not None:
        parts.append(f"r={motion.blend:g}")
    return " ".join(parts)
