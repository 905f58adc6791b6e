"""URScript maths built-ins: trigonometry, rounding, norms, text <-> number, bit lists (pure, no controller)."""
import math

import numpy as np

from sim_ursim.urscript.builtins.arguments import as_integer, as_number
from sim_ursim.urscript.builtins.registry import builtin, register
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import Pose, ScriptError, number_list, to_str


def _unary_math(name, function):
    """A built-in applying `function` to one number, ScriptError where it is undefined (e.g. sqrt(-1))."""

    def builtin(ctx: ThreadContext, x):
        try:
            return function(as_number(x, name))
        except (ValueError, OverflowError):
            raise ScriptError(f"runtime_error:{name}({to_str(x)}) is undefined:") from None

    builtin.__name__ = name
    return builtin


for _name, _function in (
    ("sin", math.sin), ("cos", math.cos), ("tan", math.tan), ("asin", math.asin), ("acos", math.acos),
    ("atan", math.atan), ("sqrt", math.sqrt), ("log", math.log), ("d2r", math.radians), ("r2d", math.degrees),
):
    register(_name, _unary_math(_name, _function))


@builtin
def atan2(ctx: ThreadContext, y, x):
    """atan2(y, x) in radians."""
    return math.atan2(as_number(y, "y"), as_number(x, "x"))


@builtin
def pow_(ctx: ThreadContext, base, exponent):
    """base ** exponent (ScriptError when undefined, e.g. a negative base with a fractional exponent)."""
    try:
        result = math.pow(as_number(base, "base"), as_number(exponent, "exponent"))
    except (ValueError, OverflowError):
        raise ScriptError(f"runtime_error:pow({to_str(base)}, {to_str(exponent)}) is undefined:") from None
    return result


@builtin
def norm(ctx: ThreadContext, a):
    """Absolute value of a number, Euclidean norm of a list, or norm of a pose's position."""
    if isinstance(a, Pose):
        return float(np.linalg.norm(a[:3]))
    if isinstance(a, list):
        return float(np.linalg.norm(number_list(a, len(a), "a")))
    return abs(as_number(a, "a"))


@builtin
def length(ctx: ThreadContext, value):
    """Number of elements of a list or characters of a string."""
    if not isinstance(value, (list, str)):
        raise ScriptError(f"runtime_error:length needs a list or string, got {to_str(value)}:")
    return len(value)


@builtin
def to_str_(ctx: ThreadContext, value):
    """URScript text of any value."""
    return to_str(value)


@builtin
def str_cat(ctx: ThreadContext, a, b):
    """Concatenation of the texts of a and b."""
    return to_str(a) + to_str(b)


@builtin
def to_num(ctx: ThreadContext, text):
    """Number written in `text` (int when it has no point or exponent)."""
    if not isinstance(text, str):
        raise ScriptError(f"runtime_error:to_num needs a string, got {to_str(text)}:")
    try:
        return int(text) if text.strip().lstrip("+-").isdigit() else float(text)
    except ValueError:
        raise ScriptError(f"runtime_error:to_num cannot read {text!r}:") from None


@builtin
def floor(ctx: ThreadContext, x):
    """Largest integer ≤ x (an int)."""
    return math.floor(as_number(x, "x"))


@builtin
def ceil(ctx: ThreadContext, x):
    """Smallest integer ≥ x (an int)."""
    return math.ceil(as_number(x, "x"))


@builtin
def round_(ctx: ThreadContext, x):
    """x rounded half away from zero (an int)."""
    x = as_number(x, "x")
    return int(math.floor(abs(x) + 0.5)) * (1 if x >= 0 else -1)


@builtin
def binary_list_to_integer(ctx: ThreadContext, bits):
    """Integer whose bit n is bits[n] (booleans, least significant first)."""
    if not isinstance(bits, list):
        raise ScriptError(f"runtime_error:binary_list_to_integer needs a list, got {to_str(bits)}:")
    return sum(1 << n for n, bit in enumerate(bits) if bit)


@builtin
def integer_to_binary_list(ctx: ThreadContext, x):
    """32 booleans, bit n of x (two's complement) at index n."""
    x = as_integer(x, "x") & 0xFFFFFFFF
    return [bool((x >> n) & 1) for n in range(32)]
