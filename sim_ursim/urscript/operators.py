"""URScript binary operators on values (pure): arithmetic, comparison, equality of lists, xor.

`/` divides as real numbers (7 / 2 = 3.5), `%` keeps integers, both refuse a zero divisor; `+` also joins two
strings; comparisons need numbers (booleans count as 0/1). Errors are ScriptError (the interpreter adds the place).
"""
import operator

from sim_ursim.urscript.values import ScriptError, to_str, truth


def require_number(value: object, op: str) -> int | float:
    """`value` if it is an int/float (booleans count as numbers, as 0/1), else ScriptError."""
    if not isinstance(value, (int, float)):
        raise ScriptError(f"runtime_error:type mismatch:{op} needs a number, got {to_str(value)}:")
    return value


def _arithmetic(symbol, function):
    def apply(left, right):
        if isinstance(left, str) and isinstance(right, str) and symbol == "+":
            return left + right
        if isinstance(left, list) or isinstance(right, list):
            return _elementwise(symbol, apply, left, right)
        require_number(left, symbol)
        require_number(right, symbol)
        return function(left, right)

    return apply


def _elementwise(symbol, apply, left, right):
    """URScript array arithmetic: list op list (equal lengths) and list op number / number op list, element by
    element (URCL's External Control script extrapolates joints with `q + qd * steptime`)."""
    if isinstance(left, list) and isinstance(right, list):
        if len(left) != len(right):
            raise ScriptError(f"runtime_error:type mismatch:{symbol} needs lists of equal length, got "
                              f"{len(left)} and {len(right)}:")
        return [apply(a, b) for a, b in zip(left, right)]
    if isinstance(left, list):
        return [apply(a, right) for a in left]
    return [apply(left, b) for b in right]


def _divide(left, right):
    if right == 0:
        raise ScriptError("runtime_error:division by zero:")
    return left / right


def _modulo(left, right):
    if right == 0:
        raise ScriptError("runtime_error:division by zero:")
    return left % right


def _ordering(symbol, function):
    def apply(left, right):
        require_number(left, symbol)
        require_number(right, symbol)
        return function(left, right)

    return apply


def _equal(left, right):
    if isinstance(left, (list, tuple)) and isinstance(right, (list, tuple)):
        return len(left) == len(right) and all(_equal(a, b) for a, b in zip(left, right))
    return left == right


def _xor(left, right):
    return truth(left) != truth(right)


# Numbers on both sides (the common case): the operator itself, no type checks. Not / and %: they check for zero.
PLAIN_NUMBERS = (int, float)
NUMERIC_FAST_PATH = {
    "+": operator.add, "-": operator.sub, "*": operator.mul, "<": operator.lt, "<=": operator.le,
    ">": operator.gt, ">=": operator.ge, "==": operator.eq, "!=": operator.ne,
}

BINARY = {
    "+": _arithmetic("+", lambda a, b: a + b),
    "-": _arithmetic("-", lambda a, b: a - b),
    "*": _arithmetic("*", lambda a, b: a * b),
    "/": _arithmetic("/", _divide),
    "%": _arithmetic("%", _modulo),
    "<": _ordering("<", lambda a, b: a < b),
    "<=": _ordering("<=", lambda a, b: a <= b),
    ">": _ordering(">", lambda a, b: a > b),
    ">=": _ordering(">=", lambda a, b: a >= b),
    "==": _equal,
    "!=": lambda a, b: not _equal(a, b),
    "xor": _xor,
}
