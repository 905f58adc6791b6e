"""Click options and typed-input parsing shared by several command modules (so they never import each other).

Every number a person types for a physical quantity goes through ur3dq.units: an option declared with
:class:`Quantity` (one kind: `--z -50mm`, `--rx 5deg`) is SI by the time the command sees it; one declared with
:class:`Typed` (a waypoint's `--speed`, whose kind depends on its move type) is a :class:`TypedValue` the command
turns into SI once it knows the kind. Both read a bare number in the person's units (--deg, --mm), which the
per-command flags set before any other option is read (they are eager), wherever they stand on the line.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click
import numpy as np

from ur3dq.cli.app import HOST, Settings
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.kinematics.models import URModel
from ur3dq.program.steps import MAX_BLEND_M, MOVE_TYPES
from ur3dq.units import (
    ANGLE,
    ANGULAR_ACCELERATION,
    ANGULAR_SPEED,
    LENGTH,
    LINEAR_ACCELERATION,
    LINEAR_SPEED,
    SI,
    Kind,
    Units,
    parse,
    plain_number,
    show,
    within,
)

if TYPE_CHECKING:
    from rich.console import Console

F = TypeVar("F", bound=Callable[..., Any])

MIN_SPEED = 1e-3           # rad/s: slower than this a move of one degree takes over 17 s; a typo, not a wish
MIN_ACCELERATION = 1e-3    # rad/s²
DEFAULT_SPEED = 1.05         # rad/s, URScript's movej default
DEFAULT_ACCELERATION = 1.4   # rad/s²
# Negative numbers such as -90 are values here, not options.
NUMBERS_CONTEXT = {"ignore_unknown_options": True}
DEFAULT_MODEL = "ur3"   # the model of fk/ik without --model


def units_of(ctx: click.Context | None) -> Units:
    """The units the command line chose so far (--deg, --mm before or after the command name)."""
    settings = ctx.find_object(Settings) if ctx is not None else None
    return settings.units if settings is not None else Units()


def _option_name(param: click.Parameter | None) -> str:
    if param is None:
        return "value"
    if isinstance(param, click.Option) and param.opts:
        return max(param.opts, key=len)
    return (param.human_readable_name or "value").upper()


class Quantity(click.ParamType):  # type: ignore[type-arg, unused-ignore]  # generic only in newer click
    """A click type for one physical quantity: a number with or without its unit, converted to SI.

    A bare number is read in the person's units (degrees under --deg for angular kinds, mm under --mm for
    lengths); `250mm/s`, `60deg/s`, `-50mm`, `5deg` say their own unit. A value that is not one is refused with
    a ValueError naming the option and an example (exit 4, one line).
    """

    def __init__(self, kind: Kind, bare_limit: tuple[float, str, str] | None = None, most: float | None = None
                 ) -> None:
        self.kind = kind
        self.name = kind.name
        self.bare_limit = bare_limit   # (SI limit, its words, the unit likely meant) for a bare number
        self.most = most   # SI: the largest value the option takes (a bare number past it is offered no "if meant")

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        """What --help shows after the option: the quantity (DISTANCE, ANGLE, SPEED, ...)."""
        return self.kind.name.split()[-1].upper()

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> float:
        if isinstance(value, float) and not isinstance(value, bool):
            return value  # already SI: a default given in code, or a value converted before
        units, name = units_of(ctx), _option_name(param)
        si = parse(value, self.kind, units, name)
        if self.bare_limit is not None and abs(si) > self.bare_limit[0] and _is_bare(value):
            limit, words, meant = self.bare_limit
            unit = units.bare_unit(self.kind)
            raise ValueError(f"{name} {value}: a bare number is read in {unit}, and {value} {unit} is more than "
                             f"{words}; {self._way_on(value, meant, si, units, name)}")
        return si

    def _way_on(self, value: str, meant: str, si: float, units: Units, name: str) -> str:
        """What to type instead of a bare `value` (`si` as read) past the bare limit: with the unit likely `meant`,
        or as read, with its unit; each only if the option takes it (self.most)."""
        unit = units.bare_unit(self.kind)
        ways: dict[float, str] = {}   # SI value -> text: under --deg, 5deg and a bare 5 are one way, not two
        for text in (f"{value}{meant}", f"{value}{unit}"):
            value_si = parse(text, self.kind, units, name)
            if self.most is None or abs(value_si) <= self.most:
                ways.setdefault(value_si, text)
        if not ways:
            return f"the most it takes is {show(self.most or 0.0, self.kind, units)}"
        lines = [f"{text} if that is meant" if value_si == si else text for value_si, text in ways.items()]
        return "type " + ", or ".join(lines)


#: A clearance or blend radius: a bare number over half a metre is millimetres typed without their unit.
SMALL_LENGTH = Quantity(LENGTH, (0.5, "half a metre", "mm"), most=MAX_BLEND_M)


def _is_bare(value: Any) -> bool:
    """Whether a typed value is a number without a unit."""
    try:
        plain_number(value)
    except ValueError:
        return False
    return True


@dataclasses.dataclass(frozen=True)
class TypedValue:
    """A value as typed, whose kind is known only later (a waypoint's speed: joint or linear), with the units
    the command line chose when it was typed."""

    text: str
    units: Units
    option: str

    def si(self, kind: Kind) -> float:
        """The value in SI as a quantity of `kind`; ValueError naming the option when its unit is of another
        kind."""
        return parse(self.text, kind, self.units, self.option)

    def within(self, si: float, kind: Kind, **bounds: float) -> float:
        """`si` (this value as `kind`) if it keeps units.within's `bounds`, else ValueError naming the option, the
        bounds in the typed units and the value as typed."""
        return within(si, self.text, kind, self.units, self.option, **bounds)


class Typed(click.ParamType):  # type: ignore[type-arg, unused-ignore]  # generic only in newer click
    """A click type for a quantity whose kind depends on other options (a speed: joint or linear move): the
    value's form is checked now (a number with a unit ur3dq knows), its kind when the command knows it."""

    name = "value"

    def __init__(self, kinds: Sequence[Kind]) -> None:
        self.kinds = tuple(kinds)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "V"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> TypedValue:
        if isinstance(value, TypedValue):
            return value
        typed = TypedValue(str(value), units_of(ctx), _option_name(param))
        errors = []
        for kind in self.kinds:   # it must be a value of one of the kinds
            try:
                typed.si(kind)
                return typed
            except ValueError as error:
                errors.append(error)
        if len(self.kinds) == 1:
            raise errors[0]
        kinds = " nor ".join(("an " if kind.name[0] in "aeiou" else "a ") + kind.name for kind in self.kinds)
        examples = " or ".join(kind.example for kind in self.kinds)   # the move type is not known yet: name both
        raise ValueError(f"{typed.option}: {typed.text!r} is neither {kinds}; for example {examples}")


def _set_flag(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    """Callback of the per-command --json/--deg/--mm: a flag given after the command counts like a global one."""
    if value:
        setattr(ctx.find_object(Settings), param.name or "", True)


def _set_value(ctx: click.Context, param: click.Parameter, value: Any) -> None:
    """Callback of a per-command --host/--model/--backend/--store: given after the command, it counts like a
    global one (and wins over it, as the later word on the line)."""
    settings = ctx.find_object(Settings)
    if value is not None and settings is not None:
        if param.name == "model":
            value = value.lower()
        if param.name == "host":
            settings.host_source = "option"
        setattr(settings, param.name or "", value)


def global_options(command: F) -> F:
    """Accept --host, --model, --backend and --store after the command name too (`ur3dq sim start --model ur5e`)."""
    from ur3dq.kinematics import MODEL_NAMES

    for flag, name, kind, text in (
            ("--store", "store_path", click.Path(dir_okay=False, path_type=Path), "The JSON pose store."),
            ("--backend", "backend", click.Choice(["rtde", "urx"]), "Client library for state and programs."),
            ("--model", "model", click.Choice(MODEL_NAMES, case_sensitive=False), "Robot model."),
            ("--host", "host", HOST, "The robot or URSim to talk to.")):
        command = click.option(flag, name, type=kind, default=None, expose_value=False, callback=_set_value,
                               hidden=True, help=f"{text} (as before the command)")(command)
    return command


def deg_option(command: F) -> F:
    """Accept --deg and --mm after the command name too.

    `ur3dq fk ... --deg` works as well as `ur3dq --deg fk ...` (and the global options, see global_options).
    Eager: they are read before any number on the line, wherever they stand."""
    command = click.option("--mm", "mm", is_flag=True, expose_value=False, callback=_set_flag, is_eager=True,
                           help="Bare lengths in mm (typed and shown).")(command)
    command = click.option("--deg", "deg", is_flag=True, expose_value=False, callback=_set_flag, is_eager=True,
                           help="Bare angles in degrees (typed and shown).")(command)
    return global_options(command)


def display_options(command: F) -> F:
    """Add --json, --deg and --mm to a command too (as well as before the command)."""
    command = click.option("--json", "json", is_flag=True, expose_value=False, callback=_set_flag,
                           help="Machine-readable JSON on stdout (SI units).")(command)
    return deg_option(command)


def ur_pose_from_input(values: Sequence[float], name: str = "pose") -> np.ndarray:
    """A UR pose vector typed by the user, already SI (see pose_vector_type) as an array; ValueError naming
    `name` unless 6 numbers."""
    if len(values) != 6:
        raise ValueError(f"{name}: expected 6 numbers x y z rx ry rz, got {len(values)}")
    return np.asarray(values, dtype=float)


def pose_vector_type() -> click.Tuple:
    """The click type of 6 typed numbers X Y Z RX RY RZ: three lengths, then a rotation vector (angles)."""
    return click.Tuple([Quantity(LENGTH)] * 3 + [Quantity(ANGLE)] * 3)


def or_default(value: float | None, default: float) -> float:
    """A converted option's SI value, or `default` (SI) when it was not given."""
    return default if value is None else value


def motion_options(command: F) -> F:
    """--speed, --acceleration and --max-travel of a whole run (joint moves): typed with units or bare (rad/s,
    rad/s², rad; degrees under --deg); each SI or None."""
    command = click.option(
        "--max-travel", type=Quantity(ANGLE), default=None, metavar="ANGLE",
        help="Refuse a plan in which one move swings a joint further than this, e.g. 90deg [default: 180°].")(command)
    command = click.option(
        "--acceleration", type=Quantity(ANGULAR_ACCELERATION), default=None, metavar="A",
        help=f"Leading joint acceleration, e.g. 80deg/s^2 [default: {DEFAULT_ACCELERATION} rad/s²].")(command)
    return click.option(
        "--speed", type=Quantity(ANGULAR_SPEED), default=None, metavar="V",
        help=f"Leading joint speed, e.g. 60deg/s [default: {DEFAULT_SPEED} rad/s]; bare numbers rad/s (°/s "
             "under --deg).")(command)


def clamp_to_model(value: float, limits: np.ndarray, name: str, kind: Kind, units: Units,
                   minimum: float = 0.0) -> tuple[float, bool]:
    """A speed or acceleration lowered to the slowest joint's limit.

    (value, clamped?) with `value` (SI) lowered to the slowest joint's limit; ValueError naming the valid range
    in the person's units unless finite and ≥ `minimum` (> 0 when `minimum` is 0)."""
    limit = float(np.min(limits))
    if not (math.isfinite(value) and value > 0 and value >= minimum):
        raise ValueError(f"{name} must be in [{show(minimum, kind, units)}, {show(limit, kind, units)}] (larger "
                         f"values are lowered to {show(limit, kind, units)}), got {show(value, kind, units)}")
    return (limit, True) if value > limit else (value, False)


def speed_and_acceleration(model: URModel, speed: float, acceleration: float, err: Console,
                           units: Units = SI) -> tuple[float, float]:
    """(a, v): --acceleration and --speed (SI) clamped to the model's slowest joint, saying so when lowered."""
    v, v_clamped = clamp_to_model(speed, model.max_joint_speed, "--speed", ANGULAR_SPEED, units, MIN_SPEED)
    a, a_clamped = clamp_to_model(acceleration, model.max_joint_acceleration, "--acceleration",
                                  ANGULAR_ACCELERATION, units, MIN_ACCELERATION)
    if v_clamped:
        err.print(f"--speed {show(speed, ANGULAR_SPEED, units)} exceeds the {model.name}'s limit: using "
                  f"{show(v, ANGULAR_SPEED, units)}")
    if a_clamped:
        err.print(f"--acceleration {show(acceleration, ANGULAR_ACCELERATION, units)} exceeds the {model.name}'s "
                  f"limit: using {show(a, ANGULAR_ACCELERATION, units)}")
    return a, v


def check_max_travel(max_travel: float) -> float:
    """--max-travel in radians if it is in (0, 2π]; ValueError naming the range (NaN would switch the check off)."""
    if not (math.isfinite(max_travel) and 0 < max_travel <= 2 * math.pi):
        raise ValueError(f"--max-travel must be an angle in (0, 360°], got {math.degrees(max_travel):g}°")
    return max_travel


def check_blend(blend: float) -> float:
    """--blend in metres if it is in [0, MAX_BLEND_M] (a waypoint's own bound); ValueError naming the range."""
    if not (math.isfinite(blend) and 0 <= blend <= MAX_BLEND_M):
        raise ValueError(f"--blend must be a radius in [0, {MAX_BLEND_M * 1000:g} mm], got {blend * 1000:g} mm")
    return blend


def placement_options(command: F) -> F:
    """--after M / --before M: where a new or moved step goes (default: the end)."""
    command = click.option("--before", metavar="M", help="Put it just before the step M.")(command)
    return click.option("--after", metavar="M", help="Put it just after the step M.")(command)


WAYPOINT_SPEED = Typed([ANGULAR_SPEED, LINEAR_SPEED])
WAYPOINT_ACCELERATION = Typed([ANGULAR_ACCELERATION, LINEAR_ACCELERATION])


def waypoint_motion_options(command: F) -> F:
    """--move, --speed, --acceleration, --blend of a waypoint (TypedValue: speed and acceleration of the move's
    kind; all three bounded where the step is known, program_workflow.motion_from_options)."""
    for option in (
        click.option("--blend", type=Typed([LENGTH]), metavar="R",
                     help="Blend radius into the next waypoint, e.g. 20mm (bare: m, mm under --mm)."),
        click.option("--acceleration", type=WAYPOINT_ACCELERATION, metavar="A",
                     help="Joint move: e.g. 80deg/s^2 (bare rad/s²); linear/process: e.g. 1200mm/s^2 (bare "
                          "m/s²)."),
        click.option("--speed", type=WAYPOINT_SPEED, metavar="V",
                     help="Joint move: e.g. 60deg/s (bare rad/s, °/s under --deg); linear/process: e.g. 250mm/s "
                          "(bare m/s, mm/s under --mm)."),
        click.option("--move", type=click.Choice(MOVE_TYPES), help="joint (movej), linear (movel), process (movep)."),
    ):
        command = option(command)
    return command


def cell_option(command: F) -> F:
    """--cell FILE (env UR3DQ_CELL): the cell the path check keeps the arm clear of."""
    return click.option("--cell", "cell_path", envvar="UR3DQ_CELL", type=click.Path(dir_okay=False, path_type=Path),
                        help="Cell file (floor, keep-out boxes, keep-in box, margin, tool; env UR3DQ_CELL; "
                             "docs/cell-file.md).")(command)


def model_for(settings: Settings, fallback: str | None = None) -> URModel:
    """The kinematic model the options name (else `fallback`, else the UR3)."""
    return robot_model(settings.model or fallback or DEFAULT_MODEL)


def joints_from_input(values: Sequence[float], name: str = "joints") -> np.ndarray:
    """Six joint angles typed by the user (already radians: Quantity(ANGLE)) as an array; ValueError naming
    `name`."""
    if len(values) != 6:
        raise ValueError(f"{name}: expected 6 joint angles, got {len(values)}")
    q = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(q)):
        raise ValueError(f"{name}: every joint angle must be finite, got {list(values)}")
    return q


def joints_in_limits(model: URModel, q: np.ndarray, units: Units, name: str = "joints") -> np.ndarray:
    """Typed joints, refused outside the model's limits.

    `q` if inside `model`'s joint limits, else ValueError naming the joint (with a --deg hint when bare numbers
    were read as radians: `fk 0 -90 0 -90 0 0` is almost always meant in degrees)."""
    outside = (q < model.joint_lower) | (q > model.joint_upper)
    if outside.any():
        i = int(np.argmax(outside))
        hint = "" if units.angle == "deg" else "; did you mean --deg (or 90deg)?"
        raise ValueError(f"{name}: joint {i + 1} = {show(q[i], ANGLE, units)} is outside the {model.name}'s "
                         f"limits [{show(model.joint_lower[i], ANGLE, units)}, "
                         f"{show(model.joint_upper[i], ANGLE, units)}]{hint}")
    return q


def pose_from_input(values: Sequence[TypedValue]) -> DualQuaternion:
    """The target of `ik`: 6 values are a UR pose vector (3 lengths, 3 angles, units allowed), 8 are
    dual-quaternion coefficients [r | d] (plain numbers)."""
    if len(values) == 8:
        return DualQuaternion.from_array([plain_number(value.text, "pose coefficient") for value in values])
    if len(values) == 6:
        kinds = [LENGTH] * 3 + [ANGLE] * 3
        vector = [value.si(kind) for value, kind in zip(values, kinds, strict=True)]
        return DualQuaternion.from_ur_pose(np.array(vector))
    raise ValueError(f"pose: give 6 numbers (x y z rx ry rz) or 8 (dual-quaternion coefficients), got {len(values)}")

