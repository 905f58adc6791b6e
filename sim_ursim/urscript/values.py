"""URScript values in Python: numbers, booleans, strings, lists (Python lists) and poses (`Pose`)."""
import math


class ScriptError(Exception):
    """A URScript run-time error without a position (the interpreter adds the call's line and column)."""

    def __init__(self, text):
        super().__init__(text)
        self.text = text


class Pose(list):
    """A UR pose p[x, y, z, rx, ry, rz]: metres and a rotation vector in radians; always 6 floats."""

    def __init__(self, values):
        values = list(values)
        if len(values) != 6 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            raise ScriptError(f"runtime_error:a pose needs 6 numbers, got {to_str(values)}:")
        super().__init__(float(v) for v in values)


def copy_value(value: object) -> object:
    """A copy of `value` with URScript value semantics: lists and poses are copied (nested lists too)."""
    if isinstance(value, Pose):
        return Pose(value)
    if isinstance(value, list):
        return [copy_value(item) for item in value]
    return value


def truth(value: object) -> bool:
    """Boolean value of a condition: booleans and numbers (non-zero is True); ScriptError otherwise."""
    if isinstance(value, (bool, int, float)):
        return bool(value)
    raise ScriptError(f"runtime_error:type mismatch:expected a boolean, got {to_str(value)}:")


def _number_text(value: float) -> str:
    """A number as URScript's to_str prints it: integers without a point, floats in shortest form."""
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, int):
        return str(value)
    if math.isfinite(value) and value.is_integer() and abs(value) < 1e15:
        return f"{value:.1f}"
    return repr(value)


def to_str(value: object) -> str:
    """URScript text of a value: True/False, numbers, [a, b], p[x, y, z, rx, ry, rz], strings as they are."""
    if isinstance(value, str):
        return value
    if isinstance(value, Pose):
        return "p[" + ", ".join(_number_text(v) for v in value) + "]"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(to_str(v) for v in value) + "]"
    if isinstance(value, (int, float)):
        return _number_text(value)
    if value is None:
        return "None"
    return str(value)


def number_list(value: object, length: int, name: str) -> list[float]:
    """`value` (list or pose) as a list of `length` floats; ScriptError naming `name` otherwise."""
    if not isinstance(value, list) or len(value) != length:
        raise ScriptError(f"runtime_error:{name} must be a list of {length} numbers, got {to_str(value)}:")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise ScriptError(f"runtime_error:{name} must contain numbers only, got {to_str(value)}:")
    return [float(v) for v in value]
