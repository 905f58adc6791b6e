"""The nodes of a PolyScope program tree as the pendant shows them: labels, tree paths, expressions, I/O pins.

A node's path is how a technician finds it on the pendant's program tree: `Robot Program/Folder 2/If digital_in[0]`
(the main program is "Robot Program", a folder or waypoint by its name, an If by its condition). Expressions are
stored as parts — typed characters, tokens, variables, I/O pins — and read back as the text the pendant shows
(its comparison symbols ≟ ≠ ≤ ≥ ≔ written as URScript's == != <= >= =). Pins are PolyScope's default names
(`digital_in[2]`, `tool_out[0]`, `analog_out[1]`, ...) or names the program's installation gave them. The
vocabulary the simulator reads the same way (pin functions, symbols, If chains, fields) is polyscope_format.nodes.

>>> read_pin("digital_in[3]", "Robot Program/Wait"), write_pin("config_out[1]", "True", "Robot Program/Set")
('get_standard_digital_in(3)', 'set_configurable_digital_out(1, True)')
"""
from __future__ import annotations

from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

from polyscope_format.nodes import (
    IDENTIFIER,
    PENDANT_SYMBOLS,
    PIN,
    PIN_FUNCTIONS,
    TRUE_WORDS,
    analog_comparison,
    digital_on,
    field_text,
    if_kind,
    node_children,
    split_pin,
    typed_text,
)
from polyscope_format.urp_file import ProgramTree

LABEL_MAX = 80   # a label in a path or a step name is cut here (with …)


class NodeError(ValueError):
    """A node ur3dq cannot read or has no step for; `path` is where it sits on the pendant's tree."""

    def __init__(self, path: str, reason: str) -> None:
        super().__init__(f"{path}: {reason}")
        self.path = path
        self.reason = reason


@dataclass
class Program:
    """A program tree and what its nodes are called: the tree, its installation's pin names, and the paths."""

    tree: ProgramTree
    pin_aliases: dict[str, str] = field(default_factory=dict)

    def children(self, element: Element) -> list[Element]:
        """The nodes under `element`'s `<children>` (references followed, empty slots dropped)."""
        return node_children(self.tree, element)

    def label(self, node: Element) -> str:
        """The node as the pendant's program tree shows it (`MoveJ`, `pick`, `Set tool_out[0]=On`, `Wait 0.5`)."""
        try:
            text = _label(self, node)
        except NodeError:
            text = node.tag
        text = " ".join(text.split()) or node.tag
        return text if len(text) <= LABEL_MAX else text[:LABEL_MAX - 1] + "…"

    def expression(self, node: Element, where: str, pendant: bool = False) -> str:
        """The URScript text of `node`'s `<expression>` (with `pendant`, as the pendant shows it: pins by their
        names); NodeError (at `where`) for a missing, empty or unreadable one."""
        expression = node.find("expression")
        if expression is None:
            raise NodeError(where, "the node has no expression")
        text = "".join(self._part(part, where, pendant) for part in expression).strip().translate(PENDANT_SYMBOLS)
        if not text:
            raise NodeError(where, "the node's expression is empty (PolyScope would not run it either)")
        return text

    def _part(self, part: Element, where: str, pendant: bool) -> str:
        typed = typed_text(part)
        if typed is not None:
            return typed
        if part.tag == "ExpressionVariable":
            variable = next(iter(part), None)
            return self.variable(variable, where)
        if part.tag == "ExpressionIO":
            return self.pin(part, where) if pendant else read_pin(self.pin(part, where), where)
        raise NodeError(where, f"expression part <{part.tag}> is not one ur3dq knows")

    def variable(self, variable: Element | None, where: str) -> str:
        """The name of a program variable element (by name or reference)."""
        name = None if variable is None else self.tree.resolve(variable).get("name")
        if not name or not IDENTIFIER.match(name):
            raise NodeError(where, f"{name!r} is not a variable name")
        return name

    def pin(self, node: Element, where: str) -> str:
        """PolyScope's default name of the pin `node` names (`<pin referencedName=...>`, the installation's names
        translated back)."""
        pin = node.find("pin")
        if pin is None:
            raise NodeError(where, "the node names no I/O pin")
        target = self.tree.resolve(pin)
        name = target.get("referencedName") or target.get("name")
        if not name:
            raise NodeError(where, "the pin has no name")
        name = self.pin_aliases.get(name, name)
        if PIN.match(name) is None:
            raise NodeError(where, f"I/O pin {name!r} is neither one of PolyScope's pin names nor named in the "
                                   "program's installation (keep the installation file beside the program)")
        return name

    def path_to(self, parent: str, node: Element) -> str:
        """The path of `node` under the node at `parent`."""
        return f"{parent}/{self.label(node)}" if parent else self.label(node)


def read_pin(name: str, where: str) -> str:
    """URScript that reads pin `name` (`digital_in[3]` -> `get_standard_digital_in(3)`)."""
    family, number = split_pin(name)
    if family not in PIN_FUNCTIONS:
        raise NodeError(where, f"I/O pin {name!r} is not one ur3dq can read")
    return f"{PIN_FUNCTIONS[family][0]}({number})"


def write_pin(name: str, value: str, where: str) -> str:
    """URScript that sets pin `name` to the URScript expression `value`."""
    family, number = split_pin(name)
    setter = PIN_FUNCTIONS.get(family, (None, None))[1]
    if setter is None:
        raise NodeError(where, f"I/O pin {name!r} cannot be set")
    return f"{setter}({number}, {value})"


def number_field(node: Element, name: str, where: str) -> float:
    """A numeric field (child text or attribute); NodeError when missing or not a finite number."""
    text = field_text(node, name)
    try:
        value = float(text)
    except ValueError:
        raise NodeError(where, f"{name} {text!r} is not a number" if text else f"the node has no {name}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise NodeError(where, f"{name} {text!r} is not a finite number")
    return value


def _label(program: Program, node: Element) -> str:
    tag = node.tag
    simple = {"MainProgram": "Robot Program", "InitVariablesNode": "Init Variables", "Halt": "Halt",
              "Move": node.get("motionType", "MoveJ")}
    if tag in simple:
        return simple[tag]
    if tag in ("Folder", "Waypoint", "Thread", "SubProgram"):
        return node.get("name") or tag
    if tag == "SpecialSequence":
        return node.get("type", "BeforeStart")
    if tag == "Comment":
        return node.get("comment") or node.findtext("comment") or "Comment"
    if tag == "Contributed":
        return node.get("strategyProgramNodeType") or node.get("strategyClass") or "URCap node"
    if tag == "CallSubProgram":
        definition = node.find("subprogram")
        return "Call " + (program.tree.resolve(definition).get("name", "") if definition is not None else "")
    if tag == "Popup":
        return "Popup: " + (node.get("message") or node.findtext("message") or "")
    return _statement_label(program, node)


def _statement_label(program: Program, node: Element) -> str:
    tag, here = node.tag, node.tag
    kind = if_kind(node)
    if kind == "Else":
        return "Else"
    if kind is not None:
        return f"{kind} {program.expression(node, here, True)}"
    if tag == "Loop":
        loop = node.get("type", "Forever")
        if loop == "Forever":
            return "Loop"
        if loop in ("Counting", "Count", "Times"):
            return f"Loop {loop_count(node, here)} times"
        return f"Loop {program.expression(node, here, True)}"
    if tag == "Wait":
        return _wait_label(program, node)
    if tag == "Set":
        if node.get("type", "DigitalOutput") == "NoAction":
            return "Set"
        value = field_text(node, "digitalValue") or field_text(node, "analogValue")
        if node.get("type") == "DigitalOutput":
            value = "On" if value.lower() in TRUE_WORDS else "Off"
        elif node.get("type") in ("Expression", "ExpressionOutput"):
            value = program.expression(node, here, True)
        return f"Set {program.pin(node, here)}={value}"
    if tag == "Script":
        if node.get("type", "Line") == "File":
            return "Script: " + (node.findtext("file") or "").split("/")[-1]
        return program.expression(node, here, True)
    if tag == "Assignment":
        return f"{program.variable(node.find('variable'), here)}:={program.expression(node, here, True)}"
    return tag


def _wait_label(program: Program, node: Element) -> str:
    kind = node.get("type", "Sleep")
    if kind == "Sleep":
        return f"Wait {field_text(node, 'waitTime')}"
    if kind == "DigitalInput":
        state = "HI" if digital_on(node) else "LO"
        return f"Wait {program.pin(node, node.tag)}={state}"
    if kind == "AnalogInput":
        return f"Wait {program.pin(node, node.tag)}{analog_comparison(node)}{field_text(node, 'analogValue')}"
    return f"Wait {program.expression(node, node.tag, True)}"


def loop_count(node: Element, where: str) -> int:
    """The number of times a counted Loop runs."""
    for name in ("count", "loopCount", "times", "iterations"):
        text = field_text(node, name)
        if text:
            try:
                return int(float(text))
            except (ValueError, OverflowError):
                raise NodeError(where, f"loop count {text!r} is not a number") from None
    raise NodeError(where, "the counted loop has no count")
