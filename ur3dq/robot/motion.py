"""Motion timing: the trapezoidal profile of a UR movej and the time a driver may wait for it.

movej moves every joint on one synchronised trapezoidal profile led by the joint with the longest travel
(docs/conventions.md, "Motion facts"), so its duration is the trapezoid of the largest joint travel.
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from typing import cast

import numpy as np
import numpy.typing as npt

from ur3dq.array_types import FloatArray
from ur3dq.errors import SafetyCheckError

# The slider is never read as slower than this, so a slider at 0 yields a (long) finite timeout, not a hang.
MIN_SPEED_FRACTION = 0.05
#: Seconds a controller may take to start a short program it was sent (a loaded simulator parses slowly).
START_TIMEOUT = 5.0
#: ... and per byte of program text on top: the controller parses the whole program before it starts it. sim_ursim
#: parses about 0.6 MB per CPU second; this allows a tenth of that, for a loaded machine (1 MiB: 10.5 s more).
PARSE_SECONDS_PER_BYTE = 1e-5
#: The largest program ur3dq sends: a controller connection holds an incomplete program up to 4 MiB and 50,000
#: lines and drops a client that sends more (sim_ursim's primary intake, docs/architecture.md).
MAX_PROGRAM_BYTES = 4 * 1024 * 1024
MAX_PROGRAM_LINES = 50_000


def program_start_timeout(program: str) -> float:
    r"""Seconds to wait for a controller to start `program` (URScript text): START_TIMEOUT plus its parse time.

    >>> program_start_timeout("def p():\n  sleep(1)\nend\n")
    5.00024
    """
    return START_TIMEOUT + len(program.encode("utf-8")) * PARSE_SECONDS_PER_BYTE


def program_size_problem(program: str) -> str | None:
    r"""Why `program` is too large to send (its size and the limit), or None.

    >>> program_size_problem("x = 1\n" * 60_000)
    '60,000 lines (the limit is 50,000)'
    """
    size, lines = len(program.encode("utf-8")), len(program.splitlines())
    if size > MAX_PROGRAM_BYTES:
        return f"{size / 2 ** 20:.1f} MiB (the limit is {MAX_PROGRAM_BYTES / 2 ** 20:g} MiB)"
    if lines > MAX_PROGRAM_LINES:
        return f"{lines:,} lines (the limit is {MAX_PROGRAM_LINES:,})"
    return None


def refuse_oversize(program: str, name: str) -> None:
    """SafetyCheckError naming the size and the limit when `program` (named `name`) is too large to send."""
    too_large = program_size_problem(program)
    if too_large is not None:
        raise SafetyCheckError(f"program {name} is too large to send: {too_large} of program text a controller "
                               "connection holds at once; nothing was sent: run it in parts (run-poses --from/--to)")


def trapezoid_duration(distance: float, a: float, v: float) -> float:
    """Seconds for a rest-to-rest trapezoid over `distance` (≥ 0) with acceleration a and cruise speed v (> 0)."""
    if not (math.isfinite(distance) and distance >= 0):
        raise ValueError(f"distance must be finite and ≥ 0, got {distance!r}")
    if not (math.isfinite(a) and a > 0):
        raise ValueError(f"a (acceleration) must be finite and > 0, got {a!r}")
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"v (speed) must be finite and > 0, got {v!r}")
    if distance >= v * v / a:
        return distance / v + v / a
    return 2.0 * math.sqrt(distance / a)


def trapezoid_durations(distances: npt.ArrayLike, a: float | npt.ArrayLike, v: float | npt.ArrayLike) -> FloatArray:
    """trapezoid_duration of many distances at once.

    trapezoid_duration of every distance (N,) at once (the same arithmetic, element by element; a plan of 10⁵
    moves), with a and v numbers or (N,) arrays (each move its own): seconds (N,); ValueError as
    trapezoid_duration's for the first a, v or distance that is not finite and ≥ 0 (a and v: > 0)."""
    distance = np.asarray(distances, dtype=float)
    acceleration: float | FloatArray
    speed: float | FloatArray
    bad = ~(np.isfinite(distance) & (distance >= 0))
    if np.ndim(a) == 0 and np.ndim(v) == 0:   # a and v are checked even for no distance at all
        acceleration, speed = cast(float, a), cast(float, v)   # one number each (np.ndim 0), kept as given
        trapezoid_duration(float(distance[bad][0]) if bad.any() else 0.0, acceleration, speed)   # its checks, messages
    else:
        acceleration, speed = np.asarray(a, dtype=float), np.asarray(v, dtype=float)
        bad |= ~(np.isfinite(acceleration) & (acceleration > 0) & np.isfinite(speed) & (speed > 0))
        if bad.any():
            first = int(np.argmax(bad))
            trapezoid_duration(*(float(np.broadcast_to(value, distance.shape)[first])
                                 for value in (distance, acceleration, speed)))
    return np.where(distance >= speed * speed / acceleration, distance / speed + speed / acceleration,
                    2.0 * np.sqrt(distance / acceleration))


def leading_travel(q_from: npt.ArrayLike, q_to: npt.ArrayLike) -> float:
    """The largest joint travel |q_to − q_from| (radians): the joint that leads a movej."""
    return float(np.abs(np.subtract(q_to, q_from, dtype=float)).max())


def leading_travels(path: npt.ArrayLike) -> FloatArray:
    """leading_travel of each move along `path` (N, 6) rad, from row i to row i + 1: (N − 1,) (empty below 2 rows)."""
    path = np.asarray(path, dtype=float).reshape(-1, 6)
    return np.abs(np.diff(path, axis=0)).max(axis=1) if len(path) > 1 else np.zeros(0)


def movej_duration(q_from: npt.ArrayLike, q_to: npt.ArrayLike, a: float, v: float) -> float:
    """Seconds a movej from `q_from` to `q_to` takes at 100 % speed (trapezoid of the leading joint)."""
    return trapezoid_duration(leading_travel(q_from, q_to), a, v)


def path_duration(q_start: npt.ArrayLike, targets: Iterable[npt.ArrayLike], a: float, v: float) -> float:
    """Seconds for movej through `targets` from `q_start`, each stopping (an upper bound when moves blend)."""
    total, previous = 0.0, q_start
    for target in targets:
        total += movej_duration(previous, target, a, v)
        previous = target
    return total


def motion_timeout(duration: float, speed_fraction: float, margin_ratio: float = 0.5, margin_s: float = 1.0) -> float:
    """Seconds to wait for a motion of `duration` at 100 % when the speed slider reads `speed_fraction` (0..1)."""
    if not (math.isfinite(duration) and duration >= 0):
        raise ValueError(f"duration must be finite and ≥ 0, got {duration!r}")
    if not math.isfinite(speed_fraction):
        raise ValueError(f"speed_fraction must be finite, got {speed_fraction!r}")
    slowed = duration / max(min(speed_fraction, 1.0), MIN_SPEED_FRACTION)
    return slowed * (1.0 + margin_ratio) + margin_s
