"""A planned ur3dq cell program as a PolyScope program tree (`ur3dq export-urp`; docs/polyscope.md).

The tree mirrors the program: one Move container per run of waypoints of one move type (MoveJ, MoveL, MoveP),
each waypoint a fixed waypoint named as in the store with its planned joints, its taught TCP offset and the
calibration of the arm it was planned on; the run's speed and acceleration as the Move's, a waypoint's own speed,
acceleration and blend (as planned: clamped, and no blend before an action) as its motion parameters;
Set nodes for outputs, Wait nodes for waits, a message Popup for a message, Comment nodes for comments, a Script
node for a kept script. A step PolyScope does not name (an output, a wait, ...) sits in a Folder named as the step,
unless its name is already the pendant's label of the node (as an import names it). What PolyScope cannot hold
(a relative waypoint's base and offset, a note, an input wait's timeout) goes in an `ur3dq: {...}` comment right
before the node, so that importing the file gives the same program back.

The layout is that of PolyScope's own files (URCL's test programs: CB3 3.15 as plain XML, e-series 5.12 gzip).
"""
from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from xml.etree.ElementTree import Element

from polyscope_format.urp_file import ProgramTree
from polyscope_format.urp_xml import doubles, element, file_bytes, java_double
from ur3dq.kinematics.models import URModel
from ur3dq.polyscope.annotations import ANNOTATION, RUN_DEFAULTS
from ur3dq.polyscope.kinematics import SavedKinematics
from ur3dq.polyscope.nodes import Program
from ur3dq.program.plan import PlannedStep
from ur3dq.program.steps import (
    MAX_WAIT_S,
    AnalogOut,
    Comment,
    DigitalOut,
    KeptScript,
    Message,
    RelativeWaypoint,
    Step,
    Wait,
    WaitInput,
    Waypoint,
)

# The versions and attributes of the programs PolyScope saved that the layout follows (URCL's wait_program.urp).
CB3_VERSION = "3.15.8.106339"
E_SERIES_VERSION = "5.12.4.1101661"
MOVE_TYPES = {"joint": "MoveJ", "linear": "MoveL", "process": "MoveP"}
PIN_FAMILIES = {"standard": "digital", "configurable": "config", "tool": "tool"}
BASE_FEATURE = "Joint_0_name"   # PolyScope's name of the robot's base feature
ZERO_POSE = "0.0, 0.0, 0.0, 0.0, 0.0, 0.0"
_NO_TREE = ProgramTree(Element("URProgram"), {}, "export")


@dataclass(frozen=True)
class MoveDefaults:
    """The speeds and accelerations of the Move containers: the run's defaults, which a waypoint that sets none
    of its own takes (an `ur3dq:` comment first in the Move says so). Joint: rad/s, rad/s²; linear/process: m/s,
    m/s²."""

    joint_speed: float = 1.05
    joint_acceleration: float = 1.4
    tcp_speed: float = 0.25
    tcp_acceleration: float = 1.2

    def of(self, move: str) -> tuple[float, float]:
        """(speed, acceleration) of a Move of `move`."""
        if move == "joint":
            return self.joint_speed, self.joint_acceleration
        return self.tcp_speed, self.tcp_acceleration


def is_e_series(model: URModel) -> bool:
    """True for the e-series (PolyScope 5), False for CB3 arms (PolyScope 3.x)."""
    return model.name.endswith("e")


def export_bytes(plan: Sequence[PlannedStep], program: Sequence[Step], name: str, model: URModel,
                 defaults: MoveDefaults = MoveDefaults(), serial: str | None = None) -> bytes:
    """The `.urp` file of `plan` (plan_program's steps of `program`, or of a --from/--to part of it) planned on
    `model`: the same plan always gives the same bytes (gzip for an e-series arm, plain XML for CB3).

    Parameters
    ----------
    plan : sequence of PlannedStep
        The steps to write, each waypoint with its planned joints, move type, speed, acceleration and blend.
    program : sequence of Step
        The whole program (a relative waypoint's base may lie outside the part written).
    name : str
        The program's name (PolyScope shows the file's name).
    model : URModel
        The arm the plan was made on; its DH is written as the calibration.
    defaults : MoveDefaults
        The Move containers' speeds and accelerations.
    serial : str, optional
        The robot's serial number, written when known.
    """
    return file_bytes(program_tree(plan, program, name, model, defaults, serial), compressed=is_e_series(model))


def program_tree(plan: Sequence[PlannedStep], program: Sequence[Step], name: str, model: URModel,
                 defaults: MoveDefaults = MoveDefaults(), serial: str | None = None) -> Element:
    """The `<URProgram>` element of `plan` (see export_bytes)."""
    e_series = is_e_series(model)
    version = E_SERIES_VERSION if e_series else CB3_VERSION
    attributes = {"name": name, "installation": "default", "installationRelativePath": "default",
                  "directory": "/programs", "createdIn": version, "lastSavedIn": version}
    if serial:
        attributes["robotSerialNumber"] = serial
    writer = TreeWriter(model, defaults, e_series)
    main = element("MainProgram", {"runOnlyOnce": "true", "InitVariablesNode": "false"},
                   [element("children", children=writer.body(plan))])
    return element("URProgram", attributes, [kinematics_element("kinematics", SavedKinematics.of_model(model)),
                                             element("children", children=[main])])


def kinematics_element(tag: str, saved: SavedKinematics) -> Element:
    """`<kinematics>` (a program's) or `<Kinematics>` (a waypoint's) holding `saved`."""
    columns = [element("deltaTheta", {"value": doubles(saved.theta)}), element("a", {"value": doubles(saved.a)}),
               element("d", {"value": doubles(saved.d)}), element("alpha", {"value": doubles(saved.alpha)}),
               element("jointChecksum", {"value": "-1, -1, -1, -1, -1, -1"})]
    return element(tag, {"status": saved.status, "validChecksum": "true" if saved.valid_checksum else "false"},
                   columns)


class TreeWriter:
    """Writes the main program's nodes of a plan (one writer per export)."""

    def __init__(self, model: URModel, defaults: MoveDefaults, e_series: bool) -> None:
        self.kinematics = SavedKinematics.of_model(model)
        self.defaults = defaults
        self.e_series = e_series
        self.labels = Program(_NO_TREE)

    def body(self, plan: Sequence[PlannedStep]) -> list[Element]:
        """The nodes of `plan` in order: a Move per run of waypoints of one move type."""
        nodes: list[Element] = []
        move: Element | None = None
        for index, planned in enumerate(plan):
            step = planned.step
            if planned.move is not None:
                if move is None or move.get("motionType") != MOVE_TYPES[planned.move]:
                    move = self._move(planned.move)
                    nodes.append(move)
                _append(move, self.waypoint(planned))
                continue
            inside = isinstance(step, Comment) and move is not None and \
                _next_move(plan, index) == move.get("motionType")
            if inside and move is not None:
                _append(move, self.action(step))
            else:
                move = None
                nodes.extend(self.action(step))
        return nodes

    def _move(self, kind: str) -> Element:
        speed, acceleration = self.defaults.of(kind)
        attributes = {"motionType": MOVE_TYPES[kind], "speed": java_double(speed),
                      "acceleration": java_double(acceleration), "useActiveTCP": "false"}
        if self.e_series:
            attributes["positionType"] = "CartesianPose"
        feature = element("feature", {"class": "GeomFeatureReference", "referencedName": BASE_FEATURE})
        defaults = _annotated({RUN_DEFAULTS: {"speed": speed, "acceleration": acceleration}})
        return element("Move", attributes, [feature, element("children", children=defaults)])

    def waypoint(self, planned: PlannedStep) -> list[Element]:
        """The waypoint's node, after the `ur3dq:` comment of a relative waypoint or a note."""
        step = planned.step
        assert isinstance(step, (Waypoint, RelativeWaypoint))
        assert planned.joints is not None and planned.tcp_offset is not None and planned.move is not None
        annotation: dict[str, object] = {}
        if isinstance(step, RelativeWaypoint):
            annotation = {"relative to": step.base, "offset": list(step.offset), "frame": step.frame}
            if step.note:
                annotation["note"] = step.note
        elif isinstance(step, Waypoint) and step.pose.note:
            annotation = {"note": step.pose.note}
        motion = step.motion
        prefix = "joint" if planned.move == "joint" else "cartesian"
        parameters: dict[str, str] = {}   # what the waypoint sets itself, as planned (clamped); the rest its Move's
        if motion.speed is not None and planned.speed is not None:
            parameters[prefix + "Speed"] = java_double(planned.speed)
        if motion.acceleration is not None and planned.acceleration is not None:
            parameters[prefix + "Acceleration"] = java_double(planned.acceleration)
        if motion.blend is not None or planned.blend > 0:
            parameters["blendRadius"] = java_double(planned.blend)
        position = element("position", children=[
            element("JointAngles", {"angles": doubles(planned.joints.tolist())}),
            element("TCPOffset", {"pose": doubles(planned.tcp_offset)}),
            kinematics_element("Kinematics", self.kinematics)])
        node = element("Waypoint", {"type": "Fixed", "name": step.name, "kinematicsFlags": "4"},
                       [element("motionParameters", parameters), position,
                        element("BaseToFeature", {"pose": ZERO_POSE})])
        return [*_annotated(annotation), node]

    def action(self, step: Step) -> list[Element]:
        """The node of a step that is not a waypoint (in a Folder named as the step unless its label is its
        name), after its `ur3dq:` comment if it needs one."""
        annotation: dict[str, object] = {}
        if isinstance(step, WaitInput) and step.timeout != MAX_WAIT_S:
            annotation = {"timeout": step.timeout}
        node = action_node(step)
        nodes = [*_annotated(annotation), node]
        if self.labels.label(node) == step.name:
            return nodes
        return [element("Folder", {"name": step.name}, [element("children", children=nodes)])]


def action_node(step: Step) -> Element:
    """The PolyScope node of an action, comment or kept-script step."""
    if isinstance(step, DigitalOut):
        pin = f"{PIN_FAMILIES[step.output]}_out[{step.pin}]"
        return element("Set", {"type": "DigitalOutput"}, [element("pin", {"referencedName": pin}),
                                                          element("digitalValue", text="1" if step.on else "0")])
    if isinstance(step, AnalogOut):
        return element("Set", {"type": "AnalogOutput"}, [element("pin", {"referencedName": f"analog_out[{step.pin}]"}),
                                                         element("analogValue", text=java_double(step.value))])
    if isinstance(step, Wait):
        return element("Wait", {"type": "Sleep"}, [element("waitTime", text=java_double(step.seconds))])
    if isinstance(step, WaitInput):
        pin = f"{PIN_FAMILIES[step.input]}_in[{step.pin}]"
        return element("Wait", {"type": "DigitalInput"}, [element("pin", {"referencedName": pin}),
                                                          element("digitalValue", text="1" if step.on else "0")])
    if isinstance(step, Message):
        return element("Popup", {"type": "Message", "message": step.text, "haltProgram": "false"})
    if isinstance(step, Comment):
        return element("Comment", {"comment": step.text})
    if isinstance(step, KeptScript):
        return element("Script", {"type": "File"}, [element("cachedContents", text=step.script),
                                                     element("file", {"resolves-to": "file"},
                                                             text=_script_file_name(step.name))])
    raise TypeError(f"no PolyScope node for step {step!r}")


def _script_file_name(name: str) -> str:
    cleaned = "".join(char if char.isalnum() or char in "-_" else "_" for char in name)
    return (cleaned or "kept") + ".script"


def _annotated(annotation: dict[str, object]) -> list[Element]:
    if not annotation:
        return []
    return [element("Comment", {"comment": ANNOTATION + json.dumps(annotation, ensure_ascii=False)})]


def _append(node: Element, nodes: list[Element]) -> None:
    """Add `nodes` to `node`'s `<children>`."""
    holder = node.find("children")
    assert holder is not None
    holder.extend(nodes)


def _next_move(plan: Sequence[PlannedStep], index: int) -> str | None:
    """The Move type of the first waypoint after `index` with only comments between, else None."""
    for planned in plan[index + 1:]:
        if planned.move is not None:
            return MOVE_TYPES[planned.move]
        if not isinstance(planned.step, Comment):
            return None
    return None
