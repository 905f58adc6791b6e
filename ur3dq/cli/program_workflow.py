"""The cell-program workflows behind the commands (no command is defined here): waypoint edits, the program
tables, and the program paths of `record-pose` and `run-poses` (the exports: export_plans.py).

Every edit is one locked, atomic store update (PoseStore.update_program): the new program is checked first and a
bad one changes nothing (one line naming the step, exit 4). The store is SI: rad/s, rad/s² for joint moves, m/s,
m/s² for linear/process moves; blend radius and offsets in metres, offset rotations in radians. What a person
types and reads goes through ur3dq.units (options.Quantity / options.Typed in, motion_text / describe_step out).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click
import numpy as np
from rich.console import Console
from rich.text import Text

from ur3dq.cli.app import Settings, confirm, emit_json, emit_json_list, robot_session, solving_poses
from ur3dq.cli.display import Column, pose_label, pose_vector_text, print_table, recorded_joints_warnings
from ur3dq.cli.options import TypedValue
from ur3dq.cli.path_report import check_program, check_verdict, report_path_check, require_passed
from ur3dq.cli.plan_summary import program_figures, summary_lines, wait_time
from ur3dq.cli.plan_warnings import plan_warnings
from ur3dq.errors import StoreError
from ur3dq.kinematics.models import URModel
from ur3dq.pose import Pose, closest_name_text
from ur3dq.program.plan import Defaults, MotionRangeError, PlannedStep, plan_program
from ur3dq.program.plan import check_motion_range as plan_check_motion_range
from ur3dq.program.resolve import select_range
from ur3dq.program.steps import MAX_BLEND_M, Motion, RelativeWaypoint, Step, Wait, WaitInput, Waypoint, describe
from ur3dq.store_format import PROGRAM_SCHEMA_VERSION, step_to_dict
from ur3dq.units import (
    ACCELERATION,
    ANGLE,
    DISPLAY_DIGITS,
    DURATION,
    LENGTH,
    SPEED,
    Units,
    angular_kind,
    show,
    to_display,
    unit_label,
)

if TYPE_CHECKING:
    from ur3dq.cli.resume_state import ResumeState

#: A step of a kind its maker knows (add_step_at returns what it inserted).
StepT = TypeVar("StepT", bound=Step)

# ---------------------------------------------------------------- shared options and edits


def motion_from_options(base: Motion, move: str | None, speed: TypedValue | None,
                        acceleration: TypedValue | None, blend: TypedValue | None, who: str,
                        model: URModel) -> Motion:
    """`base` with the options that were given replacing its values: the speed and acceleration read as the
    resulting move type's kind (joint: angular, linear/process: linear) and refused, naming `who` and the valid
    range on `model`, when outside it; a move type change without a new speed keeps none that would not fit."""
    new_move = move or base.move
    angular = angular_kind(new_move)
    keep = move is None or angular_kind(base.move) == angular   # the stored numbers still mean the same kind
    values = []
    for typed, stored, kinds in ((speed, base.speed, SPEED), (acceleration, base.acceleration, ACCELERATION)):
        if typed is None:
            values.append(stored if keep else None)
            continue
        try:
            si = typed.si(kinds[angular])
        except ValueError as error:
            other = "joint" if not angular else "linear"
            raise ValueError(f"{who} is a {new_move} move: {error} (or make it a {other} move with --move "
                             f"{other})") from None
        try:   # refused in the units it was typed in (Motion's own check would name the SI value)
            values.append(typed.within(si, kinds[angular], above=0.0))
        except ValueError as error:
            raise ValueError(f"{who}: {error}") from None
    radius = base.blend
    if blend is not None:
        try:
            radius = blend.within(blend.si(LENGTH), LENGTH, at_least=0.0, at_most=MAX_BLEND_M)
        except ValueError as error:
            raise ValueError(f"{who}: {error}") from None
    try:
        motion = Motion(new_move, values[0], values[1], radius)
    except ValueError as error:
        raise ValueError(f"{who}: {str(error).removeprefix('motion: ')}") from None
    check_motion_range(motion, model, who, typed_units(speed, acceleration))
    return motion


def typed_units(*values: TypedValue | None) -> Units:
    """The units the person typed in (those of the first value given), for messages."""
    return next((value.units for value in values if value is not None), Units())


def check_motion_range(motion: Motion, model: URModel, who: str, units: Units) -> None:
    """ValueError naming `who` and the valid range (in `units`, linear speeds in mm as on the pendant) when the
    motion's speed or acceleration is outside what `model` allows for its move type (ur3dq.program.plan's
    check_motion_range, the screen's too), with an example of the option."""
    try:
        plan_check_motion_range(motion, model, who, Units(units.angle, "mm"))
    except MotionRangeError as error:
        examples = {("speed", True): "60deg/s", ("speed", False): "250mm/s",
                    ("acceleration", True): "80deg/s^2", ("acceleration", False): "1200mm/s^2"}
        raise ValueError(f"{error} (e.g. --{error.what} {examples[error.what, error.angular]})") from None


def program_model(settings: Settings, steps: list[Step]) -> URModel:
    """The model a program's limits are checked against: --model, else the first recorded pose's, else the UR3."""
    from ur3dq.kinematics import robot_model

    first_pose = next((s.pose for s in steps if isinstance(s, Waypoint)), None)
    return robot_model(settings.model or (first_pose.robot_model if first_pose else "ur3"))


def motion_text(motion: Motion, units: Units) -> str:
    """How the arm moves to a waypoint, in the person's units: 'linear 250 mm/s, blend 20 mm'."""
    angular = angular_kind(motion.move)
    parts = [motion.move]
    if motion.speed is not None:
        parts.append(show(motion.speed, SPEED[angular], _move_units(units, angular)))
    if motion.acceleration is not None:
        parts.append("a " + show(motion.acceleration, ACCELERATION[angular], _move_units(units, angular)))
    if motion.blend is not None:
        parts.append("blend " + show(motion.blend, LENGTH, Units(units.angle, "mm")))
    return ", ".join([" ".join(parts[:2]), *parts[2:]])


def _move_units(units: Units, angular: bool) -> Units:
    """Speeds shown as the pendant shows them: joint moves in the person's angle unit, linear moves in mm."""
    return units if angular else Units(units.angle, "mm")


def describe_step(step: Step, units: Units) -> str:
    """One short line saying what the step does, in the person's units (for tables; user text as typed)."""
    if isinstance(step, Waypoint):
        return motion_text(step.motion, units)
    if isinstance(step, RelativeWaypoint):
        mm = Units(units.angle, "mm")
        x, y, z = (to_display(v, LENGTH, mm) for v in step.offset[:3])
        offset = ",".join(f"{round(v, 1):+g}" for v in (x, y, z))
        return f"{motion_text(step.motion, units)}; {step.base} {offset} mm {step.frame}{_rotation_text(step, units)}"
    if isinstance(step, Wait):
        return show(step.seconds, DURATION)
    return describe(step)


def _rotation_text(step: RelativeWaypoint, units: Units) -> str:
    """' rx,ry,rz +5,+0,-5 °': the offset's rotation vector, each component with its sign ('' when it turns none)."""
    if not any(step.offset[3:]):
        return ""
    label = unit_label(ANGLE, units)
    vector = ",".join(f"{round(to_display(v, ANGLE, units), DISPLAY_DIGITS[label]):+g}" for v in step.offset[3:])
    return f" rx,ry,rz {vector} {label}"


def step_fields_text(step: Step, units: Units) -> list[tuple[str, str]]:
    """`poses show` of a step that is not a recorded pose: its stored fields, numbers in the person's units."""
    fields = step_to_dict(step)
    rows = [(key, str(value)) for key, value in fields.items()
            if key not in ("offset", "move", "speed", "acceleration", "blend", "seconds", "timeout")]
    if isinstance(step, RelativeWaypoint):
        rows.append((pose_label("offset", units), pose_vector_text(step.offset, units)))
        rows.append(("move", motion_text(step.motion, units)))
    for key in ("seconds", "timeout"):
        if key in fields:
            rows.append((key, show(fields[key], DURATION)))
    return rows


SEE_THE_LIST = "; `ur3dq poses list` shows them"   # the way on after an unknown step name


def insertion_index(steps: Sequence[Step], after: str | None, before: str | None, source: str | Path) -> int:
    """Where --after/--before put a step in `steps` (the end by default); StoreError for an unknown name."""
    if after and before:
        raise click.UsageError("give --after or --before, not both")
    anchor = after or before
    if anchor is None:
        return len(steps)
    names = [step.name for step in steps]
    if anchor not in names:
        raise StoreError(f"no step named {anchor!r} in {source}{closest_name_text(anchor, names, SEE_THE_LIST)}")
    return names.index(anchor) + (1 if after else 0)


def replace_step(steps: Sequence[Step], name: str, new: Step, source: str | Path) -> list[Step]:
    """`steps` with the step `name` replaced by `new`."""
    names = [step.name for step in steps]
    if name not in names:
        raise StoreError(f"no step named {name!r} in {source}{closest_name_text(name, names, SEE_THE_LIST)}")
    return [new if step.name == name else step for step in steps]


def find_step(steps: Sequence[Step], name: str, source: str | Path) -> Step:
    """The step called `name`; StoreError naming `source` if there is none."""
    for step in steps:
        if step.name == name:
            return step
    names = [step.name for step in steps]
    raise StoreError(f"no step named {name!r} in {source}{closest_name_text(name, names, SEE_THE_LIST)}")


def add_step_at(settings: Settings, make_step: Callable[[list[Step]], StepT], after: str | None,
                before: str | None) -> StepT:
    """Insert the step `make_step(steps)` at --after/--before in one store update; returns it."""

    def edit(steps: list[Step]) -> tuple[list[Step], StepT]:
        step = make_step(steps)
        index = insertion_index(steps, after, before, settings.store_path)
        return steps[:index] + [step] + steps[index:], step

    return settings.store.update_program(edit)


def check_waypoint_options(settings: Settings, name: str | None, move: str | None, speed: TypedValue | None,
                           acceleration: TypedValue | None, blend: TypedValue | None, after: str | None,
                           before: str | None, steps: list[Step]) -> Motion:
    """Check record-pose's waypoint options before the arm is read.

    record-pose's --move/--speed/--acceleration/--blend/--after/--before: the new waypoint's Motion, or
    ValueError / StoreError naming what is wrong."""
    motion = motion_from_options(Motion(), move, speed, acceleration, blend, f"waypoint {name or '(new)'!r}",
                                 program_model(settings, steps))
    insertion_index(steps, after, before, settings.store_path)
    return motion


def record_waypoint(settings: Settings, pose: Pose, number_if_taken: bool, motion: Motion, after: str | None,
                    before: str | None) -> Pose:
    """Store a recorded pose as a waypoint of the program.

    Store `pose` as a waypoint moved to with `motion` at --after/--before (the end by default), in one atomic
    update (a taken name is refused, or numbered on with `number_if_taken`); returns the pose as stored."""
    from ur3dq.store import with_added

    def edit(steps: list[Step]) -> tuple[list[Step], Pose]:
        index = insertion_index(steps, after, before, settings.store_path)
        result, (added,) = with_added(steps, [pose], number_if_taken, position=index)
        result[index] = Waypoint(added.name, added, motion)
        return result, added

    return settings.store.update_program(edit)


SAME_SPOT_M = 5e-4       # two recorded poses closer than this (and SAME_SPOT_RAD) are "the same spot"
SAME_SPOT_RAD = 1e-3


def same_spot_as(pose: Pose, steps: list[Step]) -> str | None:
    """The name of a recorded waypoint of `steps` at `pose`'s spot (within 0.5 mm and 0.06°), or None: a pose
    recorded twice without moving the arm in between is almost always a slip."""
    for step in steps:
        if isinstance(step, Waypoint) and step.name != pose.name:
            metres, radians = step.pose.dq.distance(pose.dq)
            if metres < SAME_SPOT_M and radians < SAME_SPOT_RAD:
                return step.name
    return None


# ---------------------------------------------------------------- display


def program_rows(steps: list[Step], units: Units) -> list[tuple[str, str, str, str]]:
    """(position, name, type, what it does) text of each step."""
    return [(str(index), step.name, step.kind, describe_step(step, units)) for index, step in enumerate(steps, start=1)]


def list_program(settings: Settings) -> list[Step] | None:
    """`poses list` of a version-2 store: every step, and the steps; None (nothing printed) for a version-1 store."""
    if settings.store.version() != PROGRAM_SCHEMA_VERSION:
        return None
    steps = settings.store.load_program()
    if settings.json:
        emit_json_list({"store": str(settings.store_path), "version": PROGRAM_SCHEMA_VERSION}, "steps",
                       (step_to_dict(step) for step in steps))
        return steps
    print_table(settings.out, f"{len(steps)} steps in {settings.store_path}", LIST_COLUMNS,
                program_rows(steps, settings.units))
    return steps


# one %-format per row: a long program's table has 10⁵ of them (radians with 3 decimals, degrees with 1)
_TARGET_FORMAT = {"rad": " ".join(["%.3f"] * 6), "deg": " ".join(["%.1f"] * 6)}


def plan_rows(plan: list[PlannedStep], first: int, units: Units) -> Iterator[tuple[str, ...]]:
    """The rows of the cell program's plan table, one at a time.

    #, name, type, target joints, speed, blend (mm), travel (largest joint), time; numbers in the person's units
    (plan_columns names them)."""
    scale = to_display(1.0, ANGLE, units)
    mm = Units(units.angle, "mm")
    for offset, planned in enumerate(plan):
        step = planned.step
        if planned.joints is None:
            seconds, limit = wait_time(step)
            held = f"{seconds:.2f} s" if seconds is not None else "" if limit is None else f"≤ {limit:.2f} s"
            yield str(first + offset), step.name, step.kind, describe_step(step, units), "", "", "", held
            continue
        angular = angular_kind(planned.move or "joint")
        yield (str(first + offset), step.name, planned.move or "", _TARGET_FORMAT[units.angle] % tuple(
                   v * scale for v in planned.joints.tolist()),
               show(planned.speed or 0.0, SPEED[angular], _move_units(units, angular), 3 if angular else 0),
               f"{to_display(planned.blend, LENGTH, mm):.0f}",
               "—" if planned.travel is None else f"{planned.travel * scale:.{1 if units.angle == 'deg' else 3}f}",
               "—" if planned.duration is None else f"{planned.duration:.2f} s")


def plan_columns(units: Units) -> tuple[Column, ...]:
    """The columns of plan_rows, their headers naming the units."""
    unit = unit_label(ANGLE, units)
    return (Column("#", justify="right", no_wrap=True), Column("step", no_wrap=True), Column("type"),
            Column(f"target joints ({unit}) / action", narrow_header=f"target ({unit}) / action",
                   min_width=len("-180.0 -180.0 -180.0")),
            Column("speed", drop_order=3), Column("blend mm", narrow_header="blend", drop_order=1),
            Column(f"travel {unit}", justify="right", no_wrap=True, drop_order=2),
            Column("time", justify="right", no_wrap=True, drop_order=4))


PLAN_COLUMNS = plan_columns(Units())
LIST_COLUMNS = (Column("#", justify="right", no_wrap=True), Column("name", no_wrap=True), Column("type"),
                Column("details"))


# ---------------------------------------------------------------- poses set / retouch / move / copy / offset


def program_part(settings: Settings, start: str | None, end: str | None) -> tuple[list[Step], list[Step], int]:
    """(whole program, the --from/--to part, position of its first step)."""
    steps = settings.store.load_program()
    if not steps:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    part = select_range(steps, start, end)
    return steps, part, [s.name for s in steps].index(part[0].name) + 1


def run_program_command(settings: Settings, start: str | None, end: str | None, speed_scale: float, dry_run: bool,
                        yes: bool, speed: float, acceleration: float, blend: float, replay_joints: bool,
                        max_travel: float, cell_path: Path | None = None, full_plan: bool = False,
                        resume: ResumeState | None = None, tcp_choice: str | None = None) -> None:
    """`run-poses` of a cell program: plan, check, ask, run.

    `run-poses` of a cell program (a version-2 store, or --from/--to/--speed-scale): plan, the whole-path check
    (in `cell_path`'s cell if given), then the question under a summary that fits 24 rows (the full table and the
    check's margins with `full_plan` or a dry run), and the run as one URScript program with the running step
    shown and the operator's controls (ur3dq.cli.run_session). Speeds SI. `resume` (a ResumeState) goes on from
    its step on the arm it stopped on: the plan starts from the arm's actual joints, so its first move is a new
    path, checked as such. `tcp_choice` is --tcp: a program taught with another TCP than the controller's is
    refused without it (ur3dq.cli.tcp_check)."""
    from ur3dq.cli.background_simulator import running_simulator_host
    from ur3dq.cli.resume_state import store_digest
    from ur3dq.kinematics import robot_model

    digest = store_digest(settings.store_path)   # the program the run plans, for a later --resume
    steps, part, first = program_part(settings, start, end)
    defaults = Defaults(joint_acceleration=acceleration, joint_speed=speed, blend=blend)
    if not (math.isfinite(speed_scale) and 0 < speed_scale <= 1):
        raise ValueError(f"--speed-scale must be a fraction 0 < F ≤ 1, got {speed_scale!r}")
    if dry_run and not (settings.host or running_simulator_host()):
        first_pose = next((s.pose for s in steps if isinstance(s, Waypoint)), None)
        model = robot_model(settings.model or (first_pose.robot_model if first_pose else "ur3"))
        solving_poses(len(part), model)
        _warn_recorded_joints(part, model)
        plan = plan_program(model, part, None, defaults, speed_scale, replay_joints, max_travel,
                            resolve_from=steps)
        _present(settings, model, plan, None, first, cell_path, True,
                 f"Plan on a nominal {model.name} (no robot: travel from the first step)")
        return
    from ur3dq.cli import run_session
    from ur3dq.cli.tcp_check import steps_for_the_current_tcp

    with robot_session(settings, max_joint_travel=max_travel) as robot:
        solving_poses(len(part), robot.model)
        if resume is not None:
            resume.require_same_arm(robot)
        steps = steps_for_the_current_tcp(steps, [step.name for step in part], robot.model.tcp, tcp_choice,
                                          replay_joints, Console(stderr=True, highlight=False))
        part = steps[first - 1:first - 1 + len(part)]
        _warn_recorded_joints(part, robot.model)
        plan = plan_program(robot.model, part, robot.joints(), defaults, speed_scale, replay_joints, max_travel,
                            resolve_from=steps)
        if resume is not None:
            run_session.announce_resume(settings, plan, first, len(steps), robot.joints())
        _present(settings, robot.model, plan, robot.joints(), first, cell_path, dry_run or full_plan,
                 f"Plan on the {robot.model_name} at {robot.host}", dry_run)
        if dry_run:
            return
        run_session.confirm_replacing_foreign_program(robot, yes)
        confirm(f"Run {len(plan)} steps ({part[0].name!r} to {part[-1].name!r}) on the arm?", yes, default=False)
        options = {"speed": speed, "acceleration": acceleration, "blend": blend, "speed_scale": speed_scale,
                   "replay_joints": replay_joints, "max_travel": max_travel, "tcp": tcp_choice,
                   "cell": None if cell_path is None else str(cell_path)}
        record = run_session.run_record(settings, robot, "program", end, options, digest)
        seconds = run_session.run_program(settings, robot, plan, first, len(steps), record)
    if settings.json:
        emit_json({**plan_json(plan, settings.units), "steps": [p.step.name for p in plan], "seconds": seconds})
    else:
        click.echo(f"Ran {len(plan)} steps in {seconds:.2f} s.")


def _present(settings: Settings, model: URModel, plan: list[PlannedStep], start_joints: np.ndarray | None,
             first: int, cell_path: Path | None, full: bool, title: str, final: bool = True) -> None:
    """Show the plan before the question: the full table, clamp lines and the check's margins when `full`, else
    the summary; the check's problems once; SafetyCheckError when it failed. A dry run's (`final`) JSON is
    printed here; a run's after the run."""
    result, _ = check_program(model, plan, cell_path, start_joints, keep_samples=False)
    warnings = plan_warnings(plan, settings.units)
    if full:
        console = Console(stderr=True, highlight=False) if settings.json else settings.out
        print_table(console, title, plan_columns(settings.units), plan_rows(plan, first, settings.units), len(plan))
        for warning in warnings:   # what was lowered to the limits, blends dropped, script kept as it is
            click.echo(warning, err=True)
        if result is not None:
            report_path_check(settings, result, cell_path)
    if not full or not final:
        err = Console(stderr=True, highlight=False)
        for line in summary_lines(program_figures(plan), check_verdict(result, cell_path), warnings,
                                  settings.units):
            err.print(Text(line))
    if result is not None:
        require_passed(settings, result)
    if settings.json and final:
        emit_json({**plan_json(plan, settings.units), "path_check": None if result is None else result.to_dict()})


def plan_json(plan: list[PlannedStep], units: Units) -> dict[str, Any]:
    """The plan of a cell program for --json (SI), with what was lowered to the limits: a step's `duration` is its
    move's time, or a wait's seconds; a wait for an input has none, but its `timeout`."""
    return {"plan": [{"step": p.step.name, "type": p.move or p.step.kind,
                      "joints": None if p.joints is None else p.joints.tolist(), "speed": p.speed,
                      "acceleration": p.acceleration, "blend": p.blend, "travel": p.travel,
                      "duration": p.duration if p.joints is not None else wait_time(p.step)[0],
                      "clamped": list(p.clamped),
                      **({"timeout": p.step.timeout} if isinstance(p.step, WaitInput) else {})} for p in plan],
            "warnings": plan_warnings(plan, units)}


def _warn_recorded_joints(steps: list[Step], model: URModel) -> None:
    """A line on stderr per recorded waypoint whose joints put its TCP elsewhere than its pose, on `model`."""
    for line in recorded_joints_warnings([step.pose for step in steps if isinstance(step, Waypoint)], model):
        click.echo(line, err=True)
