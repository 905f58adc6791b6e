"""Click options and typed-input parsing shared by several command modules (so they never import each other)."""
from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np
from rich.console import Console

from ur3dq.cli.app import Settings
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.program.steps import MOVE_TYPES

MIN_SPEED = 1e-3           # rad/s: slower than this a move of one degree takes over 17 s; a typo, not a wish
MIN_ACCELERATION = 1e-3    # rad/s²
MAX_BLEND_RADIUS = 2.0     # metres, the driver's bound (ur3dq.robot.robot.MAX_BLEND_RADIUS)
DEFAULT_SPEED = 1.05         # rad/s, URScript's movej default
DEFAULT_ACCELERATION = 1.4   # rad/s²
# Negative numbers such as -90 are values here, not options.
NUMBERS_CONTEXT = {"ignore_unknown_options": True}
DEFAULT_MODEL = "ur3"   # the model of fk/ik without --model


def _set_flag(ctx, param, value):
    """Callback of the per-command --json/--deg: a flag given after the command counts like a global one."""
    if value:
        setattr(ctx.find_object(Settings), param.name, True)


def _set_value(ctx, param, value):
    """Callback of a per-command --host/--model/--backend/--store: given after the command, it counts like a
    global one (and wins over it, as the later word on the line)."""
    if value is not None:
        if param.name == "model":
            value = value.lower()
        setattr(ctx.find_object(Settings), param.name, value)


def global_options(command):
    """Accept --host, --model, --backend and --store after the command name too (`ur3dq sim start --model ur5e`)."""
    from ur3dq.kinematics import MODEL_NAMES

    for flag, name, kind, text in (
            ("--store", "store_path", click.Path(dir_okay=False, path_type=Path), "The JSON pose store."),
            ("--backend", "backend", click.Choice(["rtde", "urx"]), "Client library for state and programs."),
            ("--model", "model", click.Choice(MODEL_NAMES, case_sensitive=False), "Robot model."),
            ("--host", "host", str, "The robot or URSim to talk to.")):
        command = click.option(flag, name, type=kind, default=None, expose_value=False, callback=_set_value,
                               help=f"{text} (as before the command)")(command)
    return command


def deg_option(command):
    """Accept --deg after the command name too.

    Add --deg to a command too, so `ur3dq fk ... --deg` works as well as `ur3dq --deg fk ...` (and the global
    options, see global_options)."""
    command = click.option("--deg", "deg", is_flag=True, expose_value=False, callback=_set_flag,
                           help="Angles in degrees (input and display).")(command)
    return global_options(command)


def display_options(command):
    """Add --json and --deg to a command too (as well as before the command)."""
    command = click.option("--json", "json", is_flag=True, expose_value=False, callback=_set_flag,
                           help="Machine-readable JSON on stdout.")(command)
    return deg_option(command)


def ur_pose_from_input(values, deg: bool, name: str = "pose") -> np.ndarray:
    """A UR pose vector typed by the user (rotation vector in degrees when `deg`) in metres and radians."""
    if len(values) != 6:
        raise ValueError(f"{name}: expected 6 numbers x y z rx ry rz, got {len(values)}")
    pose = np.asarray(values, dtype=float)
    if deg:
        pose[3:] = np.radians(pose[3:])
    return pose


def angular_option(value: float | None, default: float, deg: bool) -> float:
    """An angular option's value in radians.

    An angular option (speed, acceleration, travel) in radians: `default` when not given, else the typed value,
    read as degrees when `deg` (so `--deg --speed 30` is 30°/s, never 30 rad/s)."""
    if value is None:
        return default
    return math.radians(value) if deg else value


def motion_options(command):
    """--speed, --acceleration and --max-travel, in radians (degrees with --deg); resolve with angular_option."""
    command = click.option(
        "--max-travel", type=float, default=None,
        help="Refuse a plan in which one move swings a joint further than this (rad, ° with --deg) "
             "[default: π rad].")(command)
    command = click.option(
        "--acceleration", type=float, default=None,
        help=f"Leading joint acceleration, rad/s² (°/s² with --deg), clamped to the model "
             f"[default: {DEFAULT_ACCELERATION} rad/s²].")(command)
    return click.option(
        "--speed", type=float, default=None,
        help=f"Leading joint speed, rad/s (°/s with --deg), clamped to the model [default: {DEFAULT_SPEED} rad/s]."
    )(command)


def clamp_to_model(value: float, limits, name: str, minimum: float = 0.0) -> tuple[float, bool]:
    """A speed or acceleration lowered to the slowest joint's limit.

    (value, clamped?) with `value` lowered to the slowest joint's limit; ValueError naming the valid range
    unless finite and ≥ `minimum` (> 0 when `minimum` is 0)."""
    limit = float(np.min(limits))
    if not (math.isfinite(value) and value > 0 and value >= minimum):
        raise ValueError(f"{name} must be a number in [{minimum:g}, {limit:g}] (larger values are lowered to "
                         f"{limit:g}), got {value!r}")
    return (limit, True) if value > limit else (value, False)


def speed_and_acceleration(model, speed: float, acceleration: float, err: Console) -> tuple[float, float]:
    """(a, v): --acceleration and --speed clamped to the model's slowest joint, saying so when they are lowered."""
    v, v_clamped = clamp_to_model(speed, model.max_joint_speed, "--speed (rad/s)", MIN_SPEED)
    a, a_clamped = clamp_to_model(acceleration, model.max_joint_acceleration, "--acceleration (rad/s²)",
                                  MIN_ACCELERATION)
    if v_clamped:
        err.print(f"--speed {speed} rad/s exceeds the {model.name}'s limit: using {v:.4f} rad/s")
    if a_clamped:
        err.print(f"--acceleration {acceleration} rad/s² exceeds the {model.name}'s limit: using {a:.4f} rad/s²")
    return a, v


def check_max_travel(max_travel: float) -> float:
    """--max-travel in radians if it is in (0, 2π]; ValueError naming the range (NaN would switch the check off)."""
    if not (math.isfinite(max_travel) and 0 < max_travel <= 2 * math.pi):
        raise ValueError(f"--max-travel must be an angle in (0, 2π] rad (0-360° with --deg), got {max_travel!r}")
    return max_travel


def check_blend(blend: float) -> float:
    """--blend in metres if it is in [0, MAX_BLEND_RADIUS]; ValueError naming the range."""
    if not (math.isfinite(blend) and 0 <= blend <= MAX_BLEND_RADIUS):
        raise ValueError(f"--blend must be a radius in [0, {MAX_BLEND_RADIUS:g}] metres, got {blend!r}")
    return blend


def placement_options(command):
    """--after M / --before M: where a new or moved step goes (default: the end)."""
    command = click.option("--before", metavar="M", help="Put it just before the step M.")(command)
    return click.option("--after", metavar="M", help="Put it just after the step M.")(command)


def waypoint_motion_options(command):
    """--move, --speed, --acceleration, --blend of a waypoint."""
    for option in (
        click.option("--blend", type=float, help="Blend radius (m) into the next waypoint."),
        click.option("--acceleration", type=float, help="rad/s² (joint) or m/s² (linear/process)."),
        click.option("--speed", type=float, help="rad/s (joint) or m/s (linear/process); clamped when planned."),
        click.option("--move", type=click.Choice(MOVE_TYPES), help="joint (movej), linear (movel), process (movep)."),
    ):
        command = option(command)
    return command


def cell_option(command):
    """--cell FILE (env UR3DQ_CELL): the cell the path check keeps the arm clear of."""
    return click.option("--cell", "cell_path", envvar="UR3DQ_CELL", type=click.Path(dir_okay=False, path_type=Path),
                        help="Cell file (JSON: floor, keep-out boxes, keep-in box, margin, tool; env UR3DQ_CELL). "
                             "See docs/cell-file.md.")(command)


def model_for(settings: Settings, fallback: str | None = None):
    """The kinematic model the options name (else `fallback`, else the UR3)."""
    return robot_model(settings.model or fallback or DEFAULT_MODEL)


def joints_from_input(values, deg: bool, name: str = "joints") -> np.ndarray:
    """Six joint angles typed by the user (degrees when `deg`) as radians; ValueError naming `name`."""
    if len(values) != 6:
        raise ValueError(f"{name}: expected 6 joint angles, got {len(values)}")
    q = np.radians(values) if deg else np.asarray(values, dtype=float)
    if not np.all(np.isfinite(q)):
        raise ValueError(f"{name}: every joint angle must be finite, got {list(values)}")
    return q


def joints_in_limits(model, q: np.ndarray, deg: bool, name: str = "joints") -> np.ndarray:
    """Typed joints, refused outside the model's limits.

    `q` if inside `model`'s joint limits, else ValueError naming the joint (with a --deg hint when the values
    were read as radians: `fk 0 -90 0 -90 0 0` is almost always meant in degrees)."""
    outside = (q < model.joint_lower) | (q > model.joint_upper)
    if outside.any():
        i = int(np.argmax(outside))
        hint = "" if deg else "; did you mean --deg?"
        shown = f"{math.degrees(q[i]):g}°" if deg else f"{q[i]:g} rad"
        raise ValueError(f"{name}: joint {i + 1} = {shown} is outside the {model.name}'s limits "
                         f"[{model.joint_lower[i]:g}, {model.joint_upper[i]:g}] rad{hint}")
    return q


def pose_from_input(values, deg: bool) -> DualQuaternion:
    """The target of `ik`: 6 numbers are a UR pose vector, 8 are dual-quaternion coefficients [r | d]."""
    if len(values) == 8:
        return DualQuaternion.from_array(values)
    if len(values) == 6:
        return DualQuaternion.from_ur_pose(ur_pose_from_input(values, deg))
    raise ValueError(f"pose: give 6 numbers (x y z rx ry rz) or 8 (dual-quaternion coefficients), got {len(values)}")
