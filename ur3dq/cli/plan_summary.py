"""The few lines run-poses shows above its question: what the plan does, how long, how far, whether the path check
passed and what was lowered, so the question and its summary fit a 24-row terminal (the full plan: --plan)."""
from __future__ import annotations

import dataclasses
import math
import textwrap
from collections.abc import Sequence

from ur3dq.cli.display import count_text
from ur3dq.program.plan import PlannedStep
from ur3dq.program.steps import Step, Wait, WaitInput
from ur3dq.replay import PlanStep
from ur3dq.units import ANGLE, DURATION, LENGTH, Units, show

WIDTH = 80          # columns of the smallest terminal the question must fit
MAX_WARNINGS = 4   # warning lines shown above the question; the rest are counted (the full plan lists them)


@dataclasses.dataclass(frozen=True)
class PlanFigures:
    """What a plan does, in SI: step and move counts, time at 100 % speed (None when the start is unknown; timed
    waits included, `waiting` of it), the longest the wait-for-input steps may add (`input_wait_limit`, their
    timeouts), the TCP's straight-line distance between targets, and the largest joint swing of one move and its
    step."""

    steps: int
    moves: int
    linear: int
    actions: int
    seconds: float | None
    tcp_metres: float
    largest_swing: float | None
    swing_step: str | None
    first: str
    last: str
    waiting: float = 0.0
    input_wait_limit: float = 0.0


def _largest(named_travels: list[tuple[str, float | None]]) -> tuple[float | None, str | None]:
    known = [(travel, name) for name, travel in named_travels if travel is not None]
    if not known:
        return None, None
    travel, name = max(known)
    return travel, name


def wait_time(step: Step) -> tuple[float | None, float | None]:
    """(seconds, at most seconds) a step that does not move holds the program: a wait its `seconds` (both), a
    wait for an input none known but at most its timeout, any other step (None, None).

    >>> wait_time(Wait("settle", 2.0)), wait_time(WaitInput("part", timeout=5.0))
    ((2.0, 2.0), (None, 5.0))
    """
    if isinstance(step, Wait):
        return step.seconds, step.seconds
    if isinstance(step, WaitInput):
        return None, step.timeout
    return None, None


def program_figures(plan: Sequence[PlannedStep]) -> PlanFigures:
    """The figures of a cell program's plan: its moves' times and its timed waits, and apart the timeouts of its
    waits for inputs."""
    moving = [p for p in plan if p.joints is not None]
    durations = [p.duration for p in moving]
    poses = [pose for pose in (p.pose for p in moving) if pose is not None]
    metres = math.fsum(a.distance(b)[0] for a, b in zip(poses, poses[1:], strict=False))
    swing, where = _largest([(p.name, p.travel) for p in moving])
    waits = [wait_time(p.step) for p in plan if p.joints is None]
    waiting = math.fsum(seconds for seconds, _ in waits if seconds is not None)
    input_waits = math.fsum(limit for seconds, limit in waits if seconds is None and limit is not None)
    known = [d for d in durations if d is not None]
    seconds = float(sum(known)) + waiting if len(known) == len(durations) and (known or waits) else None
    return PlanFigures(len(plan), len(moving), sum(p.move != "joint" for p in moving), len(plan) - len(moving),
                       seconds, float(metres), swing, where, plan[0].name, plan[-1].name, waiting, input_waits)


def replay_figures(steps: Sequence[PlanStep], loops: int = 1) -> PlanFigures:
    """The figures of a replay plan (movej to each pose; `loops` times)."""
    durations = [step.duration for step in steps]
    poses = [step.pose.dq for step in steps]
    metres = math.fsum(a.distance(b)[0] for a, b in zip(poses, poses[1:], strict=False))
    swing, where = _largest([(step.pose.name, step.travel) for step in steps])
    seconds = None if any(d is None for d in durations) else float(sum(d for d in durations if d is not None))
    return PlanFigures(len(steps) * loops, len(steps) * loops, 0, 0,
                       None if seconds is None else seconds * loops, float(metres) * loops, swing, where,
                       steps[0].pose.name, steps[-1].pose.name)


def summary_lines(figures: PlanFigures, verdict: str, warnings: Sequence[str], units: Units) -> list[str]:
    """The summary above the run question: 5 + MAX_WARNINGS lines or so, each wrapped within 80 columns (a
    continued line indented under its own), unless a step name alone is longer."""
    what = [count_text(figures.moves, "move")]
    if figures.linear:
        what.append(f"{figures.linear} linear")
    if figures.actions:
        what.append(count_text(figures.actions, "action"))
    time = "time unknown (no start)" if figures.seconds is None else f"about {figures.seconds:.1f} s at 100 %"
    if figures.seconds is not None and figures.waiting:
        time += f" ({show(figures.waiting, DURATION)} of it waits)"
    if figures.input_wait_limit:
        time += f", plus up to {show(figures.input_wait_limit, DURATION)} waiting for inputs"
    lines = [f"Plan: {count_text(figures.steps, 'step')}, {figures.first!r} to {figures.last!r}",
             f"  {', '.join(what)}; {time}",
             f"  TCP travel {show(figures.tcp_metres, LENGTH, Units(units.angle, 'mm'), 0)} between targets"
             + ("" if figures.largest_swing is None else
                f"; largest joint swing {_angle(figures.largest_swing, units)} ({figures.swing_step!r})"),
             f"  {verdict}"]
    shown = list(warnings[:MAX_WARNINGS])
    if len(warnings) > MAX_WARNINGS:
        shown.append(f"... and {len(warnings) - MAX_WARNINGS} more (--plan lists them)")
    lines += [f"  Warning: {warning}" for warning in shown]
    lines.append("  The full plan and the check's table: --plan (or --dry-run to stop there).")
    return [part for line in lines for part in textwrap.wrap(line, WIDTH, subsequent_indent="    ",
                                                              break_long_words=False, break_on_hyphens=False)]


def _angle(radians: float, units: Units) -> str:
    return show(radians, ANGLE, units, 1 if units.angle == "deg" else 3) if math.isfinite(radians) else "?"
