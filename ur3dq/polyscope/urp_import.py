"""A PolyScope program tree as a ur3dq cell program: one step per node that has a counterpart, the rest refused
by their place in the tree, or kept as URScript (docs/polyscope.md, "ur3dq's import and export").

Move containers and their waypoints become waypoints (recorded joints, TCP offset, the TCP pose those give on the
arm the program was saved on, the Move's or the waypoint's own speed, acceleration and blend); a PolyScope relative
waypoint becomes a relative waypoint on the waypoint before it; Set (digital and analog outputs), Wait (a time, a
digital input), a Message popup, comments and folders (their names as comment steps, their nodes flattened)
become the matching steps; a BeforeStart sequence runs first. Every other node (If, Loop, Script, Assignment,
Thread, sub-program calls, URCap nodes, variables, ...) is refused by its path (`Robot Program/Folder 2/If
digital_in[0]`) — or, with `keep_script`, kept as a kept-script step: URScript generated as PolyScope would.

Steps without a name in PolyScope are named as the pendant labels them (`Wait 0.5`, `Set tool_out[0]=On`); a
folder holding one such node gives it its name. A comment starting `ur3dq: ` holds what PolyScope cannot (a
relative waypoint's base and offset, a note, an input wait's timeout) for the node after it, as a JSON object.
"""
from __future__ import annotations

import math
import unicodedata
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import Element

from polyscope_format.nodes import digital_on, if_kind, split_pin
from polyscope_format.urp_file import ProgramTree, UrpFormatError
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.kinematics.models import URModel
from ur3dq.polyscope.annotations import annotation_of, relative_from_annotations, run_defaults_of
from ur3dq.polyscope.kept_script import KeptScriptWriter
from ur3dq.polyscope.kinematics import SavedKinematics
from ur3dq.polyscope.nodes import NodeError, Program, number_field
from ur3dq.polyscope.urp_file import UrpFileError
from ur3dq.pose import Pose, name_problem, next_free_name, numbering_prefix
from ur3dq.program.plan import check_motion_range
from ur3dq.program.resolve import offset_pose
from ur3dq.program.steps import (
    ANALOG_PIN_COUNT,
    MAX_MESSAGE_LENGTH,
    MAX_WAIT_S,
    PIN_COUNT,
    AnalogOut,
    Comment,
    DigitalOut,
    KeptScript,
    Message,
    Motion,
    RelativeWaypoint,
    Step,
    Wait,
    WaitInput,
    Waypoint,
)
from ur3dq.units import DURATION, Units, show

MOVE_TYPES = {"MoveJ": "joint", "MoveL": "linear", "MoveP": "process"}
PIN_KINDS = {"digital": "standard", "config": "configurable", "tool": "tool"}
MOTION_PARAMETERS = ("jointSpeed", "jointAcceleration", "cartesianSpeed", "cartesianAcceleration", "blendRadius")
BASE_FEATURES = ("Joint_0_name", "Base", "base")
# Build one step once its name is known; `previous` is the last waypoint built so far (name, TCP pose) or None.
Build = Callable[[str, "tuple[str, DualQuaternion] | None"], Step]


class UnsupportedNodes(ValueError):
    """Nodes ur3dq has no step for, each named by its path; the import changed nothing."""

    def __init__(self, source: str, problems: list[NodeError], keep_script: bool, keepable: int = 0) -> None:
        shown = "; ".join(f"{problem.path} ({problem.reason})" for problem in problems[:8])
        more = f"; and {len(problems) - 8} more" if len(problems) > 8 else ""
        them = "them" if keepable == len(problems) else f"{keepable} of them"
        fix = f": import with --keep-script to keep {them} as URScript (not path-checked)" \
            if keepable and not keep_script else ""
        count = f"{len(problems)} node{'s' if len(problems) > 1 else ''}"
        super().__init__(f"{source}: {count} without a ur3dq step: {shown}{more}{fix}")
        self.problems = problems


@dataclass
class Entry:
    """One step-to-be: where it came from, its pendant label, its PolyScope name (if any), how to build it."""

    path: str
    label: str
    name: str | None
    build: Build
    waypoint: bool = False
    annotation: dict[str, object] | None = None


@dataclass
class Imported:
    """What an import gives: the steps, warnings (one line each), the kept-script steps' names, the arm."""

    steps: list[Step]
    warnings: list[str]
    kept: list[str]
    model: URModel
    saved: SavedKinematics | None
    joints: list[tuple[float, ...]] = field(default_factory=list)
    tcp_offsets: list[tuple[float, ...]] = field(default_factory=list)


class Importer:
    """Turns one program tree into steps (see the module docstring); `model` is the arm it was saved on."""

    def __init__(self, program: Program, model: URModel, keep_script: bool, origin: str) -> None:
        self.program = program
        self.model = model
        self.keep_script = keep_script
        self.origin = origin
        self.problems: list[NodeError] = []
        self.keepable = 0   # how many of the problems --keep-script would keep
        self.warnings: list[str] = []
        self.kept: set[int] = set()
        self.kept_writer = KeptScriptWriter(program, self.position)
        self.recorded: list[tuple[tuple[float, ...], tuple[float, ...]]] = []
        self.models: dict[SavedKinematics, URModel] = {}
        self.after_waypoint = False   # walking the tree: a waypoint came last (a relative one moves from it)
        self.tcps: dict[tuple[float, ...], DualQuaternion] = {}

    # ------------------------------------------------------------------------------------------ tree walk
    def top_level(self) -> list[Entry]:
        """The entries of the whole program: BeforeStart's nodes, threads (kept), then the main program's."""
        children = self.program.tree.root.find("children")
        if children is None:
            raise NodeError(self.program.tree.source, "not a PolyScope program (<URProgram> has no <children>)")
        main, entries, threads = None, [], []
        for element in children:
            node = self.program.tree.resolve(element) if element.tag != "SubProgram" else element
            path = self.program.label(node)
            if node.tag == "MainProgram":
                main = node
            elif node.tag == "SpecialSequence" and node.get("type", "BeforeStart") == "BeforeStart":
                entries.extend(self.folder(node, path, "BeforeStart"))
            elif node.tag in ("InitVariablesNode", "Thread", "SpecialSequence"):
                if node.tag != "InitVariablesNode" or self.program.children(node):
                    threads.extend(self.unsupported([node], "", "variables and threads have no ur3dq step"))
            elif node.tag != "SubProgram":
                self.problems.append(NodeError(path, f"top-level node <{node.tag}> has no ur3dq step"))
        if main is None:
            raise NodeError(self.program.tree.source, "not a PolyScope program (it has no MainProgram node)")
        if main.get("runOnlyOnce", "false").lower() != "true":
            self.warnings.append("the program loops forever on the pendant (Robot Program without 'Program Loops "
                                 "Forever' unticked); ur3dq runs it once")
        return threads + entries + self.block(self.program.children(main), "Robot Program")

    def block(self, nodes: list[Element], parent: str) -> list[Entry]:
        """The entries of `nodes` in order; an `ur3dq: ` comment goes to the entry of the node after it."""
        entries: list[Entry] = []
        annotation: dict[str, object] | None = None
        index = 0
        while index < len(nodes):
            node = nodes[index]
            chain = [node]
            if if_kind(node) == "If":
                while index + 1 < len(nodes) and if_kind(nodes[index + 1]) in ("ElseIf", "Else"):
                    index += 1
                    chain.append(nodes[index])
            index += 1
            found = annotation_of(node)
            if found is not None and index < len(nodes):
                annotation = found
                continue
            made = self.node(chain, parent)
            if annotation is not None and made:
                made[0].annotation, annotation = annotation, None
            entries.extend(made)
        return entries

    def node(self, chain: list[Element], parent: str) -> list[Entry]:
        node = chain[0]
        path = self.program.path_to(parent, node)
        try:
            handler = _HANDLERS.get(node.tag)
            if handler is None or len(chain) > 1 or if_kind(node):
                raise NodeError(path, "has no ur3dq step")
            return handler(self, node, path)
        except NodeError as error:
            return self.unsupported(chain, parent, error.reason)

    def unsupported(self, chain: list[Element], parent: str, reason: str,
                    move: Element | None = None) -> list[Entry]:
        """A kept-script entry for `chain` (a waypoint of `move`) with --keep-script, if ur3dq can write its
        URScript; else a problem."""
        path = self.program.path_to(parent, chain[0])
        try:
            script = self.kept_writer.waypoint_script(move, chain[0], path) if move is not None else \
                self.kept_writer.script(chain, path)
        except NodeError as error:
            self.problems.append(error if self.keep_script else
                                 NodeError(path, f"{reason}; --keep-script cannot keep it: {error.reason}"))
            return []
        if not self.keep_script:
            self.problems.append(NodeError(path, reason))
            self.keepable += 1
            return []
        origin = f"{self.origin}: {path}"
        self.after_waypoint = False   # where a kept script leaves the arm is not known

        def build(name: str, previous: object) -> Step:
            return KeptScript(name, script, origin)

        return [Entry(path, self.program.label(chain[0]), None, build)]

    def folder(self, node: Element, path: str, name: str | None = None) -> list[Entry]:
        """A folder's nodes flattened after a comment step naming it; a folder of one nameless node names it."""
        name = name or node.get("name") or "Folder"
        inner = self.block(self.program.children(node), path)
        if len(inner) == 1 and inner[0].name is None and not inner[0].waypoint:
            inner[0].name = name
            return inner
        return [Entry(path, name, name, lambda step_name, previous: Comment(step_name, name)), *inner]

    # ------------------------------------------------------------------------------------------ nodes
    def comment(self, node: Element, path: str) -> list[Entry]:
        raw = node.get("comment") or node.findtext("comment") or ""
        text = "".join(" " if unicodedata.category(char).startswith("C") else char for char in raw)
        return [Entry(path, self.program.label(node), None, lambda name, previous: Comment(name, text))]

    def set_output(self, node: Element, path: str) -> list[Entry]:
        kind = node.get("type", "DigitalOutput")
        _only_children(node, path, ("pin", "digitalValue", "analogValue"))
        if kind == "DigitalOutput":
            family, pin = split_pin(self.program.pin(node, path))
            output = PIN_KINDS.get(family.removesuffix("_out")) if family.endswith("_out") else None
            if output is None or pin >= PIN_COUNT[output]:
                raise NodeError(path, f"output {family}[{pin}] has no ur3dq step (digital_out, config_out and "
                                      "tool_out pins only)")
            on = digital_on(node)
            return [Entry(path, self.program.label(node), None,
                          lambda name, previous: DigitalOut(name, output, pin, on))]
        if kind == "AnalogOutput":
            family, pin = split_pin(self.program.pin(node, path))
            value = number_field(node, "analogValue", path)
            if family != "analog_out" or pin >= ANALOG_PIN_COUNT or not 0.0 <= value <= 1.0:
                raise NodeError(path, "only analog_out[0..1] set to a fraction 0..1 of its range has a ur3dq step")
            return [Entry(path, self.program.label(node), None,
                          lambda name, previous: AnalogOut(name, pin, value))]
        raise NodeError(path, f"a Set of type {kind!r} has no ur3dq step")

    def wait(self, node: Element, path: str) -> list[Entry]:
        kind = node.get("type", "Sleep")
        label = self.program.label(node)
        if kind == "Sleep":
            seconds = number_field(node, "waitTime", path)
            if not 0 < seconds <= MAX_WAIT_S:
                raise NodeError(path, f"a wait of {show(seconds, DURATION)} has no ur3dq step (more than 0, at most "
                                      "a day)")
            return [Entry(path, label, None, lambda name, previous: Wait(name, seconds))]
        if kind == "DigitalInput":
            family, pin = split_pin(self.program.pin(node, path))
            source = PIN_KINDS.get(family.removesuffix("_in")) if family.endswith("_in") else None
            if source is None or pin >= PIN_COUNT[source]:
                raise NodeError(path, f"input {family}[{pin}] has no ur3dq step (digital_in, config_in and tool_in "
                                      "pins only)")
            on = digital_on(node)

            def wait_input(name: str, previous: object) -> Step:
                timeout = (entry.annotation or {}).get("timeout", MAX_WAIT_S)   # the export's annotation, if any
                if timeout == MAX_WAIT_S:
                    self.warnings.append(f"{path}: PolyScope waits for the input for ever; ur3dq fails the run "
                                         "after a day")
                return WaitInput(name, source, pin, on, timeout)  # type: ignore[arg-type]  # WaitInput checks it

            entry = Entry(path, label, None, wait_input)
            return [entry]
        raise NodeError(path, f"a wait for {'an analog input' if kind == 'AnalogInput' else 'a condition'} has no "
                              "ur3dq step")

    def popup(self, node: Element, path: str) -> list[Entry]:
        text = node.get("message") or node.findtext("message") or ""
        if node.get("type", "Message") != "Message" or node.get("haltProgram", "false").lower() == "true":
            raise NodeError(path, "only a message popup that does not halt has a ur3dq step")
        if not text or len(text) > MAX_MESSAGE_LENGTH:
            raise NodeError(path, f"a popup text of 1 to {MAX_MESSAGE_LENGTH} characters has a ur3dq step")
        self.warnings.append(f"{path}: the pendant waits for the operator at a popup; ur3dq logs the text and goes "
                             "on")
        return [Entry(path, self.program.label(node), None, lambda name, previous: Message(name, text))]

    def move(self, node: Element, path: str) -> list[Entry]:
        kind = node.get("motionType", "MoveJ")
        if kind not in MOVE_TYPES:
            raise NodeError(path, f"a {kind} has no ur3dq step (MoveJ, MoveL and MoveP have)")
        feature = node.find("feature")
        base_feature = feature is None or (feature.get("referencedName") or "Joint_0_name") in BASE_FEATURES
        if node.find("tcp") is not None:
            self.warnings.append(f"{path}: the Move names a TCP of the installation; ur3dq moves each waypoint "
                                 "with the TCP offset it was taught with")
        entries: list[Entry] = []
        children = self.program.children(node)
        run_defaults = run_defaults_of(node, children)
        if run_defaults:
            children = children[1:]
        others: list[Element] = []   # the nodes between two waypoints: a block (with their annotations)
        for child in children:
            if child.tag != "Waypoint":
                others.append(child)
                continue
            annotation = annotation_of(others[-1]) if others else None
            if annotation is not None:
                others.pop()
            entries.extend(self.block(others, path))
            others = []
            child_path = self.program.path_to(path, child)
            try:
                entry = self.waypoint(node, child, child_path, base_feature, run_defaults)
                entry.annotation = annotation
                entries.append(entry)
            except NodeError as error:
                entries.extend(self.unsupported([child], path, error.reason, move=node))
        return entries + self.block(others, path)

    def waypoint(self, move: Element, node: Element, path: str, base_feature: bool,
                 run_defaults: bool = False) -> Entry:
        """A Fixed waypoint (its recorded position) or a Relative one (on the waypoint before it); with
        `run_defaults`, what the waypoint does not set itself is left to the run's defaults (a ur3dq export)."""
        kind = node.get("type", "Fixed")
        motion = self._motion(move, node, path, run_defaults)
        name = node.get("name")
        name = name if name and name_problem(name) is None else None
        label = self.program.label(node)
        if kind == "Fixed":
            q, tcp, pose = self.position(_required(node, "position", path), path)
            self.recorded.append((tuple(q), tuple(tcp)))
            dq = DualQuaternion.from_ur_pose(pose)

            def fixed(step_name: str, previous: object) -> Step:
                note = (entry.annotation or {}).get("note", "")
                recorded = Pose.from_dual_quaternion(step_name, dq, self.model.name, joints=tuple(q),
                                                     tcp_offset=tuple(tcp), note=note)
                return Waypoint(step_name, recorded, motion)

            entry = Entry(path, label, name, fixed, waypoint=True)
            self.after_waypoint = True
            return entry
        if kind == "Relative":
            if not self.after_waypoint:
                raise NodeError(path, "a relative waypoint with no waypoint before it moves from wherever the arm "
                                      "is: no ur3dq step")
            if not base_feature:
                raise NodeError(path, "a relative waypoint of a Move on a feature other than the base has no "
                                      "ur3dq step")
            start = DualQuaternion.from_ur_pose(self.position(_required(node, "fromPosition", path), path)[2])
            end = DualQuaternion.from_ur_pose(self.position(_required(node, "toPosition", path), path)[2])

            def relative(step_name: str, previous: tuple[str, DualQuaternion] | None) -> Step:
                if previous is None:
                    raise NodeError(path, "a relative waypoint with no waypoint before it moves from wherever the "
                                          "arm is: no ur3dq step")
                return RelativeWaypoint(step_name, previous[0], _polyscope_offset(previous[1], start, end), "base",
                                        motion)

            self.after_waypoint = True
            return Entry(path, label, name, relative, waypoint=True)
        raise NodeError(path, f"a {kind} waypoint has no ur3dq step (variables have none)")

    def _motion(self, move: Element, node: Element, path: str, run_defaults: bool) -> Motion:
        """The waypoint's move type, speed, acceleration and blend: its own parameters, else its Move's (or, with
        `run_defaults`, None: the run's)."""
        kind = move.get("motionType", "MoveJ")
        joint = kind == "MoveJ"
        speed: float | None = None
        acceleration: float | None = None
        blend: float | None = None
        if not run_defaults:
            speed = number_field(move, "speed", path) if move.get("speed") else \
                (1.0471975511965976 if joint else 0.25)
            acceleration = number_field(move, "acceleration", path) if move.get("acceleration") else \
                (1.3962634015954636 if joint else 1.2)
            blend = number_field(move, "blendRadius", path) if move.get("blendRadius") else 0.0
        parameters = node.find("motionParameters")
        if parameters is not None:
            unknown = sorted(set(parameters.attrib) - set(MOTION_PARAMETERS))
            if unknown:
                raise NodeError(path, f"motion parameter {unknown[0]!r} has no ur3dq counterpart")
            prefix = "joint" if joint else "cartesian"
            if parameters.get(prefix + "Speed"):
                speed = number_field(parameters, prefix + "Speed", path)
            if parameters.get(prefix + "Acceleration"):
                acceleration = number_field(parameters, prefix + "Acceleration", path)
            if parameters.get("blendRadius"):
                blend = number_field(parameters, "blendRadius", path)
        try:
            motion = Motion(MOVE_TYPES[kind], speed, acceleration, blend)
            # the range `poses set` allows: a file is an editor too (the plan would only lower it, with a warning)
            check_motion_range(motion, self.model, "the waypoint", Units(length="mm"))   # as the pendant shows
        except ValueError as error:
            raise NodeError(path, str(error).removeprefix("motion: ")) from None
        return motion

    def position(self, element: Element, path: str) -> tuple[list[float], list[float], list[float]]:
        """(joints, TCP offset, TCP pose) of a recorded position: 5.x `<JointAngles>`, `<TCPOffset>` and its own
        `<Kinematics>` (the pose by forward kinematics on the arm it was recorded on), or 3.x `joints`/`pose`."""
        element = self.program.tree.resolve(element)
        angles = element.find("JointAngles")
        q = _numbers(angles.get("angles") if angles is not None else element.get("joints"), path, "joint angles")
        offset = element.find("TCPOffset")
        tcp = _numbers(offset.get("pose") if offset is not None else None, path, "TCP offset")
        pose = _numbers(element.get("pose"), path, "pose")
        if q is None:
            raise NodeError(path, "the waypoint records no joint angles")
        model = self._model_of(SavedKinematics.read(element.find("Kinematics")))
        if tcp is None:   # 3.x: the TCP offset is what turns the flange at q into the recorded pose
            flange = model.fk_flange(q)
            tcp = list((flange.inverse() * DualQuaternion.from_ur_pose(pose)).to_ur_pose()) if pose else [0.0] * 6
        if pose is None:
            flange = model.fk_flange(q)
            pose = list((flange * self._tcp(tuple(tcp))).to_ur_pose())
        return q, tcp, pose

    def _model_of(self, saved: SavedKinematics | None) -> URModel:
        """The arm a position was recorded on: its own kinematics when it keeps them (PolyScope 5), else the
        program's (one model per distinct calibration)."""
        if saved is None or saved.model_name() != self.model.name:
            return self.model
        if saved not in self.models:
            self.models[saved] = saved.model(self.model.name)
        return self.models[saved]

    def _tcp(self, offset: tuple[float, ...]) -> DualQuaternion:
        if offset not in self.tcps:
            self.tcps[offset] = DualQuaternion.from_ur_pose(offset)
        return self.tcps[offset]

    # ------------------------------------------------------------------------------------------ names and steps
    def steps(self, entries: list[Entry], taken: Iterable[str]) -> list[Step]:
        """The steps of `entries`, named: PolyScope's names first (made unique against `taken`), then labels."""
        used = set(taken)
        names: list[str | None] = [None] * len(entries)
        for index, entry in enumerate(entries):
            if entry.name is not None:
                names[index] = self._unique(entry.name, used, entry.path, rename_warning=True)
        for index, entry in enumerate(entries):
            if names[index] is None:
                names[index] = self._unique(entry.label, used, entry.path)
        steps: list[Step] = []
        previous: tuple[str, DualQuaternion] | None = None
        targets: dict[str, DualQuaternion] = {}
        for entry, name in zip(entries, names):
            assert name is not None
            try:
                step = entry.build(name, previous)
            except NodeError as error:
                self.problems.append(error)
                continue
            except ValueError as error:
                self.problems.append(NodeError(entry.path, str(error)))
                continue
            steps.append(step)
            if isinstance(step, (Waypoint, RelativeWaypoint)):
                target = step.pose.dq if isinstance(step, Waypoint) else \
                    offset_pose(targets[step.base], step.offset, step.frame)
                targets[name] = target
                previous = (name, target)
            elif isinstance(step, KeptScript):
                previous = None   # where a kept script leaves the arm is not known
        annotated = {name: entry.annotation for entry, name in zip(entries, names) if name is not None
                     and entry.waypoint and entry.annotation and "relative to" in entry.annotation}
        return relative_from_annotations(steps, annotated, self.warnings)

    def _unique(self, wanted: str, used: set[str], path: str, rename_warning: bool = False) -> str:
        name = wanted.strip() or "step"
        if name_problem(name) is not None:
            name = name[:90].strip() or "step"
        if name in used:
            fresh = next_free_name(numbering_prefix(name), used)
            if rename_warning:
                self.warnings.append(f"{path}: the name {name!r} is taken; imported as {fresh!r}")
            name = fresh
        used.add(name)
        return name


def _polyscope_offset(previous: DualQuaternion, start: DualQuaternion, end: DualQuaternion) -> tuple[float, ...]:
    """The base-frame offset (ur3dq's `base` frame) that puts the TCP where PolyScope's relative waypoint does
    from `previous`: `pose_add(previous, pose_sub(end, start))` — positions added, rotation
    previous.R · start.R⁻¹ · end.R."""
    rotation = previous.rotation * start.rotation.inverse * end.rotation
    target = DualQuaternion.from_rotation_translation(rotation, previous.translation + end.translation
                                                      - start.translation)
    turn = DualQuaternion.from_rotation_translation(target.rotation * previous.rotation.inverse, (0.0, 0.0, 0.0))
    return (*(float(v) for v in target.translation - previous.translation), *(float(v) for v in turn.to_ur_pose()[3:]))


def _numbers(text: str | None, path: str, what: str) -> list[float] | None:
    if text is None:
        return None
    try:
        values = [float(part) for part in text.replace(",", " ").split()]
    except ValueError:
        raise NodeError(path, f"the {what} {text!r} are not 6 numbers") from None
    if len(values) != 6 or not all(math.isfinite(v) and abs(v) <= 100 for v in values):
        raise NodeError(path, f"the {what} {text!r} are not 6 plausible numbers")
    return values


def _required(node: Element, tag: str, path: str) -> Element:
    child = node.find(tag)
    if child is None:
        raise NodeError(path, f"the waypoint has no <{tag}>")
    return child


def _only_children(node: Element, path: str, allowed: tuple[str, ...]) -> None:
    unknown = [child.tag for child in node if child.tag not in allowed]
    if unknown:
        raise NodeError(path, f"<{unknown[0]}> in a {node.tag} has no ur3dq counterpart")


_HANDLERS: dict[str, Callable[[Importer, Element, str], list[Entry]]] = {
    "Move": Importer.move, "Set": Importer.set_output, "Wait": Importer.wait, "Popup": Importer.popup,
    "Comment": Importer.comment, "Folder": Importer.folder,
}



def import_program(tree: ProgramTree, model_name: str | None = None, keep_script: bool = False,
                   taken: Iterable[str] = (), pin_aliases: dict[str, str] | None = None) -> Imported:
    """The cell program of a PolyScope program tree.

    Parameters
    ----------
    tree : ProgramTree
        The parsed `.urp` (ur3dq.polyscope.urp_file.read_urp).
    model_name : str, optional
        The UR model, when the program's kinematics do not say (PolyScope 3.x files may carry none).
    keep_script : bool
        Keep nodes without a step as kept-script steps instead of refusing the program.
    taken : iterable of str
        Names already in the program the steps are added to (an imported name that is taken gets `-N`).
    pin_aliases : dict, optional
        {name an installation gave a pin: PolyScope's name of it} (ur3dq.polyscope.urp_file.installation_pin_aliases).

    Raises
    ------
    UnsupportedNodes
        Nodes without a step (or that cannot be kept), each named by its path on the pendant's tree.
    UrpFileError, ValueError
        The program is not one ur3dq can read (no main program, no way to tell the UR model).
    """
    saved = SavedKinematics.read(tree.root.find("kinematics"))
    found = saved.model_name() if saved is not None else None
    name = found or model_name
    if name is None:
        raise ValueError(f"{tree.source}: its kinematics do not say which UR model it was saved on: pass --model")
    model = saved.model(name) if saved is not None and found == name else robot_model(name)
    importer = Importer(Program(tree, pin_aliases or {}), model, keep_script, Path(tree.source).name)
    try:
        entries = importer.top_level()
        steps = importer.steps(entries, taken)
    except (NodeError, UrpFormatError) as error:
        raise UrpFileError(str(error)) from None
    if importer.problems:
        raise UnsupportedNodes(tree.source, importer.problems, keep_script, importer.keepable)
    if not steps:
        raise ValueError(f"{tree.source}: the program has no node ur3dq can import")
    kept = [step.name for step in steps if isinstance(step, KeptScript)]
    if kept:
        importer.warnings.append(f"{len(kept)} step{'s' if len(kept) > 1 else ''} kept as URScript run as "
                                 f"{'they are' if len(kept) > 1 else 'it is'}, not path-checked: "
                                 + ", ".join(repr(name) for name in kept))
    return Imported(steps, importer.warnings, kept, model, saved,
                    [q for q, _ in importer.recorded], [tcp for _, tcp in importer.recorded])
