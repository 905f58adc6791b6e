"""Move containers and their waypoints, as PolyScope turns them into URScript motion commands.

A `<Move motionType="MoveJ|MoveL|MoveP" speed= acceleration= useActiveTCP=...>` holds waypoints (and possibly other
nodes, run in order between them). Each waypoint is one motion with the Move's speed and acceleration unless its
`<motionParameters>` gives its own (`jointSpeed`/`jointAcceleration` for MoveJ, `cartesianSpeed`/
`cartesianAcceleration` for MoveL/MoveP) and a `blendRadius` (MoveP: the Move's own `blendRadius` otherwise).

Positions: 5.x writes `<position><JointAngles angles="..."/><TCPOffset pose="..."/><Kinematics .../></position>`;
3.x writes `<position joints="..." pose="..."/>` (the TCP pose in the base frame). A Fixed waypoint under MoveJ moves
to its recorded joint angles; under MoveL/MoveP to the TCP pose those joints give with the recorded TCP offset
(`get_forward_kin(q, tcp)`, the simulator's own kinematics), or to the 3.x recorded pose. A Move that does not use
the active TCP sets the waypoint's recorded TCP first. A Relative waypoint moves by the difference of its
`<fromPosition>` and `<toPosition>` from where the arm is headed (`pose_add(get_target_tcp_pose(), pose_sub(to,
from))`); a Variable waypoint moves to its variable.
"""
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol
from xml.etree.ElementTree import Element

from polyscope_format.urp_file import ProgramTree

from .errors import UrpError
from .expressions import variable_name
from .script_writer import ScriptWriter, number, number_list

COMMANDS = {"MoveJ": "movej", "MoveL": "movel", "MoveP": "movep"}


class Translating(Protocol):
    """What a Move needs of the translation it is part of (translation.Translation)."""

    tree: ProgramTree
    writer: ScriptWriter

    def children_of(self, element: Element) -> list[Element]: ...

    def block(self, nodes: list[Element]) -> None: ...

    def located(self, node: Element, translate: Callable[..., None], *arguments: object) -> None: ...


@dataclass(frozen=True)
class MoveSettings:
    """A Move container's settings, which its waypoints inherit."""

    kind: str
    speed: float
    acceleration: float
    blend: float
    active_tcp: bool


@dataclass(frozen=True)
class Position:
    """A recorded position: joint angles, the TCP offset then active, the TCP pose (3.x); any may be missing."""

    q: list[float] | None
    tcp: list[float] | None
    pose: list[float] | None

    def target(self) -> str:
        """URScript for the TCP pose this position stands for."""
        if self.q is not None and self.tcp is not None:
            return f"get_forward_kin({number_list(self.q)}, {number_list(self.tcp, pose=True)})"
        if self.pose is not None:
            return number_list(self.pose, pose=True)
        if self.q is not None:
            return f"get_forward_kin({number_list(self.q)})"
        raise UrpError("the waypoint records no position")


def translate_move(translation: Translating, node: Element) -> None:
    """Write the motions of a Move container (and the other nodes between its waypoints)."""
    settings = _settings(translation.tree, node)
    translation.writer.marker(settings.kind)
    others: list[Element] = []
    for child in translation.children_of(node):
        if child.tag != "Waypoint":
            others.append(child)
            continue
        translation.block(others)
        others = []
        translation.located(child, _waypoint, translation, settings, child)
    translation.block(others)


def _settings(tree: ProgramTree, node: Element) -> MoveSettings:
    kind = node.get("motionType", "MoveJ")
    if kind not in COMMANDS:
        raise UrpError(f"{tree.path_of(node)}: motion type {kind!r} is not supported by sim_ursim")
    joint = kind == "MoveJ"
    return MoveSettings(
        kind=kind,
        speed=_attribute(tree, node, "speed", 1.0471975511965976 if joint else 0.25),
        acceleration=_attribute(tree, node, "acceleration", 1.3962634015954636 if joint else 1.2),
        blend=_attribute(tree, node, "blendRadius", 0.0),
        active_tcp=node.get("useActiveTCP", "true").lower() != "false",
    )


def _waypoint(translation: Translating, settings: MoveSettings, waypoint: Element) -> None:
    tree, writer = translation.tree, translation.writer
    kind = waypoint.get("type", "Fixed")
    writer.marker(waypoint.get("name") or f"{kind} waypoint")
    arguments = _motion_arguments(tree, settings, waypoint)
    command = COMMANDS[settings.kind]
    if kind == "Fixed":
        position = _position(tree, waypoint.find("position"), waypoint)
        if not settings.active_tcp and position.tcp is not None:
            writer.line(f"set_tcp({number_list(position.tcp, pose=True)})")
        joint_target = settings.kind == "MoveJ" and position.q is not None
        target = number_list(position.q) if joint_target and position.q is not None else position.target()
    elif kind == "Relative":
        start = _position(tree, waypoint.find("fromPosition"), waypoint).target()
        end = _position(tree, waypoint.find("toPosition"), waypoint).target()
        target = f"pose_add(get_target_tcp_pose(), pose_sub({end}, {start}))"
    elif kind == "Variable":
        target = variable_name(tree, waypoint.find("variable"), waypoint)
    else:
        raise UrpError(f"{tree.path_of(waypoint)}: waypoint type {kind!r} is not supported by sim_ursim")
    writer.line(f"{command}({target}, {arguments})")


def _motion_arguments(tree: ProgramTree, settings: MoveSettings, waypoint: Element) -> str:
    parameters = waypoint.find("motionParameters")
    prefix = "joint" if settings.kind == "MoveJ" else "cartesian"
    speed, acceleration, blend = settings.speed, settings.acceleration, settings.blend
    if parameters is not None:
        speed = _attribute(tree, parameters, prefix + "Speed", speed)
        acceleration = _attribute(tree, parameters, prefix + "Acceleration", acceleration)
        blend = _attribute(tree, parameters, "blendRadius", blend)
    if speed <= 0 or acceleration <= 0 or blend < 0:
        raise UrpError(f"{tree.path_of(waypoint)}: speed and acceleration must be positive and the blend radius "
                       f"not negative (got v={speed}, a={acceleration}, r={blend})")
    text = f"a={number(acceleration)}, v={number(speed)}"
    return text + (f", r={number(blend)}" if blend > 0 else "")


def _position(tree: ProgramTree, element: Element | None, waypoint: Element) -> Position:
    if element is None:
        raise UrpError(f"{tree.path_of(waypoint)}: the waypoint records no position")
    element = tree.resolve(element)
    joints = element.find("JointAngles")
    offset = element.find("TCPOffset")
    q = _numbers(tree, element, joints.get("angles") if joints is not None else element.get("joints"), 6)
    tcp = _numbers(tree, element, offset.get("pose") if offset is not None else None, 6)
    pose = _numbers(tree, element, element.get("pose"), 6)
    if q is None and pose is None:
        raise UrpError(f"{tree.path_of(element)}: the position has neither joint angles nor a pose")
    return Position(q, tcp, pose)


def _numbers(tree: ProgramTree, element: Element, text: str | None, count: int) -> list[float] | None:
    if text is None:
        return None
    try:
        values = [float(number(float(part))) for part in text.replace(",", " ").split()]
    except ValueError:
        raise UrpError(f"{tree.path_of(element)}: {text!r} is not {count} numbers") from None
    if len(values) != count:
        raise UrpError(f"{tree.path_of(element)}: {text!r} is not {count} numbers")
    return values


def _attribute(tree: ProgramTree, element: Element, name: str, default: float) -> float:
    text = element.get(name)
    if text is None or not text.strip():
        return default
    try:
        return float(number(float(text)))
    except ValueError:
        raise UrpError(f"{tree.path_of(element)}: {name}={text!r} is not a number") from None
