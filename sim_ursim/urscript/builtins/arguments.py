"""Argument conversions shared by the built-in families: each raises ScriptError naming the argument.

Units are the controller's: metres, radians, seconds; poses are p[x, y, z, rx, ry, rz] with a rotation vector.
"""
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from sim_ursim import kinematics
from sim_ursim.urscript.values import Pose, ScriptError, number_list, to_str
from sim_ursim.vocabulary import CommandRefused

T = TypeVar("T")


def as_number(value: Any, name: str) -> float:
    """`value` as a float; ScriptError naming `name` unless it is a number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScriptError(f"runtime_error:{name} must be a number, got {to_str(value)}:")
    return float(value)


def as_integer(value: Any, name: str) -> int:
    """`value` as an int (integral floats accepted); ScriptError naming `name` otherwise."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ScriptError(f"runtime_error:{name} must be an integer, got {to_str(value)}:")
    return value


def as_pose_array(value: Any, name: str) -> np.ndarray:
    """`value` (pose or list of 6 numbers) as a float array of shape (6,)."""
    return np.array(number_list(value, 6, name))


def to_pose(array: Any) -> Pose:
    """A 6-vector as a URScript pose."""
    return Pose([float(v) for v in array])


def to_list(array: Any) -> list[float]:
    """A vector as a URScript list of floats."""
    return [float(v) for v in array]


def controller_call(function: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """Call a controller command, turning its refusals into script errors (the program stops, as on a robot)."""
    try:
        return function(*args, **kwargs)
    except (CommandRefused, kinematics.IKError, ValueError) as error:
        raise ScriptError(f"runtime_error:{error}:") from None
