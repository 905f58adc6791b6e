"""The cell-program workflows behind the commands (no command is defined here): waypoint edits, the program
tables, and the program paths of `record-pose`, `run-poses` and `export-urscript`.

Every edit is one locked, atomic store update (PoseStore.update_program): the new program is checked first and a
bad one changes nothing (one line naming the step, exit 4). Speeds are SI: rad/s, rad/s² for joint moves, m/s,
m/s² for linear/process moves; blend radius and offsets in metres, offset rotations in radians.
"""
from __future__ import annotations

import math

import click
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from ur3dq.cli.app import Settings, confirm, emit_json, emit_json_list, robot_session
from ur3dq.cli.display import Column, print_table
from ur3dq.cli.path_report import require_clear_program_path
from ur3dq.errors import StoreError
from ur3dq.pose import utc_now_iso
from ur3dq.program.plan import Defaults, plan_program
from ur3dq.program.resolve import select_range
from ur3dq.program.script import program_script
from ur3dq.program.steps import Motion, Waypoint, describe
from ur3dq.store_format import PROGRAM_SCHEMA_VERSION, step_to_dict

# ---------------------------------------------------------------- shared options and edits


def motion_from_options(base: Motion, move, speed, acceleration, blend) -> Motion:
    """`base` with the options that were given replacing its values (validated when the step is built)."""
    return Motion(move or base.move, base.speed if speed is None else speed,
                  base.acceleration if acceleration is None else acceleration, base.blend if blend is None else blend)


def insertion_index(steps, after: str | None, before: str | None, source) -> int:
    """Where --after/--before put a step in `steps` (the end by default); StoreError for an unknown name."""
    if after and before:
        raise click.UsageError("give --after or --before, not both")
    anchor = after or before
    if anchor is None:
        return len(steps)
    names = [step.name for step in steps]
    if anchor not in names:
        raise StoreError(f"no step named {anchor!r} in {source}")
    return names.index(anchor) + (1 if after else 0)


def replace_step(steps, name, new, source):
    """`steps` with the step `name` replaced by `new`."""
    if name not in [step.name for step in steps]:
        raise StoreError(f"no step named {name!r} in {source}")
    return [new if step.name == name else step for step in steps]


def find_step(steps, name, source):
    """The step called `name`; StoreError naming `source` if there is none."""
    for step in steps:
        if step.name == name:
            return step
    raise StoreError(f"no step named {name!r} in {source}")


def add_step_at(settings: Settings, make_step, after, before):
    """Insert the step `make_step(steps)` at --after/--before in one store update; returns it."""

    def edit(steps):
        step = make_step(steps)
        index = insertion_index(steps, after, before, settings.store_path)
        return steps[:index] + [step] + steps[index:], step

    return settings.store.update_program(edit)


def check_waypoint_options(name: str | None, move, speed, acceleration, blend, after, before, steps, source):
    """Check record-pose's waypoint options before the arm is read.

    record-pose's --move/--speed/--acceleration/--blend/--after/--before checked before the arm is read:
    ValueError or StoreError naming what is wrong."""
    Motion(move or "joint", speed, acceleration, blend).check(f"waypoint {name or '(new)'!r}")
    insertion_index(steps, after, before, source)


def record_waypoint(settings: Settings, pose, number_if_taken: bool, move, speed, acceleration, blend, after,
                    before):
    """Store a recorded pose as a waypoint of the program.

    Store `pose` as a waypoint with its own motion at --after/--before (the end by default), in one atomic
    update (a taken name is refused, or numbered on with `number_if_taken`); returns the pose as stored."""
    from ur3dq.store import with_added

    def edit(steps):
        index = insertion_index(steps, after, before, settings.store_path)
        result, (added,) = with_added(steps, [pose], number_if_taken, position=index)
        motion = motion_from_options(Motion(), move, speed, acceleration, blend)
        result[index] = Waypoint(added.name, added, motion)
        return result, added

    return settings.store.update_program(edit)


# ---------------------------------------------------------------- display


def program_rows(steps):
    """(position, name, type, what it does) text of each step."""
    return [(str(index), step.name, step.kind, describe(step)) for index, step in enumerate(steps, start=1)]


def list_program(settings: Settings) -> bool:
    """`poses list` of a version-2 store: every step; False (nothing printed) for a version-1 store."""
    if settings.store.version() != PROGRAM_SCHEMA_VERSION:
        return False
    steps = settings.store.load_program()
    if settings.json:
        emit_json_list(step_to_dict(step) for step in steps)
        return True
    print_table(settings.out, f"{len(steps)} steps in {settings.store_path}", LIST_COLUMNS,
                program_rows(steps))
    return True


_TARGET_FORMAT = " ".join(["%.3f"] * 6)   # one %-format per row: a long program's table has 10⁵ of them


def plan_rows(plan, first: int):
    """The rows of the cell program's plan table, one at a time.

    The run-poses plan table's rows, one at a time: #, name, type, target joints (rad, 3 decimals), speed,
    blend, travel, time."""
    for offset, planned in enumerate(plan):
        step = planned.step
        if planned.joints is None:
            yield str(first + offset), step.name, step.kind, describe(step), "", "", "", ""
            continue
        unit = "rad/s" if planned.move == "joint" else "m/s"
        yield (str(first + offset), step.name, planned.move, _TARGET_FORMAT % tuple(planned.joints.tolist()),
               f"{planned.speed:.3g} {unit}", f"{planned.blend:.3g}",
               "—" if planned.travel is None else f"{planned.travel:.3f}",
               "—" if planned.duration is None else f"{planned.duration:.2f} s")


PLAN_COLUMNS = (Column("#", justify="right", no_wrap=True), Column("step", no_wrap=True), Column("type"),
                Column("target (rad) / action", min_width=len("-3.142 -3.142 -3.142")),
                Column("speed", drop_order=3), Column("blend m", narrow_header="blend", drop_order=1),
                Column("travel", justify="right", no_wrap=True, drop_order=2),
                Column("time", justify="right", no_wrap=True, drop_order=4))
LIST_COLUMNS = (Column("#", justify="right", no_wrap=True), Column("name", no_wrap=True), Column("type"),
                Column("details"))


# ---------------------------------------------------------------- poses set / retouch / move / copy / offset


def program_part(settings: Settings, start, end):
    """(whole program, the --from/--to part, position of its first step)."""
    steps = settings.store.load_program()
    if not steps:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    part = select_range(steps, start, end)
    return steps, part, [s.name for s in steps].index(part[0].name) + 1


def run_program_command(settings: Settings, start, end, speed_scale, dry_run, yes, speed, acceleration, blend,
                        replay_joints, max_travel, cell_path=None):
    """`run-poses` of a cell program: plan, check, ask, run.

    `run-poses` of a cell program (a version-2 store, or --from/--to/--speed-scale): plan, table, the whole-path
    check (in `cell_path`'s cell if given), ask, run as one URScript program with the running step shown. Joint
    speeds in rad/s (already converted from --deg)."""
    from ur3dq.cli.background_simulator import running_simulator_host
    from ur3dq.kinematics import robot_model

    err = Console(stderr=True, highlight=False)
    steps, part, first = program_part(settings, start, end)
    defaults = Defaults(joint_acceleration=acceleration, joint_speed=speed, blend=blend)
    if not (math.isfinite(speed_scale) and 0 < speed_scale <= 1):
        raise ValueError(f"--speed-scale must be a fraction 0 < F ≤ 1, got {speed_scale!r}")
    if dry_run and not (settings.host or running_simulator_host()):
        first_pose = next((s.pose for s in steps if isinstance(s, Waypoint)), None)
        model = robot_model(settings.model or (first_pose.robot_model if first_pose else "ur3"))
        plan = plan_program(model, part, None, defaults, speed_scale, replay_joints, max_travel,
                            resolve_from=steps)
        _show_plan(settings, plan, first, f"Plan on a nominal {model.name} (no robot: travel from the first "
                                          "step)")
        require_clear_program_path(settings, model, plan, None, cell_path)
        return
    from ur3dq.program.runner import run_plan

    with robot_session(settings, max_joint_travel=max_travel) as robot:
        plan = plan_program(robot.model, part, robot.joints(), defaults, speed_scale, replay_joints, max_travel,
                            resolve_from=steps)
        _show_plan(settings, plan, first, f"Plan on the {robot.model_name} at {robot.host}")
        require_clear_program_path(settings, robot.model, plan, robot.joints(), cell_path)
        if dry_run:
            return
        confirm(f"Run {len(plan)} steps ({part[0].name!r} to {part[-1].name!r}) on the arm?", yes, default=False)
        columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                   TimeElapsedColumn())
        with Progress(*columns, console=err, transient=False) as progress:
            task = progress.add_task("starting", total=len(plan))

            def shown(position, step):
                progress.update(task, description=escape(f"step {position}: {step.name} ({step.kind})"),
                                completed=position - first)

            seconds = run_plan(robot, plan, first, shown)
            progress.update(task, completed=len(plan), description="done")
    if settings.json:
        emit_json({"steps": [p.step.name for p in plan], "seconds": seconds})
    else:
        click.echo(f"Ran {len(plan)} steps in {seconds:.2f} s.")


def _show_plan(settings: Settings, plan, first: int, title: str) -> None:
    console = Console(stderr=True, highlight=False) if settings.json else settings.out
    print_table(console, title, PLAN_COLUMNS, plan_rows(plan, first), len(plan))
    for planned in plan:  # say what was lowered to the model's (or the TCP's) limits
        if planned.clamped:
            click.echo(f"{planned.step.who}: clamped {', '.join(planned.clamped)}", err=True)
    if settings.json:
        emit_json({"plan": [{"step": p.step.name, "type": p.move or p.step.kind,
                             "joints": None if p.joints is None else p.joints.tolist(), "speed": p.speed,
                             "acceleration": p.acceleration, "blend": p.blend, "travel": p.travel,
                             "duration": p.duration} for p in plan]})


def export_program_text(settings: Settings, start, end, speed, acceleration, blend, speed_scale, replay_joints,
                        max_travel) -> tuple[str, int]:
    """The URScript text of the stored cell program and its number of steps.

    (the .script text of the program or its --from/--to part on the nominal model, number of steps): the same
    program run-poses sends."""
    from ur3dq.kinematics import robot_model

    steps, part, first = program_part(settings, start, end)
    first_pose = next((s.pose for s in steps if isinstance(s, Waypoint)), None)
    model = robot_model(settings.model or (first_pose.robot_model if first_pose else "ur3"))
    defaults = Defaults(joint_acceleration=acceleration, joint_speed=speed, blend=blend)
    plan = plan_program(model, part, None, defaults, speed_scale, replay_joints, max_travel, resolve_from=steps)
    header = [f"ur3dq export-urscript: steps {first}..{first + len(plan) - 1} of {settings.store_path} for a "
              f"{model.name}", f"generated {utc_now_iso()}",
              "the first move starts wherever the arm is: check it at low speed first"]
    return program_script(plan, header=header, first_position=first), len(plan)
