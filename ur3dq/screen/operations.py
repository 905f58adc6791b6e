"""What the page's buttons do, as blocking calls on the Station's robot and store: the robot panel, teach (record,
retouch, jog, move here), check and run, and the program's edits.

Nothing here plans, checks or converts on its own: runs are planned by ur3dq.program.plan and run by
ur3dq.program.run (the driver checks every target and, required at connection, the whole path), the check is
ur3dq.pathcheck's, jogs are ur3dq.robot.jog's, edits go through the store (ur3dq.screen.editing), typed numbers
through ur3dq.units. A motion that needs the operator's yes is two calls: `prepare_*` (planned and checked,
returning the question) and the returned callable, run once the page answered yes.

Each motion the page starts is logged (`log`) with the lines the command line prints for it.
"""
from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

from ur3dq import units as u
from ur3dq.errors import ProgramError, RobotConnectionError, RobotError, SafetyCheckError, StoreError
from ur3dq.pathcheck import Margins, check_path
from ur3dq.pose import next_free_name
from ur3dq.program.path import path_plan_of
from ur3dq.program.plan import Defaults, check_motion_range, plan_program
from ur3dq.program.resolve import select_range
from ur3dq.program.runner import run_plan
from ur3dq.program.steps import MAX_BLEND_M, PIN_COUNT, DigitalOut, Message, Motion, Step, Wait, is_waypoint
from ur3dq.replay import read_pose
from ur3dq.robot.jog import Jog
from ur3dq.robot.jog_steps import JogStep
from ur3dq.screen import editing
from ur3dq.screen.station import Station
from ur3dq.screen.views import check_message
from ur3dq.store import find_step

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel
    from ur3dq.robot.robot import Robot

MAX_LOOPS = 1000
STOPPED_BY_OPERATOR = "stopped by the operator (Stop)"


class Busy(RobotError):
    """The arm is already doing something the page started."""


class Operations:
    """The page's commands on one Station; `log(line)` records each motion and change."""

    def __init__(self, station: Station, log: Callable[[str], None]):
        self.station = station
        self.log = log
        self.editor = editing.ProgramEditor(station.store)
        self.margins = Margins()
        self._claim_lock = threading.Lock()
        self._stop_reason: str | None = None   # why the run in progress was stopped (None: it was not)
        self._jog_lock = threading.Lock()
        self._jog_generation = 0
        self._jog: Jog | None = None
        self.last_check: dict[str, Any] | None = None   # the last `check` message

    # ------------------------------------------------------------------------------------------------ helpers
    def robot(self) -> Robot:
        """The connected, prepared Robot, or RobotConnectionError saying why there is none."""
        robot = self.station.robot
        if robot is None:
            raise RobotConnectionError(self.station.connection_error or "no robot connected")
        if not self.station.ready:
            raise RobotConnectionError(f"the connection to {robot.host} is still being prepared: try again")
        return robot

    @contextlib.contextmanager
    def claimed(self, activity: str) -> Iterator[None]:
        """Mark the arm busy with `activity` for the block; Busy if it already is."""
        with self._claim_lock:
            if self.station.activity is not None:
                raise Busy(f"the arm is busy ({self.station.activity}): wait, or Stop it first")
            self.station.activity = activity
        try:
            yield
        finally:
            self.station.activity = None

    def _robot_call(self, activity: str, call: Callable[[Robot], object], done: str, moot: str | None = None) -> str:
        """call(robot) while claimed; logs and returns `done` (the CLI's line), or `moot` when the call answered
        False (there was nothing to do)."""
        with self.claimed(activity):
            robot = self.robot()
            with self.station.robot_lock:
                outcome = call(robot)
        line = (moot if outcome is False and moot is not None else done).format(host=robot.host)
        self.log(line)
        return line

    def store_problem(self) -> str | None:
        """While the store file does not read: what is wrong and what to do (naming the file), else None."""
        problem = self.station.store_error
        if problem is None:
            return None
        return (f"The program's file does not read: {problem}. Check, Run and Move here wait until it does: repair "
                f"{self.station.store.path} or put back a good copy (the screen reads it again by itself).")

    def program(self) -> list[Step]:
        """The program to check, run or move along: the store's steps, or StoreError (store_problem) while the
        store file does not read, so that nothing runs an old copy of it."""
        problem = self.store_problem()
        if problem is not None:
            raise StoreError(problem)
        return self.station.steps

    # ------------------------------------------------------------------------------------------------ robot panel
    def power_on(self) -> str:
        return self._robot_call("power on", lambda r: r.power_on(),
                                "{host}: powered on (brakes held: `ur3dq robot brake-release`).")

    def power_off(self) -> str:
        return self._robot_call("power off", lambda r: r.power_off(), "{host}: powered off.")

    def brake_release(self) -> str:
        return self._robot_call("brake release", lambda r: r.brake_release(),
                                "{host}: brakes released, the arm is RUNNING.")

    def unlock(self) -> str:
        return self._robot_call("unlock", lambda r: r.unlock_protective_stop(), "{host}: protective stop unlocked.",
                                "{host}: no protective stop to unlock.")

    def freedrive(self, on: bool) -> str:
        switch = "on" if on else "off"
        return self._robot_call(f"freedrive {switch}", lambda r: r.teach_mode(on), f"{{host}}: freedrive {switch}.")

    def set_output(self, group: str, pin: int, on: bool) -> str:
        """Switch a digital output (through the RTDE inputs: a running program goes on)."""
        robot = self.robot()
        setters = {"standard": robot.set_digital_out, "tool": robot.set_tool_digital_out,
                   "configurable": robot.set_configurable_digital_out}
        if group not in setters:
            raise ValueError(f"digital output family {group!r} is not one of {', '.join(setters)}")
        setters[group](pin, on)
        line = f"{robot.host}: {group} digital output {pin} {'on' if on else 'off'}."
        self.log(line)
        return line

    def output_question(self, group: str, pin: int, on: bool) -> str | None:
        """The question to ask before switching an output while a program runs, else None."""
        if self.station.latest.program == "STOPPED":
            return None
        return f"A program is running: switch {group} digital output {pin} {'on' if on else 'off'} now?"

    def set_speed_slider(self, fraction: float) -> str:
        """Set the controller's speed slider (the speed scaling of every motion), 1..100 %."""
        if not (isinstance(fraction, (int, float)) and math.isfinite(fraction) and 0.01 <= fraction <= 1.0):
            raise ValueError(f"speed slider: {fraction!r} is not a fraction 0.01..1")
        robot = self.robot()
        robot.inputs.set_speed_slider(float(fraction))
        line = f"{robot.host}: speed slider {fraction * 100:.0f} %."
        self.log(line)
        return line

    # ------------------------------------------------------------------------------------------------ teach
    def default_pose_name(self) -> str:
        """The name Record pose proposes: the next free pose-N."""
        return next_free_name("pose", {step.name for step in self.station.steps})

    def record(self, name: str, after: str | None) -> str:
        """Record the arm's pose as a joint waypoint `name` just after `after` (or at the end)."""
        robot = self.robot()
        pose = read_pose(robot, name)
        stored = self.editor.apply(f"record {name!r}", editing.record_pose(pose, after))
        self.station.reload_program(force=True)
        line = f"Recorded {stored[0].name!r} in {self.station.store.path}."
        self.log(line)
        return line

    def retouch(self, name: str) -> str:
        """Re-record the waypoint `name` where the arm is now (its motion and place stay)."""
        step = find_step(self.station.steps, name, "the program")
        pose = read_pose(self.robot(), name, note=getattr(getattr(step, "pose", None), "note", ""))
        self.editor.apply(f"retouch {name!r}", editing.retouch(name, pose))
        self.station.reload_program(force=True)
        self.log(f"Re-recorded {name!r}.")
        return f"Re-recorded {name!r}."

    def press(self) -> int:
        """A jog button went down: the token jog_start takes (read in the order the page's messages came)."""
        return self._jog_generation

    def release(self) -> None:
        """A jog button went up (in the order the page's messages came): a jog pressed before never starts."""
        self._jog_generation += 1

    def jog_start(self, step: JogStep, speed: float, units: u.Units, pressed: int) -> str:
        """Start the hold-to-move jog `step` at `speed` (rad/s, m/s) pressed with token `pressed` (see press); it
        runs until jog_stop or until keep_alive stops coming. A release that came after the press and before this
        start wins: no motion."""
        with self._jog_lock:
            if pressed != self._jog_generation:
                return "released before it started"
            with self._claim_lock:
                busy = self.station.activity
                if busy is not None and not busy.startswith("jog"):
                    raise Busy(f"the arm is busy ({busy}): wait, or Stop it first")
                self.station.activity = f"jog {step.label}"
            try:
                plan = self._jogger().start(step, speed)
            except BaseException:
                self.station.activity = None
                raise
        kind = u.LENGTH if step.linear else u.ANGLE
        speed_kind = u.LINEAR_SPEED if step.linear else u.ANGULAR_SPEED
        line = (f"jog {step.label}{'' if step.joint_mode else ' ' + step.frame}: "
                f"{u.show(plan.speed, speed_kind, units)}, up to {u.show(plan.distance, kind, units)}"
                + (f" ({plan.limited_by})" if plan.limited_by else ""))
        self.log(line)
        return line

    def jog_stop(self, why: str = "released") -> None:
        """Stop a jog now (the button went up, the page went silent or away)."""
        self._jog_generation += 1
        with self._jog_lock:
            if self.station.activity is None or not self.station.activity.startswith("jog"):
                return
            label = self.station.activity
            try:
                if self._jog is not None and self.station.robot is not None:
                    self._jog.stop()
            finally:
                self.station.activity = None
        self.log(f"{label} stopped ({why})")

    def keep_alive(self) -> None:
        """The controlling page's heartbeat, while a jog may run: feeds the jog's controller watchdog."""
        activity = self.station.activity
        if self._jog is not None and activity is not None and activity.startswith("jog"):
            self._jog.keep_alive()

    def _jogger(self) -> Jog:
        robot = self.robot()
        if self._jog is None or self._jog.robot is not robot:
            self._jog = Jog(robot)   # checked in the cell the station's robot requires
        return self._jog

    def warm_up(self, robot: Robot) -> None:
        """Plan a jog of each kind on `robot` without moving (the first plans compile the kinematics kernels)."""
        self._jog = jog = Jog(robot)
        for step in (JogStep("J1", 1), JogStep("X", 1)):
            with contextlib.suppress(SafetyCheckError, ValueError):
                jog.plan(step, 0.05)

    def prepare_move_here(self, name: str, units: u.Units) -> tuple[str, Callable[[], str]]:
        """(question, move): the move `ur3dq move-to NAME` makes — the waypoint `name` by its own move type and
        speed, planned from the arm and path-checked now, run by the program runner once answered yes."""
        robot = self.robot()
        steps = self.program()
        step = find_step(steps, name, "the program")
        if not is_waypoint(step):
            raise ValueError(f"{step.who}: not a waypoint; Move here goes to waypoints")
        start = robot.joints()
        plan = plan_program(robot.model, [step], start, Defaults(), max_joint_travel=robot.max_joint_travel,
                            resolve_from=steps)
        path = path_plan_of(plan, start)
        if path is not None:
            result = check_path(robot.model, path, self.station.config.cell, self.margins, keep_samples=False)
            if not result.ok:
                raise result.refusal()
        planned, position = plan[0], [s.name for s in steps].index(name) + 1
        speed = "" if planned.speed is None or planned.move is None else \
            f" at {u.show(planned.speed, u.SPEED[u.angular_kind(planned.move)], units)}"
        travel = "" if planned.travel is None else \
            f", the largest joint turning {u.show(planned.travel, u.ANGLE, units)}"
        question = f"Move the arm to {name!r} (a {planned.move} move{speed}{travel})?"

        def move() -> str:
            with self.claimed(f"move here {name!r}"):
                self.log(f"{question} yes")
                seconds = run_plan(robot, plan, position)
            line = f"Moved to {name!r} in {seconds:.2f} s."
            self.log(line)
            return line

        return question, move

    # ------------------------------------------------------------------------------------------------ check, run
    def check(self, start: str | None) -> dict[str, Any]:
        """The path check of the program (from `start`) as run-poses would run it now: planned from the arm's
        joints (from the first waypoint without a robot), every move sampled; the `check` message. StoreError
        while the store file does not read."""
        steps = self.program()
        model = self.station.model()
        try:
            part = select_range(steps, start, None) if steps else []
            if not part:
                raise ValueError("the program has no steps: record poses first")
            joints = self.station.joints()
            plan = plan_program(model, part, joints, Defaults(), resolve_from=steps,
                                max_joint_travel=self.station.robot.max_joint_travel if self.station.robot else None)
            path = path_plan_of(plan, joints)
            result = None if path is None else check_path(model, path, self.station.config.cell, self.margins)
        except (ValueError, RobotError) as error:
            who = next((s.name for s in steps if s.who in str(error)), None)
            self.last_check = check_message(None, model, None, self.margins, start, str(error), who)
            return self.last_check
        if result is None:
            self.last_check = {"type": "check", "ok": True, "summary": "no waypoint: nothing moves", "problems": [],
                               "verdicts": {}, "paths": [], "smallest_clearance": None, "from": start}
        else:
            self.last_check = check_message(result, model, self.station.config.cell, self.margins, start)
        return self.last_check

    def prepare_run(self, start: str | None, loops: int) -> tuple[str, Callable[[], str]]:
        """(question, run): the program (from `start`) planned from the arm and checked now, run `loops` times,
        each time planned again from where the arm is; refused as run-poses refuses (SafetyCheckError...)."""
        if not (isinstance(loops, int) and 1 <= loops <= MAX_LOOPS):
            raise ValueError(f"loop count must be a whole number 1..{MAX_LOOPS}, got {loops!r}")
        robot = self.robot()
        checked = self.check(start)
        if not checked["ok"]:
            if checked.get("error"):
                raise SafetyCheckError(checked["summary"])
            text, measured = checked["refusal"]   # its numbers in the units of the page that asked
            raise SafetyCheckError.from_wording("path check: " + text, measured)
        steps = list(self.station.steps)
        part = select_range(steps, start, None)
        first = [s.name for s in steps].index(part[0].name) + 1
        times = f" {loops} times" if loops > 1 else ""
        question = f"Run {len(part)} steps ({part[0].name!r} to {part[-1].name!r}) on the arm{times}?"

        def run() -> str:
            with self.claimed("run"):
                self._stop_reason = None
                self.log(f"{question} yes")
                try:
                    return self._run_loops(robot, steps, part, first, loops)
                finally:
                    self.station.running_step = self.station.loop_text = None

        return question, run

    def _run_loops(self, robot: Robot, steps: list[Step], part: list[Step], first: int, loops: int) -> str:
        began = time.monotonic()
        for loop in range(1, loops + 1):
            self.station.loop_text = f"{loop} / {loops}" if loops > 1 else None
            plan = plan_program(robot.model, part, robot.joints(), Defaults(), max_joint_travel=robot.max_joint_travel,
                                resolve_from=steps)

            def shown(position: int, step: Step) -> None:
                self.station.running_step = step.name
                self.log(f"step {position}: {step.name} ({step.kind})")

            try:
                run_plan(robot, plan, first, shown)
            except RobotError as error:
                if self._stop_reason is not None:
                    raise ProgramError(self._stop_reason) from error
                raise
        seconds = time.monotonic() - began
        line = f"Ran {len(part)} steps in {seconds:.2f} s." if loops == 1 else \
            f"Ran {len(part)} steps {loops} times in {seconds:.2f} s."
        self.log(line)
        return line

    def pause(self) -> str:
        """The controller's pause (the arm rests on its path); where it refuses, the arm is stopped instead."""
        robot = self.robot()
        outcome = robot.pause()
        self.log(f"{robot.host}: {outcome}.")
        return outcome

    def resume(self) -> str:
        robot = self.robot()
        robot.resume()
        self.log(f"{robot.host}: resumed.")
        return "resumed"

    def stop(self, reason: str = STOPPED_BY_OPERATOR) -> str:
        """Stop whatever moves (stopj) and end a run and its loops; a run stopped ends with ProgramError(reason)."""
        self._stop_reason = reason
        robot = self.robot()
        robot.stop()
        self.log(f"{robot.host}: stopj sent.")
        return "stopped"

    # ------------------------------------------------------------------------------------------------ edits
    def edit(self, kind: str, fields: dict[str, Any], units: u.Units) -> str:
        """Apply one edit of the page (`kind` and its `fields`), with undo; returns what was done."""
        description, change = self._edit_of(kind, fields, units)
        self.editor.apply(description, change)
        self.station.reload_program(force=True)
        self.log(f"edit: {description}")
        return description

    def _edit_of(self, kind: str, fields: dict[str, Any], units: u.Units) -> tuple[str, editing.Edit]:
        name, after = str(fields.get("name") or ""), fields.get("after")
        if kind == "motion":
            new = typed_motion(name, fields, units, self.station.model())
            return f"set {name!r} to a {fields.get('move', 'joint')} move", editing.set_motion(name, new)
        if kind == "move":
            offset = int(fields.get("offset", 0))
            return f"move {name!r} {'up' if offset < 0 else 'down'}", editing.move_step(name, offset)
        if kind == "delete":
            return f"delete {name!r}", editing.delete_step(name)
        if kind == "rename":
            return f"rename {name!r} to {fields.get('new')!r}", editing.rename_step(name, str(fields.get("new", "")))
        if kind in ("output", "wait", "message"):
            make = self._action_maker(kind, fields, units)
            return f"add {'an' if kind == 'output' else 'a'} {kind} step", editing.insert_step(make, after)
        raise ValueError(f"unknown edit {kind!r}")

    @staticmethod
    def _action_maker(kind: str, fields: dict[str, Any], units: u.Units) -> Callable[[set[str]], Step]:
        """make(taken names) of a new output, wait or message step typed on the page."""
        given = str(fields.get("step_name", "")).strip()

        def name(taken: set[str]) -> str:
            return given or next_free_name(kind, taken)

        if kind == "output":
            group, pin = output_pin(fields.get("group", "standard"), fields.get("pin", ""))
            on = bool(fields.get("on"))
            return lambda taken: DigitalOut(name(taken), group, pin, on)
        if kind == "wait":
            seconds = u.parse(str(fields.get("seconds", "")), u.DURATION, units, "wait")
            return lambda taken: Wait(name(taken), seconds)
        text = str(fields.get("text", ""))
        return lambda taken: Message(name(taken), text)

    def undo(self) -> str:
        done = self.editor.undo()
        self.station.reload_program(force=True)
        self.log(f"undo: {done}")
        return f"undone: {done}"

    def redo(self) -> str:
        done = self.editor.redo()
        self.station.reload_program(force=True)
        self.log(f"redo: {done}")
        return f"redone: {done}"


def typed_motion(name: str, fields: dict[str, Any], units: u.Units, model: URModel) -> Callable[[Motion], Motion]:
    """new(motion) of the waypoint `name` as typed on the page (editing.set_motion's argument): move type, speed and
    blend (blank: the run's default) read in `units`; its acceleration, which the page does not show, is kept while
    the move stays of the same kind (joint: angular; linear/process: linear). A speed out of `model`'s range:
    ValueError written in `units` (program.plan.check_motion_range, the command line's check).

    >>> from ur3dq.kinematics import robot_model
    >>> typed_motion("p", {"move": "linear", "blend": "2"}, u.Units("deg", "mm"), robot_model("ur3"))(
    ...     Motion("linear", 0.1, 0.5))
    Motion(move='linear', speed=None, acceleration=0.5, blend=0.002)
    """
    move = str(fields.get("move", "joint"))
    angular = u.angular_kind(move)
    speed_text, blend_text = str(fields.get("speed", "")).strip(), str(fields.get("blend", "")).strip()
    # bounded here, where the typed units are known: Motion's own check would name the SI value
    speed = None if not speed_text else u.parse(speed_text, u.SPEED[angular], units, "speed", above=0.0)
    blend = None if not blend_text else u.parse(blend_text, u.LENGTH, units, "blend", at_least=0.0,
                                                at_most=MAX_BLEND_M)

    def new(base: Motion) -> Motion:
        kept = base.acceleration if u.angular_kind(base.move) == angular else None
        motion = Motion(move, speed, kept, blend)
        check_motion_range(motion, model, f"waypoint {name!r}", units)
        return motion

    return new


def output_pin(group: object, pin: object) -> tuple[str, int]:
    """(group, pin) of a digital output typed on the page: a family of PIN_COUNT and a whole pin number it has;
    ValueError naming the field and the range otherwise (never rounded or guessed)."""
    if group not in PIN_COUNT:
        raise ValueError(f"digital output family {group!r} is not one of {', '.join(PIN_COUNT)}")
    return str(group), u.whole_number(pin, f"{group} output pin", 0, PIN_COUNT[str(group)] - 1)
