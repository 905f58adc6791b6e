"""The units layer: typed values with and without units, in SI or the person's chosen units."""
import doctest
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

import ur3dq.units as units_module
from ur3dq.errors import UnreachablePoseError
from ur3dq.units import (
    ANGLE,
    ANGULAR_ACCELERATION,
    ANGULAR_SPEED,
    DURATION,
    LENGTH,
    LINEAR_ACCELERATION,
    LINEAR_SPEED,
    Measured,
    Units,
    parse,
    show,
    to_display,
    unit_label,
)

DEG = Units(angle="deg")
MM = Units(length="mm")


@pytest.mark.parametrize("text, kind, units, expected", [
    ("250mm/s", LINEAR_SPEED, Units(), 0.25),
    ("250 mm/s", LINEAR_SPEED, DEG, 0.25),
    ("0.25", LINEAR_SPEED, DEG, 0.25),              # --deg never changes a length
    ("250", LINEAR_SPEED, MM, 0.25),
    ("60deg/s", ANGULAR_SPEED, Units(), math.radians(60)),
    ("60°/s", ANGULAR_SPEED, Units(), math.radians(60)),
    ("60", ANGULAR_SPEED, DEG, math.radians(60)),
    ("1.5", ANGULAR_SPEED, Units(), 1.5),
    ("1.5rad/s", ANGULAR_SPEED, DEG, 1.5),
    ("-50mm", LENGTH, Units(), -0.05),
    ("-5cm", LENGTH, Units(), -0.05),
    ("5deg", ANGLE, Units(), math.radians(5)),
    ("5", ANGLE, DEG, math.radians(5)),
    ("5", ANGLE, Units(), 5.0),
    ("80deg/s^2", ANGULAR_ACCELERATION, Units(), math.radians(80)),
    ("80°/s²", ANGULAR_ACCELERATION, Units(), math.radians(80)),
    ("1200mm/s^2", LINEAR_ACCELERATION, Units(), 1.2),
    ("500ms", DURATION, DEG, 0.5),
    ("1e-3m", LENGTH, Units(), 1e-3),
    (".5", LENGTH, Units(), 0.5),
    (3, LENGTH, MM, 0.003),
])
def test_typed_values_become_si(text, kind, units, expected):
    assert parse(text, kind, units) == pytest.approx(expected, rel=1e-15, abs=0)


@pytest.mark.parametrize("text, kind, words", [
    ("250mm/s", ANGULAR_SPEED, ["--speed takes a joint speed", "'mm/s' is a unit of linear speed", "60deg/s"]),
    ("60deg/s", LINEAR_SPEED, ["'deg/s' is a unit of joint speed", "250mm/s"]),
    ("5 km", LENGTH, ["'km' is not a unit ur3dq knows"]),
    ("fast", LINEAR_SPEED, ["'fast' is not a linear speed", "250mm/s"]),
    ("nan", LENGTH, ["is not a distance"]),
    ("1e999", LENGTH, ["not a finite number"]),
    ("", LENGTH, ["is not a distance"]),
    (True, LENGTH, ["expected a distance"]),
    (float("inf"), LENGTH, ["not a finite number"]),
])
def test_wrong_values_are_refused_with_the_way_to_write_them(text, kind, words):
    with pytest.raises(ValueError) as raised:
        parse(text, kind, name="--speed")
    message = str(raised.value)
    assert "\n" not in message
    for word in words:
        assert word in message


@pytest.mark.parametrize("value, kind, units, text", [
    (0.25, LENGTH, MM, "250 mm"),
    (0.25, LINEAR_SPEED, MM, "250 mm/s"),
    (0.25, LINEAR_SPEED, Units(), "0.25 m/s"),
    (math.radians(60), ANGULAR_SPEED, DEG, "60 °/s"),
    (math.radians(80), ANGULAR_ACCELERATION, DEG, "80 °/s²"),
    (1.2, LINEAR_ACCELERATION, MM, "1200 mm/s²"),
    (1.0, ANGLE, Units(), "1 rad"),
])
def test_values_are_shown_in_the_chosen_units(value, kind, units, text):
    assert show(value, kind, units) == text


def test_labels_and_display_values_agree_with_show():
    assert unit_label(ANGULAR_SPEED, DEG) == "°/s"
    assert to_display(math.pi, ANGLE, DEG) == pytest.approx(180.0)


@given(value=st.floats(-1e3, 1e3, allow_nan=False),
       kind=st.sampled_from([LENGTH, ANGLE, LINEAR_SPEED, ANGULAR_SPEED, LINEAR_ACCELERATION, ANGULAR_ACCELERATION]),
       units=st.sampled_from([Units(), DEG, MM, Units("deg", "mm")]))
def test_what_is_shown_reads_back_as_the_same_value(value, kind, units):
    shown = show(value, kind, units, digits=12).replace(" ", "")
    assert parse(shown, kind, Units()) == pytest.approx(value, rel=1e-9, abs=1e-9)


def test_unknown_unit_choices_are_refused():
    with pytest.raises(ValueError, match="angle must be 'rad' or 'deg'"):
        Units(angle="grad")


def test_the_module_examples_run():
    assert doctest.testmod(units_module).failed == 0


@pytest.mark.parametrize("value, kind, units, text", [
    (0.84081, LENGTH, Units(), "0.8408 m"), (0.84081, LENGTH, Units(length="mm"), "840.8 mm"),
    (0.1358, ANGLE, Units(), "0.1358 rad"), (0.1358, ANGLE, Units(angle="deg"), "7.78 °"),
])
def test_a_measured_value_keeps_its_resolution_in_the_chosen_units(value, kind, units, text):
    assert Measured(value, kind, si_digits=4).shown(units) == text


def test_an_errors_measured_values_read_in_si_until_shown_in_a_persons_units():
    error = UnreachablePoseError("too far: {0} past {1}", measured=[Measured(0.0123, LENGTH), Measured(0.5, ANGLE)])
    assert str(error) == "too far: 0.0123 m past 0.5000 rad"
    wrapped = error.prefixed("pose '{odd}': ")     # a name with braces stays a name
    assert isinstance(wrapped, UnreachablePoseError)
    assert str(wrapped.shown_in(Units(angle="deg", length="mm"))) == "pose '{odd}': too far: 12.3 mm past 28.65 °"
    assert str(UnreachablePoseError("no values {here}").prefixed("p: ")) == "p: no values {here}"


@pytest.mark.parametrize("value, kind, units, shown", [
    (math.radians(60.16064), ANGULAR_SPEED, Units(angle="deg"), "60.16 °/s"),   # a move's speed, a jog's
    (0.1, ANGULAR_SPEED, Units(angle="deg"), "5.73 °/s"),
    (0.0123456, LENGTH, Units(length="mm"), "12.3 mm"), (0.5, DURATION, Units(), "0.5 s"),
    (0.25, LINEAR_SPEED, Units(length="mm"), "250 mm/s"), (1e-12, LENGTH, Units(length="mm"), "1e-09 mm"),
])
def test_every_value_is_shown_at_its_units_one_precision(value, kind, units, shown):
    assert show(value, kind, units) == shown


@pytest.mark.parametrize("text, bounds, said", [
    ("-5", {"above": 0.0}, "speed must be more than 0 °/s, got -5 °/s"),
    ("-5mm/s", {"above": 0.0}, "'mm/s' is a unit of linear speed"),
    ("1e300", {"at_least": 0.0, "at_most": 1.0}, "speed must be from 0 °/s to 57.3 °/s, got 1e300 °/s"),
    ("90deg/s", {"at_most": 1.0}, "speed must be at most 57.3 °/s, got 90deg/s"),
])
def test_a_value_out_of_its_bounds_is_named_as_typed_in_the_typed_units(text, bounds, said):
    with pytest.raises(ValueError) as refused:
        parse(text, ANGULAR_SPEED, Units(angle="deg"), "speed", **bounds)
    assert said in str(refused.value) and "0.0872" not in str(refused.value)
