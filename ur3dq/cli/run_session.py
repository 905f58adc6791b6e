"""`run-poses` moving the arm: the watched run with the operator's pause/resume/stop, and what is said when a run
ends early — which step was running, where the arm came to rest, the outputs the program had switched on that are
still on, and the exact command that goes on from there (`run-poses --resume`, with the state it needs written
beside the store: ur3dq.cli.resume_state).
"""
from __future__ import annotations

import dataclasses
import os
import shlex
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from ur3dq.cli.app import Cancelled, Settings, confirm
from ur3dq.cli.operator_controls import OperatorControls
from ur3dq.cli.resume_state import ResumeState, arm_identity, clear_resume_state, store_digest
from ur3dq.cli.signals import signal_name
from ur3dq.errors import RobotError, SafetyCheckError, StoreError, add_note
from ur3dq.program.plan import PlannedStep
from ur3dq.program.runner import STALE_AGE, ProgramStop, StepWatch, run_plan, status_at_rest
from ur3dq.store import DEFAULT_STORE_PATH
from ur3dq.units import ANGLE, LENGTH, Units, to_display


class OperatorStop(KeyboardInterrupt):
    """The operator stopped the run (the `s` key while it ran or was paused): handled like Ctrl-C."""


@dataclasses.dataclass(frozen=True)
class RunRecord:
    """What a stopped run's resume state keeps: `kind` ('program' or 'replay'), the run's last step (`end`, a
    program's --to), its `options`, and the store and arm it ran with (taken before the run: after a fault the
    controller may not answer)."""

    kind: str
    end: str | None
    options: dict[str, Any]
    store_digest: str
    arm: dict[str, Any]


def confirm_replacing_foreign_program(robot: Any, yes: bool) -> None:
    """Before a run sends its program: another program, running or paused on the controller (another client's, the
    pendant's), would be stopped and replaced by it (a controller runs one program at a time). Ask (default No), or
    refuse under `yes` (RobotError, exit 6): --yes answers the question about moving the arm, not this one."""
    status = robot.state()
    if not (status.program_running or status.program_paused):
        return
    try:
        dashboard = f" (dashboard: {robot.program_state()})"
    except RobotError:
        dashboard = ""
    found = f"another program is {'paused' if status.program_paused else 'running'} on the controller{dashboard}"
    if yes:
        raise RobotError(f"{found}: this run would stop and replace it, so nothing was sent; stop it first (at "
                         "the pendant, or `ur3dq robot stop`), or run without --yes to be asked")
    confirm(f"{found[0].upper()}{found[1:]}: stop it and run this one instead?", False, default=False)


def run_record(settings: Settings, robot: Any, kind: str, end: str | None, options: dict[str, Any],
               digest: str | None = None) -> RunRecord:
    """The RunRecord of a run about to start on `robot` (`digest`: the store's, taken when it was loaded)."""
    return RunRecord(kind, end, options, digest if digest is not None else store_digest(settings.store_path),
                     arm_identity(robot))


def run_program(settings: Settings, robot: Any, plan: Sequence[PlannedStep], first: int, program_length: int,
                record: RunRecord) -> float:
    """Run a planned cell program (positions first.. of a program of `program_length` steps) with the running
    step shown and the operator's controls; returns the wall time. A run that ends early says where and how to go
    on (resume state written), then its error leaves with that as a note; one that ends removes the resume state."""
    err = Console(stderr=True, highlight=False)
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
               TimeElapsedColumn())
    with Progress(*columns, console=err, transient=False) as progress:
        task = progress.add_task("starting", total=len(plan))

        def shown(position: int, step: Any) -> None:
            progress.update(task, description=escape(f"step {position}: {step.name} ({step.kind})"),
                            completed=position - first)

        watch = StepWatch(plan, first, shown)

        def describe() -> str:
            return step_text(watch.position, plan[watch.position - first].step, program_length)

        with OperatorControls(robot, progress.console, describe) as controls:
            failure: BaseException | None = None
            try:
                seconds = run_plan(robot, plan, first, watch=watch)
            except BaseException as error:
                if getattr(error, "program_stop", None) is None:
                    raise
                failure = error
            else:
                progress.update(task, completed=len(plan), description="done")
    if failure is not None:
        stop = failure.program_stop   # type: ignore[attr-defined]
        raise ended_early(settings, failure, stop, plan[stop.position - first].step, program_length, record,
                          controls) from None
    clear_resume_state(settings.store_path)
    return seconds


def step_text(position: int, step: Any, program_length: int) -> str:
    """"step 4 of 6, 'descend' (linear waypoint)" (or a replay's "move 2 of 5, to 'place'") for people."""
    if isinstance(step, _PoseMove):
        return f"move {position} of {program_length}, to {step.name!r}"
    motion = getattr(step, "motion", None)
    kind = f"{motion.move} {step.kind}" if motion is not None else step.kind
    return f"step {position} of {program_length}, {step.name!r} ({kind})"


def ended_early(settings: Settings, error: BaseException, stop: ProgramStop, step: Any, program_length: int,
                record: RunRecord, controls: OperatorControls | None = None, names: Sequence[str] = ()
                ) -> BaseException:
    """The error to raise for a run that ended early with `error` at `stop`: the report printed on stderr (step,
    where the arm rests, outputs left on, the command that goes on), the resume state written (removed when the
    operator quit), and the error's one line extended with the step, the outputs and that command."""
    err = Console(stderr=True, highlight=False)
    quit_run = controls is not None and controls.stop_choice == "quit"
    command = resume_command(settings)
    written = None if quit_run else _write_state(settings, error, stop, record, names, controls)
    err.print(f"Stopped during {escape(step_text(stop.position, step, program_length))}"
              + ("." if stop.stale_for is None else f", the last step the controller reported: its state stream then "
                 f"went silent ({stop.stale_for:.1f} s), so the program may have gone on to a later step."))
    err.print(where_text(stop, settings.deg))
    if stop.outputs_on:
        err.print(f"{stop.outputs_text().capitalize()} (switched on by the program).")
    if quit_run:
        clear_resume_state(settings.store_path)
        return Cancelled(f"quit during step {stop.position} {stop.step_name!r}: the run is abandoned (nothing to "
                         f"resume){'; ' + stop.outputs_text() if stop.outputs_on else ''}", deliberate=True)
    if written is None:
        err.print(f"To go on from step {stop.position}: {escape(command)}", soft_wrap=True)
    if not any(note.startswith("(during ") for note in getattr(error, "__notes__", ())):
        # the program runner names the step itself; a replay's move is named here
        add_note(error, f"(during {step_text(stop.position, step, program_length)})")
    if controls is not None and controls.stop_choice == "stop":
        error, cause = OperatorStop("stopped by the operator"), error
        for note in getattr(cause, "__notes__", ()):
            add_note(error, note)
    add_note(error, f"— to go on: {command}" if written is None else f"— no resume state: {written}")
    return error


def _write_state(settings: Settings, error: BaseException, stop: ProgramStop, record: RunRecord,
                 names: Sequence[str], controls: OperatorControls | None) -> str | None:
    """Write the resume state of `stop`; None, or why it could not be written."""
    if controls is not None and controls.stop_choice:
        reason = "stopped by the operator"
    elif isinstance(error, KeyboardInterrupt):
        reason = f"interrupted by {signal_name(error) or 'Ctrl-C (SIGINT)'}"
    else:
        reason = f"{type(error).__name__}: {error}"
    state = ResumeState(record.kind, stop.position, stop.step_name, record.end, tuple(names), record.options,
                        reason, record.store_digest, record.arm)
    try:
        state.write(settings.store_path)
    except StoreError as problem:
        return str(problem)
    return None


def where_text(stop: ProgramStop, deg: bool) -> str:
    """Where the arm came to rest: TCP position in mm, rotation vector and joints in ° (--deg) or rad."""
    if stop.joints is None or stop.tcp_pose is None:
        return "Where the arm is could not be read (the controller did not answer)."
    units = Units(angle="deg" if deg else "rad", length="mm")
    unit = "°" if deg else "rad"
    x, y, z = (to_display(float(value), LENGTH, units) for value in stop.tcp_pose[:3])
    rotation = " ".join(f"{to_display(float(value), ANGLE, units):.2f}" for value in stop.tcp_pose[3:])
    joints = " ".join(f"{to_display(float(value), ANGLE, units):.2f}" for value in np.asarray(stop.joints))
    where = f"x {x:.1f} y {y:.1f} z {z:.1f} mm, rotation {rotation} {unit} (joints {joints} {unit})"
    if stop.stale_for is not None:
        return f"The last state received ({stop.stale_for:.1f} s old: the arm may have moved since) showed {where}."
    return f"The arm is at rest at {where}."


def resume_command(settings: Settings) -> str:
    """The exact command that resumes this run: `ur3dq [--host H] [--backend B] [--store S] run-poses --resume`,
    naming what the environment would not give again."""
    words = ["ur3dq"]
    if settings.host and settings.host_source == "option":
        words += ["--host", settings.host]
    if settings.backend != "rtde":
        words += ["--backend", settings.backend]
    store = str(settings.store_path)
    if store != os.environ.get("UR3DQ_STORE", DEFAULT_STORE_PATH):
        words += ["--store", store]
    return " ".join(shlex.quote(word) for word in words + ["run-poses", "--resume"])


def announce_resume(settings: Settings, plan: Sequence[PlannedStep], first: int, program_length: int,
                    start_joints: np.ndarray) -> None:
    """Say how a resumed program goes on: from the arm's joints to its first waypoint's target by that waypoint's
    own move, that path checked from the joints the arm is at."""
    err = Console(stderr=True, highlight=False)
    units = Units(angle="deg" if settings.deg else "rad")
    joints = " ".join(f"{to_display(float(value), ANGLE, units):.2f}" for value in start_joints)
    waypoint = next(((offset, planned) for offset, planned in enumerate(plan) if planned.joints is not None), None)
    head = f"Resuming at {step_text(first, plan[0].step, program_length)}"
    if waypoint is None:
        err.print(escape(f"{head}: no step left moves the arm."), soft_wrap=True)
        return
    offset, planned = waypoint
    err.print(escape(f"{head}: first a {planned.move} move from where the arm is (joints {joints} "
                     f"{'°' if settings.deg else 'rad'}) to the target of step {first + offset} "
                     f"{planned.step.name!r}; the path check runs from those joints."),
              soft_wrap=not err.is_terminal)   # a terminal's width, between words; a log's line, whole


def replay_stop(robot: Any, position: int, name: str) -> ProgramStop:
    """The ProgramStop of a replay of stored poses stopped during its `position`-th move (to pose `name`): where
    the arm came to rest (a replay switches no output)."""
    status = status_at_rest(robot)
    stale = None if status is None or status.age <= STALE_AGE else float(status.age)
    return ProgramStop(position, name, None if status is None else status.joints,
                       None if status is None else status.tcp_pose, (), status is not None, stale)


def run_replay(settings: Settings, robot: Any, execute: Callable[[Callable[[str, int, int], None]], Any],
               names: Sequence[str], record: RunRecord) -> Any:
    """Run a replay of the stored poses `names` (in order, loops unrolled) through `execute(progress)`
    (ur3dq.replay.execute_plan with its progress callback), with the operator's controls; a replay that ends
    early says where and how to go on, as run_program does."""
    err = Console(stderr=True, highlight=False)
    done = [0]
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
               TimeElapsedColumn())
    with Progress(*columns, console=err, transient=False) as progress:
        task = progress.add_task("moving", total=len(names))

        def report(description: str, completed: int, total: int) -> None:
            done[0] = min(completed, len(names) - 1)
            progress.update(task, description=escape(description), completed=completed, total=total)


        def describe() -> str:
            return step_text(done[0] + 1, _PoseMove(names[done[0]]), len(names))

        with OperatorControls(robot, progress.console, describe) as controls:
            failure: BaseException | None = None
            try:
                results = execute(report)
            except (KeyboardInterrupt, Exception) as error:
                if isinstance(error, SafetyCheckError) and done[0] == 0:
                    raise   # refused before anything moved
                failure = error
    if failure is not None:
        stop = replay_stop(robot, done[0] + 1, names[done[0]])
        raise ended_early(settings, failure, stop, _PoseMove(names[done[0]]), len(names), record, controls,
                          names=names[done[0]:]) from None
    clear_resume_state(settings.store_path)
    return results


@dataclasses.dataclass(frozen=True)
class _PoseMove:
    """A replay's move to a stored pose, named as a program step is."""

    name: str
