"""What the page shows, as JSON-ready dicts: the live state, the program's steps and the path check, every number a
person reads written by ur3dq.units in the page's chosen units (the joints, TCP, speeds, blends, offsets, margins).

Pure functions of library values (RobotStatus, steps, PathCheckResult): the server decides when to send them.
"""
from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ur3dq import units as u
from ur3dq.errors import POWER_ON_HINT, UNLOCK_HINT
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import Cell, Margins, PathCheckResult
from ur3dq.pathcheck.checks import StepChecker
from ur3dq.program.steps import RelativeWaypoint, Step, Waypoint, describe, is_waypoint

#: Digits after the point of the live readouts: the units layer's one display precision (0.01° / 0.1 mm).
READOUT_DIGITS = u.DISPLAY_DIGITS
#: Data older than this (s) is stale: the controller streams at 125-500 Hz and the station reads at 30 Hz, so a
#: healthy reading is a few ms old; a third of a second means the stream went silent (a frozen or gone controller).
STALE_AFTER = 0.3
#: At most this many samples of one move go to the page (its path is drawn as a line through them).
MAX_PATH_POINTS = 120


def readout(value: float, kind: u.Kind, units: u.Units) -> str:
    """A live readout: `value` (SI) in the page's units with READOUT_DIGITS."""
    return u.show(value, kind, units, digits=READOUT_DIGITS.get(u.unit_label(kind, units), 3))


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """One reading of the cell for the page (SI): the controller's status and what the server is doing."""

    connected: bool
    robot_mode: str
    safety_mode: str
    program: str              # STOPPED / PLAYING / PAUSED (the dashboard's words)
    joints: tuple[float, ...] = (0.0,) * 6
    tcp_pose: tuple[float, ...] = (0.0,) * 6
    placed: dict[str, Any] | None = None   # scene.ArmShape.placed of the joints
    speed_slider: float = 1.0
    freedrive: bool = False
    inputs: dict[str, list[bool]] | None = None   # {group: [bools]}
    outputs: dict[str, list[bool]] | None = None
    activity: str | None = None  # "run", "jog J1+", "move here", ... while the server moves the arm
    running_step: str | None = None
    loop: str | None = None      # "2 / 5" while a run loops
    message: str | None = None   # why there is no robot (connection error), else None
    ready: bool = False          # connected and prepared: motions may start
    read_at: float = 0.0         # when the controller last sent fresh data (time.time(), s)
    age: float = 0.0             # how old that data was when read (RobotStatus.age, s): a frozen stream grows it


#: The driver's command-line hints and the screen's own words for them: its buttons.
SCREEN_HINTS = {UNLOCK_HINT: "(press Unlock)", POWER_ON_HINT: "(press Power on, then Brake release)"}


def error_text(text: str) -> str:
    """An error's one line as the screen shows it: the driver's hints to type `ur3dq robot unlock` or call
    robot.unlock_protective_stop() point at the screen's buttons instead (the exception keeps its text)."""
    for hint, screen in SCREEN_HINTS.items():
        text = text.replace(hint, screen)
    return text


def state_message(snapshot: Snapshot, units: u.Units, control: dict[str, bool | str | int | None]) -> dict[str, Any]:
    """The `state` message of one page: the snapshot with its numbers in `units` and who has control.

    Stale data (older than STALE_AFTER) claims no mode: the robot, safety and program modes read "UNKNOWN" (the
    page offers Stop, never Run or a jog, on them) and "stale" says for how long nothing came ("no data for
    1.2 s"); the joints and TCP are the last ones read, which the page greys out. "age" is the data's age (s)."""
    joints_text = [readout(q, u.ANGLE, units) for q in snapshot.joints]
    x, y, z, rx, ry, rz = snapshot.tcp_pose
    stale = snapshot.connected and snapshot.age > STALE_AFTER
    modes = ("UNKNOWN",) * 3 if stale else (snapshot.robot_mode, snapshot.safety_mode, snapshot.program)
    return {
        "type": "state", "connected": snapshot.connected, "robot_mode": modes[0], "safety_mode": modes[1],
        "program": modes[2], "joints": list(snapshot.joints), "joints_text": joints_text,
        "tcp_text": [readout(v, u.LENGTH, units) for v in (x, y, z)] + [readout(v, u.ANGLE, units) for v in
                                                                        (rx, ry, rz)],
        "arm": snapshot.placed, "speed_slider": snapshot.speed_slider, "freedrive": snapshot.freedrive,
        "inputs": snapshot.inputs, "outputs": snapshot.outputs,
        "activity": snapshot.activity, "running_step": snapshot.running_step, "loop": snapshot.loop,
        "message": snapshot.message, "ready": snapshot.ready, "read_at": snapshot.read_at, "age": snapshot.age,
        "stale": f"no data for {u.show(snapshot.age, u.DURATION, digits=1)}" if stale else None, "control": control,
    }


def step_row(step: Step, units: u.Units) -> dict[str, Any]:
    """One program step as the list shows it: name, kind, move type, speed and blend in `units`, details."""
    row = {"name": step.name, "kind": step.kind, "move": None, "speed": "", "blend": "", "details": "",
           "waypoint": is_waypoint(step), "recorded": isinstance(step, Waypoint)}
    if is_waypoint(step):
        motion = step.motion
        angular = u.angular_kind(motion.move)
        row["move"] = motion.move
        row["speed"] = "default" if motion.speed is None else u.show(motion.speed, u.SPEED[angular], units)
        row["blend"] = "default" if motion.blend is None else u.show(motion.blend, u.LENGTH, units)
        if isinstance(step, RelativeWaypoint):
            offset = ", ".join(u.show(v, u.LENGTH, units) for v in step.offset[:3])
            turn = ", ".join(u.show(v, u.ANGLE, units) for v in step.offset[3:])
            row["details"] = f"from {step.base} ({step.frame} frame): {offset}" + (
                f"; turn {turn}" if any(step.offset[3:]) else "")
    else:
        row["details"] = describe(step)
    return row


def program_message(steps: list[Step], units: u.Units, editor_state: dict[str, bool | str],
                    frames: list[dict[str, Any]], source: str, store_error: str | None = None) -> dict[str, Any]:
    """The `program` message: every step's row, the undo/redo state, the poses' frames for the 3D view, and while
    the store file does not read `store_error` (the file, the problem and the fix; `steps` are then the last good
    ones, shown but not run)."""
    return {"type": "program", "steps": [step_row(step, units) for step in steps], "source": source,
            "frames": frames, "store_error": store_error, **editor_state}


def check_message(result: PathCheckResult | None, model: URModel, cell: Cell | None, margins: Margins,
                  start_name: str | None = None, error: str | None = None,
                  error_step: str | None = None) -> dict[str, Any]:
    """The `check` message of a path check `result` (kept samples) of the program on `model` in `cell`: a verdict
    per step, the problems, and each move's sampled TCP path with its clearance per sample (m, the smallest of
    self-collision and cell margins: the page colours by it). `error` (a planning error naming `error_step`) stands
    for a check that could not run. Each problem's message and hint are units.worded texts with their "measured"
    values, and "refusal" is the wording of the error refusing a run along a failed path: post the message with
    check_for_page, which writes them in a page's units."""
    if error is not None:
        return {"type": "check", "ok": False, "summary": error, "error": True, "from": start_name,
                "problems": [{"step": error_step, "line": error, "tcp": None, "check": "plan"}],
                "verdicts": {error_step: "fail"} if error_step else {}, "paths": [], "smallest_clearance": None}
    assert result is not None, "a check message needs the check's result or its error"
    failed = {problem.step for problem in result.problems}
    checker = StepChecker(model, cell, margins)
    paths = []
    verdicts = {}
    for report in result.steps:
        verdicts[report.name] = "fail" if report.name in failed else "ok"
        if report.tcp is None or report.joints is None or not len(report.tcp):
            continue
        pick = np.unique(np.linspace(0, len(report.tcp) - 1, min(len(report.tcp), MAX_PATH_POINTS)).astype(int))
        own, cell_margins = checker.clearance_margins(report.joints[pick])
        clearance = np.min(np.concatenate([own, cell_margins, np.full((len(pick), 1), np.inf)], axis=1), axis=1)
        paths.append({"step": report.name, "points": np.round(report.tcp[pick], 5).tolist(),
                      "clearance": [None if not np.isfinite(c) else round(float(c), 5) for c in clearance]})
    for name in result.unchecked:
        verdicts[name] = "fail"
    smallest = result.steps.smallest_margins()
    clearances = [value for check, (value, _) in smallest.items() if check in ("self_collision", "cell")]
    return {"type": "check", "ok": result.ok, "summary": result.summary(), "from": start_name,
            "problems": [{"step": p.step, "tcp": list(p.tcp), "check": p.check, "fraction": p.fraction,
                          "message": p.what, "hint": p.fix, "measured": p.measured} for p in result.problems],
            "verdicts": verdicts, "paths": paths, "smallest_clearance": min(clearances) if clearances else None,
            "refusal": None if result.ok else result.summary_wording()}


def check_for_page(message: dict[str, Any], units: u.Units) -> dict[str, Any]:
    """A `check` message (check_message) as a page in `units` reads it: the smallest clearance, and each problem's
    message, hint and line (Problem.line's words) with their numbers and the TCP position in `units`."""
    value = message.get("smallest_clearance")
    problems = [problem_for_page(problem, units) for problem in message["problems"]]
    smallest = "" if value is None else f"smallest clearance {readout(value, u.LENGTH, units)}"
    return {**{key: shown for key, shown in message.items() if key != "refusal"}, "problems": problems,
            "smallest": smallest}


def problem_for_page(problem: dict[str, Any], units: u.Units) -> dict[str, Any]:
    """One problem of a `check` message with its message, hint and line in `units` (a planning error's line as it
    is)."""
    if problem.get("tcp") is None or "message" not in problem:
        return problem
    measured = problem.get("measured", ())
    message, hint = u.worded(problem["message"], measured, units), u.worded(problem["hint"], measured, units)
    where = u.position_text(problem["tcp"], units)
    line = f"step {problem['step']!r} at {problem['fraction']:.0%} of the move (TCP {where}): {message}; {hint}"
    return {**{key: shown for key, shown in problem.items() if key != "measured"}, "message": message, "hint": hint,
            "line": line}
