"""The one units layer: every number a person types or reads goes through here.

ur3dq keeps SI everywhere inside (metres, radians, seconds and their rates); people type and read the units of the
pendant (mm, mm/s, °, °/s). A typed value either carries its unit (``250mm/s``, ``60deg/s``, ``-50mm``, ``5°``) or is
a bare number, read in the user's chosen units (:class:`Units`: SI, or degrees for angles under ``--deg``).

Examples
--------
>>> from ur3dq.units import Units, ANGULAR_SPEED, LENGTH, parse, show
>>> round(parse("60deg/s", ANGULAR_SPEED), 6)
1.047198
>>> parse("-50mm", LENGTH)
-0.05
>>> round(parse("60", ANGULAR_SPEED, Units(angle="deg")), 6)     # a bare number under --deg
1.047198
>>> show(0.25, LENGTH, Units(length="mm"))
'250 mm'
"""
from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from typing import TypeAlias

__all__ = [
    "ACCELERATION", "ANGLE", "ANGULAR_ACCELERATION", "ANGULAR_SPEED", "DURATION", "LENGTH", "LINEAR_ACCELERATION",
    "DISPLAY_DIGITS", "FINE", "LINEAR_SPEED", "SI", "SPEED", "Kind", "Measured", "Units", "angular_kind", "parse",
    "plain_number", "position_text", "show", "typed_text", "Wording", "to_display", "unit_label", "within", "worded",
]


@dataclasses.dataclass(frozen=True)
class Kind:
    """A physical quantity: its name in messages, its SI unit, and the units a person may type for it.

    ``units`` maps each accepted spelling to the factor that turns it into SI; ``angular`` says whether the
    user's angle preference applies to a bare number of this kind.
    """

    name: str
    si: str
    units: dict[str, float]
    angular: bool
    example: str


_DEG = math.pi / 180.0


def _spellings(base: dict[str, float], suffix: str, superscript: bool = False) -> dict[str, float]:
    """Each of `base`'s spellings followed by `suffix` (and `²` for `^2` when `superscript`)."""
    spelled = {name + suffix: factor for name, factor in base.items()}
    if superscript:
        spelled.update({name + suffix.replace("^2", "²"): factor for name, factor in base.items()})
    return spelled


_LENGTHS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}
_ANGLES = {"rad": 1.0, "deg": _DEG, "°": _DEG}

LENGTH = Kind("distance", "m", dict(_LENGTHS), False, "-50mm")
ANGLE = Kind("angle", "rad", dict(_ANGLES), True, "5deg")
LINEAR_SPEED = Kind("linear speed", "m/s", _spellings(_LENGTHS, "/s"), False, "250mm/s")
ANGULAR_SPEED = Kind("joint speed", "rad/s", _spellings(_ANGLES, "/s"), True, "60deg/s")
LINEAR_ACCELERATION = Kind("linear acceleration", "m/s²", _spellings(_LENGTHS, "/s^2", True), False, "1200mm/s^2")
ANGULAR_ACCELERATION = Kind("joint acceleration", "rad/s²", _spellings(_ANGLES, "/s^2", True), True, "80deg/s^2")
DURATION = Kind("duration", "s", {"s": 1.0, "ms": 1e-3}, False, "500ms")

# A move's speed is angular for a joint move and linear for a linear or process move: see angular_kind.
SPEED = {True: ANGULAR_SPEED, False: LINEAR_SPEED}
ACCELERATION = {True: ANGULAR_ACCELERATION, False: LINEAR_ACCELERATION}

#: Digits after the point a value shows with, per unit it is shown in: one display precision per quantity (0.01° /
#: 0.1 mm and the same resolution in the other units, 1 ms), for every message and readout.
DISPLAY_DIGITS = {"°": 2, "rad": 4, "mm": 1, "m": 4, "°/s": 2, "rad/s": 4, "mm/s": 1, "m/s": 4, "°/s²": 1,
                  "rad/s²": 3, "mm/s²": 0, "m/s²": 3, "s": 3}

_NUMBER = re.compile(r"\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S*)\s*\Z")
_ALL_KINDS = (LENGTH, ANGLE, LINEAR_SPEED, ANGULAR_SPEED, LINEAR_ACCELERATION, ANGULAR_ACCELERATION, DURATION)


def angular_kind(move: str) -> bool:
    """True when a move of type `move` ('joint', 'linear', 'process') takes angular speeds and accelerations."""
    return move == "joint"


@dataclasses.dataclass(frozen=True)
class Units:
    """The units a person chose: ``angle`` 'rad' or 'deg', ``length`` 'm' or 'mm'.

    A bare typed number is read in these units, and :func:`show` writes values in them. JSON output never uses
    them: it is SI whatever the person chose.
    """

    angle: str = "rad"
    length: str = "m"

    def __post_init__(self) -> None:
        if self.angle not in ("rad", "deg") or self.length not in ("m", "mm"):
            raise ValueError(f"units: angle must be 'rad' or 'deg' and length 'm' or 'mm', got {self!r}")

    def bare_unit(self, kind: Kind) -> str:
        """The unit a bare number of `kind` is read in and values of `kind` are shown in."""
        if kind is DURATION:
            return "s"
        base = self.angle if kind.angular else self.length
        if kind.si == "rad":
            return "°" if base == "deg" else "rad"
        if kind.si == "m":
            return base
        rate = kind.si[kind.si.index("/"):]
        return ("°" if base == "deg" else base) + rate


def _a(noun: str) -> str:
    """`noun` with its indefinite article: 'an angle', 'a distance'."""
    return ("an " if noun[0] in "aeiou" else "a ") + noun


def _kind_named_by(unit: str) -> Kind | None:
    return next((kind for kind in _ALL_KINDS if unit in kind.units), None)


def parse(text: str | float | int, kind: Kind, units: Units = Units(), name: str = "value", *,
          above: float | None = None, at_least: float | None = None, at_most: float | None = None) -> float:
    """The SI value of `text`, a number a person typed for a quantity of `kind`.

    Parameters
    ----------
    text : str or number
        ``"250mm/s"``, ``"60 deg/s"``, ``"-50mm"``, ``"5°"``, or a bare number (``"0.05"``, ``0.05``), which is
        read in `units` (degrees for angles, speeds and accelerations of angular kinds under ``Units(angle='deg')``).
    kind : Kind
        What the number is (``LENGTH``, ``ANGULAR_SPEED``, ...).
    units : Units
        The person's chosen units, for bare numbers.
    name : str
        The option or field the value came from, named in the error.
    above, at_least, at_most : float, optional
        Bounds (SI) the value must keep: a value outside them is refused naming the value as typed and the bounds
        in `units` (``speed must be more than 0 °/s, got -5 °/s``), never in SI.

    Returns
    -------
    float
        The value in SI (m, rad, m/s, rad/s, m/s², rad/s², s).

    Raises
    ------
    ValueError
        One line naming `name`, what was typed, and how to write it: not a number, NaN or infinite, or a unit of
        another kind (``--speed 250mm/s`` on a joint move).
    """
    if isinstance(text, bool):
        raise ValueError(f"{name}: expected {_a(kind.name)} such as {kind.example}, got {text!r}")
    if isinstance(text, (int, float)):
        value, unit = float(text), ""
    else:
        match = _NUMBER.match(str(text))
        if match is None:
            raise ValueError(f"{name}: {text!r} is not {_a(kind.name)}; write a number with a unit, such as "
                             f"{kind.example} (units: {', '.join(kind.units)})")
        value, unit = float(match.group(1)), match.group(2)
    if not math.isfinite(value):
        raise ValueError(f"{name}: {text!r} is not a finite number")
    if not unit:
        unit = units.bare_unit(kind)
    if unit not in kind.units:
        other = _kind_named_by(unit)
        what = f"{unit!r} is a unit of {other.name}" if other else f"{unit!r} is not a unit ur3dq knows"
        raise ValueError(f"{name} takes {_a(kind.name)} ({', '.join(kind.units)}), but {what}; for example "
                         f"{kind.example}")
    return within(value * kind.units[unit], text, kind, units, name, above=above, at_least=at_least, at_most=at_most)


def within(si: float, text: str | float | int, kind: Kind, units: Units = Units(), name: str = "value", *,
           above: float | None = None, at_least: float | None = None, at_most: float | None = None) -> float:
    """`si` (the value of what was typed, `text`) if it keeps the bounds (SI), else ValueError naming `name`, the
    bounds in `units` and the value as typed (typed_text): where the value was read before its bounds were known."""
    low_ok = (above is None or si > above) and (at_least is None or si >= at_least)
    if not (low_ok and (at_most is None or si <= at_most)):
        raise ValueError(f"{name} must be {_bounds(kind, units, above, at_least, at_most)}, got "
                         f"{typed_text(text, kind, units)}")
    return si


def _bounds(kind: Kind, units: Units, above: float | None, at_least: float | None, at_most: float | None) -> str:
    """'more than 0 mm/s', 'from 0 mm to 1000 mm', 'at most 2 s': the bounds in `units`."""
    low = None if at_least is None else show(at_least, kind, units)
    high = None if at_most is None else show(at_most, kind, units)
    if low is not None and high is not None:
        return f"from {low} to {high}"
    words = [f"more than {show(above, kind, units)}"] if above is not None else [f"at least {low}"] if low else []
    return " and ".join(words + ([f"at most {high}"] if high is not None else []))


def typed_text(text: str | float | int, kind: Kind, units: Units = Units()) -> str:
    """What a person typed for `kind`, with the unit a bare number is read in: ``'-5 °/s'``, ``'250mm/s'``.

    >>> typed_text("-5", ANGULAR_SPEED, Units(angle="deg")), typed_text(" 1e300mm", LENGTH)
    ('-5 °/s', '1e300mm')
    """
    typed = str(text).strip()
    match = _NUMBER.match(typed)
    return f"{typed} {units.bare_unit(kind)}" if match is not None and not match.group(2) else typed


def position_text(values: Sequence[float], units: Units = Units()) -> str:
    """A position (x, y, z in m) as every message writes it, at the display precision of its unit.

    >>> position_text((-0.37982, -0.11237, 0.3125), Units(length="mm"))
    '-379.8, -112.4, 312.5 mm'
    """
    label = unit_label(LENGTH, units)
    return ", ".join(f"{to_display(v, LENGTH, units):.{DISPLAY_DIGITS[label]}f}" for v in values) + f" {label}"


def plain_number(text: str | float | int, name: str = "value") -> float:
    """A number without a unit (a fraction, a coefficient, a count of something), as typed; ValueError naming
    `name` when it is not one, carries a unit, or is not finite.

    >>> plain_number("0.5")
    0.5
    """
    match = None if isinstance(text, bool) else _NUMBER.match(str(text))
    if match is None or match.group(2):
        raise ValueError(f"{name}: expected a plain number such as 0.5, got {text!r}")
    value = float(match.group(1))
    if not math.isfinite(value):
        raise ValueError(f"{name}: {text!r} is not a finite number")
    return value


def whole_number(text: object, name: str, low: int, high: int) -> int:
    """A count or a pin number as typed: digits only (an int passes as it is), within low..high; ValueError naming
    `name` and the range otherwise (a fraction, a blank, a unit, an exponent are refused, never rounded).

    >>> whole_number(" 3 ", "loops", 1, 1000)
    3
    >>> whole_number("2.5", "loops", 1, 1000)
    Traceback (most recent call last):
    ...
    ValueError: loops: '2.5' is not a whole number from 1 to 1000
    """
    shown = repr(text) if len(repr(text)) <= 24 else repr(text)[:20] + "…"
    problem = ValueError(f"{name}: {shown} is not a whole number from {low} to {high}")
    if isinstance(text, bool) or not isinstance(text, (str, int)):
        raise problem
    digits = str(text).strip()
    if not re.fullmatch(r"[+-]?[0-9]{1,18}", digits) or not low <= int(digits) <= high:
        raise problem
    return int(digits)


def to_display(value: float, kind: Kind, units: Units = Units()) -> float:
    """`value` (SI) in the unit `units` shows `kind` in (see :meth:`Units.bare_unit`)."""
    return value / kind.units[units.bare_unit(kind)]


def unit_label(kind: Kind, units: Units = Units()) -> str:
    """The unit `units` shows `kind` in, as a table heading or after a number ('mm/s', '°', 'rad/s²')."""
    return units.bare_unit(kind)


def show(value: float, kind: Kind, units: Units = Units(), digits: int | None = None) -> str:
    """`value` (SI) as a person reads it: the number in the chosen units and its unit (``'250 mm'``, ``'60 °/s'``).

    `digits` after the point, by default the unit's DISPLAY_DIGITS (0.1 mm / 0.01° resolution) without trailing
    zeros; a value too small to show so (not zero) keeps two significant digits, so that it does not read as 0, and
    one too large for any arm (a typo, a hostile file) is shown with its exponent, not as hundreds of digits.

    >>> show(0.1, ANGULAR_SPEED, Units(angle="deg")), show(0.5, DURATION), show(1e-12, LENGTH, Units(length="mm"))
    ('5.73 °/s', '0.5 s', '1e-09 mm')
    >>> show(1e300, LINEAR_SPEED, Units(length="mm"))
    '1e+303 mm/s'
    """
    shown = to_display(value, kind, units)
    label = unit_label(kind, units)
    if abs(shown) >= 1e9:
        text = f"{shown:.6g}"
    elif digits is None:
        text = f"{shown:.{DISPLAY_DIGITS.get(label, 4)}f}"
        if "." in text:
            text = text.rstrip("0").rstrip(".")
        if shown != 0 and float(text) == 0:
            text = f"{shown:.2g}"
        if text == "-0":
            text = "0"
    else:
        text = f"{shown:.{digits}f}"
    return f"{text} {label}"


#: The units a person reads without --deg or --mm (and a program reads an error's values in).
SI = Units()
#: The units small values read in whatever the person chose (clearances, blend radii, angles from a singularity):
#: mm and degrees, as on the pendant; a metre or a radian would put them behind "0.0".
FINE = Units(angle="deg", length="mm")


@dataclasses.dataclass(frozen=True)
class Measured:
    """A value inside a message (an error's text, a path-check problem), kept in SI until a person's units are known.

    `si_digits` digits after the point in SI; in other units as many as keep that resolution (4 in m are 1 in mm,
    4 in rad are 2 in °); None: as many as :func:`show` writes (no trailing zeros). A `fine` value is small (a
    clearance, an angle from a singularity): it reads in :data:`FINE` units whatever the person chose. Without its
    `unit` it is the number alone, as the first coordinates of a position whose last one carries the unit.

    >>> far = Measured(0.84081, LENGTH, si_digits=4)
    >>> str(far), far.shown(Units(length="mm"))
    ('0.8408 m', '840.8 mm')
    >>> Measured(0.1358, ANGLE, si_digits=4).shown(Units(angle="deg"))
    '7.78 °'
    >>> str(Measured(0.0123, LENGTH, si_digits=4, fine=True)), str(Measured(0.3, LENGTH, 3, unit=False))
    ('12.3 mm', '0.300')
    """

    value: float
    kind: Kind
    si_digits: int | None = 4
    fine: bool = False
    unit: bool = True

    def shown(self, units: Units = Units()) -> str:
        """The value in `units` (in FINE units when it is `fine`), with its unit unless it goes without."""
        units = FINE if self.fine else units
        digits = None
        if self.si_digits is not None:
            digits = max(0, self.si_digits - round(math.log10(to_display(1.0, self.kind, units))))
        text = show(self.value, self.kind, units, digits)
        return text if self.unit else text.rsplit(" ", 1)[0]

    def __str__(self) -> str:
        return self.shown()


#: A message with values in it, as it is carried from one message into another: (units.worded text, its values).
Wording: TypeAlias = tuple[str, tuple[Measured, ...]]


def worded(text: str, measured: Sequence[Measured], units: Units = Units()) -> str:
    """`text` with its placeholders ``{0}``, ``{1}``, ... replaced by the `measured` values shown in `units`.

    The one way a message with values in it (an error's, a path-check problem's) is written for a person: the
    values stay SI until then. Braces meant as text are doubled in `text`, values or not (ur3dq.errors.literal).

    >>> worded("{0} inside the box (margin {1})", [Measured(0.012, LENGTH, 3, fine=True),
    ...                                            Measured(0.01, LENGTH, 3, fine=True)])
    '12 mm inside the box (margin 10 mm)'
    """
    return text.format(*(value.shown(units) for value in measured))
