"""Running a planned cell program on a Robot as ONE URScript program, watched step by step.

The program (ur3dq.program.script) reports each step it starts with a `ur3dq_step:` k key text on the primary
interface; the driver's motion watch passes every robot message to `StepWatch.note`, which calls `progress(k,
step)` as steps begin and turns a `ur3dq_fail:` k report (a wait-input timed out) into a ProgramError naming the
step. Everything else is the driver's: checks before sending, the watch to the end with the arm at the final
target, stopj on any fault or Ctrl-C, no re-send.

When a run ends early (Ctrl-C, a signal, any fault) the error that leaves `run_plan` carries a `ProgramStop`
(`error.program_stop`): the step that was running, where the arm came to rest, and the outputs the program had
switched on that are still on; the program can go on from that step (`run(..., start=stop.step_name)`, or
`ur3dq run-poses --resume`).
"""
from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from ur3dq.errors import ProgramError, RobotError, SafetyCheckError, add_note
from ur3dq.pathcheck import PathPlan, PathSegment
from ur3dq.program.path import path_plan_of
from ur3dq.program.plan import Defaults, PlannedStep, plan_program
from ur3dq.program.resolve import select_range
from ur3dq.program.script import FAIL_KEY, STEP_KEY, program_script
from ur3dq.program.steps import DigitalOut, Step, Wait, WaitInput
from ur3dq.robot import interrupts, primary, safety, state
from ur3dq.urscript import new_program_name

if TYPE_CHECKING:
    from ur3dq.robot.robot import Robot

#: progress(position, step): called as each step of a running program starts
Progress = Callable[[int, Step], None]

MAX_STATEMENT_SECONDS = 0.05   # each action's own time on the controller (a few control cycles), for the timeout
REST_TIMEOUT = 2.0             # s to wait for the arm to come to rest after a stop, before saying where it is
REST_SPEED = 1e-3              # rad/s: every joint slower than this is at rest
STALE_AGE = 0.5                # s: a state older than this when read is stale (the stream sends every 2-8 ms)


@dataclasses.dataclass(frozen=True)
class ProgramStop:
    """Where a program run ended early.

    position, step_name: the 1-based position and name of the step that was running as the program last reported
    it (the first step when it had reported none); joints (6,) rad and tcp_pose (UR pose vector) where the arm came
    to rest, None when the controller could not be read; outputs_on: the (family, pin) of each digital output the
    program had switched on that is still on (all it had switched on when the controller could not be read:
    `outputs_read` False); stale_for: None when the last state received was fresh, else its age (s): the stream
    went silent, so the arm was then where `joints` says and may have gone on, to a later step too.
    """

    position: int
    step_name: str
    joints: np.ndarray | None
    tcp_pose: np.ndarray | None
    outputs_on: tuple[tuple[str, int], ...]
    outputs_read: bool
    stale_for: float | None = None

    def outputs_text(self) -> str:
        """'tool output 0 and standard output 3 still on', or '' when none is."""
        if not self.outputs_on:
            return ""
        names = [f"{family} output {pin}" for family, pin in self.outputs_on]
        listed = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
        return f"{listed} {'still on' if self.outputs_read else 'may still be on'}"


class StepWatch:
    """Follow the step reports of one running program.

    Follows the step reports of one running program (positions first_position .. first_position+N−1);
    `done` once the program reported first_position+N, after its last step; `ended` once the controller's key
    message said that program (`program_name`, set by run_plan) stopped: only then are its reports known whole."""

    def __init__(self, plan: Iterable[PlannedStep], first_position: int = 1, progress: Progress | None = None) -> None:
        self.plan = list(plan)
        self.first = first_position
        self.progress = progress
        self.current: int | None = None      # index into plan of the step running now
        self.done = False
        self.program_name: str | None = None
        self.ended = False

    @property
    def position(self) -> int:
        """The 1-based position of the step running now (the first one before any report, the last once done)."""
        return self.first + (len(self.plan) - 1 if self.done else self.current or 0)

    def note(self, message: object) -> None:
        """Update from one robot message; ProgramError when the program reports a failed step."""
        text = getattr(message, "text", None)
        if not isinstance(text, str):
            return
        if self.program_name is not None and primary.is_program_stopped(message, self.program_name):
            self.ended = True
        for key in (STEP_KEY, FAIL_KEY):
            if text.startswith(key) and text[len(key):].strip().lstrip("-").isdigit():
                index = int(text[len(key):].strip()) - self.first
                step = self.plan[index].step if 0 <= index < len(self.plan) else None
                if key == FAIL_KEY and isinstance(step, WaitInput):
                    raise ProgramError(f"{step.who}: input {step.input} DI{step.pin} did not turn "
                                       f"{'on' if step.on else 'off'} within {step.timeout:g} s; the program stopped")
                if key == STEP_KEY:
                    if index >= len(self.plan):
                        self.done = True
                    elif index >= 0 and index != self.current:
                        self.current = index
                        if self.progress is not None:
                            self.progress(self.first + index, self.plan[index].step)


def expected_seconds(plan: Iterable[PlannedStep]) -> float:
    """An upper bound of the program's duration at 100 % speed: moves (each from rest), waits, input timeouts."""
    total = 0.0
    for planned in plan:
        if planned.duration is not None:
            total += planned.duration
        elif isinstance(planned.step, Wait):
            total += planned.step.seconds
        elif isinstance(planned.step, WaitInput):
            total += planned.step.timeout
        total += MAX_STATEMENT_SECONDS
    return total


def check_plan_for_robot(robot: Robot, plan: Iterable[PlannedStep], start_joints: npt.ArrayLike) -> None:
    """Check every joint target of a plan as the driver checks a motion.

    Every joint target inside the limits, FK-consistent with its target pose, and within the travel limit from
    the previous one (SafetyCheckError naming the step): the checks every driver motion gets."""
    previous = np.asarray(start_joints, dtype=float)
    for planned in plan:
        pose = planned.pose
        if planned.joints is None or pose is None:   # an action step
            continue
        who = planned.step.who
        try:
            safety.check_joint_limits(planned.joints, robot.model.joint_lower, robot.model.joint_upper, who)
            model = robot.model.with_tcp(planned.tcp_offset)
            safety.check_fk_consistency(model, planned.joints, pose, name=who)
            safety.check_travel(previous, planned.joints, robot.max_joint_travel, name=who)
        except ValueError as error:
            raise SafetyCheckError(str(error)) from None
        previous = planned.joints


def run_plan(robot: Robot, plan: Sequence[PlannedStep], first_position: int = 1, progress: Progress | None = None,
             watch: StepWatch | None = None) -> float:
    """Run a planned program on the robot as one URScript program.

    Run `plan` (PlannedStep list, planned from the arm's current joints) as one program; returns the wall time
    (s). `progress(position, step)` is called as each step starts (or give your own `watch`, a StepWatch of this
    plan, to ask it which step runs while the program runs). An error or interrupt that ends the run once the
    program was sent leaves with a ProgramStop as its `program_stop` and a note naming the step and the outputs
    left on; one before (a refused check) leaves as it came."""
    if not plan:
        raise ValueError("the program has no steps to run")
    start = robot.joints()
    check_plan_for_robot(robot, plan, start)
    final = next((p.joints for p in reversed(plan) if p.joints is not None), start)
    watch = watch or StepWatch(plan, first_position, progress)
    name = new_program_name("program")
    watch.program_name = name
    text = program_script(plan, program_name=name, first_position=first_position,
                          restore_tcp=tuple(robot.model.tcp.to_ur_pose()))
    sent = []
    try:
        return robot.run_script(name, text, final, expected_seconds(plan), on_message=watch.note,
                                reached_end=lambda: watch.done, path=_path_of(plan, start),
                                on_sent=lambda: sent.append(True))
    except BaseException as error:
        if sent:   # the program ran (or was sent): it ended early, at a step
            stop = program_stop(robot, watch)
            error.program_stop = stop   # type: ignore[attr-defined]
            add_note(error, f"(during step {stop.position} {stop.step_name!r}"
                           + (f"; {stop.outputs_text()})" if stop.outputs_on else ")"))
        raise


def program_stop(robot: Robot, watch: StepWatch) -> ProgramStop:
    """The ProgramStop of a run `watch` followed: its running step, and (once the arm is at rest, at most
    REST_TIMEOUT s) where the arm is and which of the outputs the program switched on are still on.

    Without the program's end in its reports (a frozen, late or dropped stream) the program may have run on past the
    last step reported, and what the controller's state shows may be from before: every output the program could
    have left on by then is named as one that may still be on."""
    index = watch.position - watch.first
    switched_on = outputs_switched_on(watch.plan[:index + 1])
    status = status_at_rest(robot)
    name = watch.plan[index].step.name
    if not watch.ended:
        later = [output for end in range(index + 1, len(watch.plan) + 1)
                 for output in outputs_switched_on(watch.plan[:end])]
        may_be_on = tuple(dict.fromkeys(switched_on + later))
        stale = None if status is None or status.age <= STALE_AGE else float(status.age)
        return ProgramStop(watch.position, name, None if status is None else status.joints,
                           None if status is None else status.tcp_pose, may_be_on, False, stale)
    if status is None:
        return ProgramStop(watch.position, name, None, None, tuple(switched_on), False)
    try:
        still_on = set(robot.io_state().outputs_on())
    except (RobotError, KeyboardInterrupt):
        return ProgramStop(watch.position, name, status.joints, status.tcp_pose, tuple(switched_on), False)
    return ProgramStop(watch.position, name, status.joints, status.tcp_pose,
                       tuple(output for output in switched_on if output in still_on), True)


def outputs_switched_on(plan: Sequence[PlannedStep]) -> list[tuple[str, int]]:
    """(family, pin) of the digital outputs `plan`'s steps leave on (switched on and not off again), in order."""
    last: dict[tuple[str, int], bool] = {}
    for planned in plan:
        if isinstance(planned.step, DigitalOut):
            key = (planned.step.output, planned.step.pin)
            last.pop(key, None)
            last[key] = planned.step.on
    return [output for output, on in last.items() if on]


@interrupts.taken_at_polls
def status_at_rest(robot: Robot) -> state.RobotStatus | None:
    """The robot's status once a fresh one shows every joint at rest (or the last one received after REST_TIMEOUT,
    its `age` telling how stale it is); None when it cannot be read."""
    deadline = time.monotonic() + REST_TIMEOUT
    try:
        while True:
            status = robot.state()
            at_rest = float(np.max(np.abs(status.joint_speeds))) < REST_SPEED and status.age <= STALE_AGE
            if at_rest or time.monotonic() > deadline:
                return status
            interrupts.poll(0.01)
    except (RobotError, KeyboardInterrupt):
        return None


def _path_of(plan: Sequence[PlannedStep], start: np.ndarray) -> PathPlan:
    """The PathPlan the driver's path check sees; a program without waypoints checks where the arm rests."""
    return path_plan_of(plan, start) or PathPlan(start, (PathSegment("(no motion)", target_joints=start),))


def run(robot: Robot, steps: Sequence[Step], defaults: Defaults | None = None, speed_scale: float = 1.0,
        start: str | None = None, end: str | None = None,
        progress: Progress | None = None) -> tuple[list[PlannedStep], float]:
    """Plan a cell program from the arm's joints and run it.

    The program runs as one URScript program, watched step by step; every target is checked first (limits, FK,
    travel, and the path check when the robot requires it). Also importable as ``ur3dq.program.run``.

    Parameters
    ----------
    robot : Robot
        A connected robot (``ur3dq.robot.connect``).
    steps : sequence of Step
        The whole program (``ur3dq.program.steps``); relative waypoints are resolved in it.
    defaults : Defaults, optional
        What a waypoint leaves unset.
    speed_scale : float
        0 < F ≤ 1, scales every speed.
    start, end : str, optional
        Run only the steps from the one named `start` to the one named `end`.
    progress : callable, optional
        ``progress(position, step)``, called as each step starts (positions count from 1 in the whole program).

    Returns
    -------
    (list of PlannedStep, float)
        The plan and the run's wall time in seconds.

    Examples
    --------
    >>> import ur3dq.program
    >>> from ur3dq.program.steps import Wait
    >>> with ur3dq.robot.connect(host) as robot:                       # doctest: +SKIP
    ...     plan, seconds = ur3dq.program.run(robot, [Wait("settle", 0.5)])
    """
    part = select_range(steps, start, end)
    first = [s.name for s in steps].index(part[0].name) + 1
    plan = plan_program(robot.model, part, robot.joints(), defaults or Defaults(), speed_scale,
                        max_joint_travel=robot.max_joint_travel, resolve_from=steps)
    if not math.isfinite(expected_seconds(plan)):
        raise ValueError("the program's duration is not finite")
    return plan, run_plan(robot, plan, first, progress)

