"""The nodes of a PolyScope program tree as the pendant shows them: labels, tree paths, expressions, I/O pins.

A node's path is how a technician finds it on the pendant's program tree: `Robot Program/Folder 2/If digital_in[0]`
(the main program is "Robot Program", a folder or waypoint by its name, an If by its condition). Expressions are
stored as parts — typed characters, tokens, variables, I/O pins — and read back as the text the pendant shows
(its comparison symbols ≟ ≠ ≤ ≥ ≔ written as URScript's == != <= >= =). Pins are PolyScope's default names
(`digital_in[2]`, `tool_out[0]`, `analog_out[1]`, ...) or names the program's installation gave them.

>>> split_pin("config_out[3]")
('config_out', 3)
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

from ur3dq.polyscope.urp_file import ProgramTree

_PIN = re.compile(r"^([A-Za-z_]+)\[(\d+)\]$")
_IDENTIFIER = re.compile(r"^[A-Za-z_]\w*$")
_PENDANT_SYMBOLS = str.maketrans({"≟": "==", "≠": "!=", "≤": "<=", "≥": ">=", "≔": "="})
TRUE_WORDS = ("1", "true", "on", "high")
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
        holder = element.find("children")
        if holder is None:
            return []
        nodes = [self.tree.resolve(child) for child in holder]
        return [node for node in nodes if node.tag != "Placeholder"]

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
        text = "".join(self._part(part, where, pendant) for part in expression).strip().translate(_PENDANT_SYMBOLS)
        if not text:
            raise NodeError(where, "the node's expression is empty (PolyScope would not run it either)")
        return text

    def _part(self, part: Element, where: str, pendant: bool) -> str:
        if part.tag == "ExpressionChar":
            return part.get("character", "")
        if part.tag == "ExpressionToken":
            return part.get("token", "")
        if part.tag == "ExpressionVariable":
            variable = next(iter(part), None)
            return self.variable(variable, where)
        if part.tag == "ExpressionIO":
            return self.pin(part, where) if pendant else read_pin(self.pin(part, where), where)
        raise NodeError(where, f"expression part <{part.tag}> is not one ur3dq knows")

    def variable(self, variable: Element | None, where: str) -> str:
        """The name of a program variable element (by name or reference)."""
        name = None if variable is None else self.tree.resolve(variable).get("name")
        if not name or not _IDENTIFIER.match(name):
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
        if _PIN.match(name) is None:
            raise NodeError(where, f"I/O pin {name!r} is neither one of PolyScope's pin names nor named in the "
                                   "program's installation (keep the installation file beside the program)")
        return name

    def path_to(self, parent: str, node: Element) -> str:
        """The path of `node` under the node at `parent`."""
        return f"{parent}/{self.label(node)}" if parent else self.label(node)


def split_pin(name: str) -> tuple[str, int]:
    """(family, number) of a default pin name: `config_out[3]` -> ('config_out', 3)."""
    match = _PIN.match(name)
    if match is None:
        raise ValueError(f"{name!r} is not a pin name")
    return match.group(1), int(match.group(2))


# PolyScope pin family -> (URScript getter, URScript setter or None)
PIN_FUNCTIONS = {
    "digital_in": ("get_standard_digital_in", None),
    "digital_out": ("get_standard_digital_out", "set_standard_digital_out"),
    "config_in": ("get_configurable_digital_in", None),
    "config_out": ("get_configurable_digital_out", "set_configurable_digital_out"),
    "tool_in": ("get_tool_digital_in", None),
    "tool_out": ("get_tool_digital_out", "set_tool_digital_out"),
    "analog_in": ("get_standard_analog_in", None),
    "analog_out": ("get_standard_analog_out", "set_standard_analog_out"),
    "tool_analog_in": ("get_tool_analog_in", None),
    "GP_bool_in": ("read_input_boolean_register", None),
    "GP_bool_out": ("read_output_boolean_register", "write_output_boolean_register"),
    "GP_int_in": ("read_input_integer_register", None),
    "GP_int_out": ("read_output_integer_register", "write_output_integer_register"),
    "GP_float_in": ("read_input_float_register", None),
    "GP_float_out": ("read_output_float_register", "write_output_float_register"),
}


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


def field_text(node: Element, name: str) -> str:
    """A field given as a child element's text or as an attribute (PolyScope writes both forms)."""
    text = node.findtext(name)
    return (text if text is not None else node.get(name, "")).strip()


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


def if_kind(node: Element) -> str | None:
    """'If', 'ElseIf', 'Else' for the nodes of an if chain (5.x `<If type=...>` or separate tags), else None."""
    if node.tag == "If":
        return node.get("type", "If")
    return node.tag if node.tag in ("ElseIf", "Else") else None


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
        state = "HI" if field_text(node, "digitalValue").lower() in TRUE_WORDS else "LO"
        return f"Wait {program.pin(node, node.tag)}={state}"
    if kind == "AnalogInput":
        comparison = {"0": "<", "1": ">", "2": "=="}.get(field_text(node, "analogComparison"), ">")
        return f"Wait {program.pin(node, node.tag)}{comparison}{field_text(node, 'analogValue')}"
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
