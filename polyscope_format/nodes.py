"""The vocabulary of PolyScope program nodes that every reader of a program tree shares.

- I/O pins by PolyScope's default names (`digital_in[2]`, `config_out[0]`, `tool_in[1]`, `analog_out[1]`,
  `GP_bool_out[64]`, ...) and the URScript functions that read and set them;
- expressions, stored as parts (`<ExpressionChar character="x"/>`, `<ExpressionToken token=" and "/>`, variables,
  pins): the typed parts' text, and the pendant's comparison symbols (≟ ≠ ≤ ≥ ≔) as URScript writes them;
- If chains: 5.x writes `<If type="If|ElseIf|Else">`, 3.x separate `<ElseIf>`/`<Else>` tags; an ElseIf/Else follows
  its If as a sibling, or sits in the If's children;
- a node's children (references followed, empty slots dropped) and its fields, which PolyScope writes either as a
  child element's text or as an attribute.

>>> split_pin("config_out[3]"), PIN_FUNCTIONS["digital_in"][0]
(('config_out', 3), 'get_standard_digital_in')
>>> "read_input_integer_register(0)≟1".translate(PENDANT_SYMBOLS)
'read_input_integer_register(0)==1'
"""
from __future__ import annotations

import re
from xml.etree.ElementTree import Element

from polyscope_format.urp_file import ProgramTree

PIN = re.compile(r"^([A-Za-z_]+)\[(\d+)\]$")
IDENTIFIER = re.compile(r"^[A-Za-z_]\w*$")
# The pendant's expression editor writes comparisons and assignment as symbols (a PolyScope 3.6 program stores
# `read_input_integer_register(0)≟1 and setp≠p[0, 0, 0, 0, 0, 0]`); URScript spells them with ASCII.
PENDANT_SYMBOLS = str.maketrans({"≟": "==", "≠": "!=", "≤": "<=", "≥": ">=", "≔": "="})
TRUE_WORDS = ("1", "true", "on", "high")   # a digital value as PolyScope versions write "on"
IF_CHAIN_TAILS = ("ElseIf", "Else")

# PolyScope pin family -> (URScript getter, URScript setter or None)
PIN_FUNCTIONS: dict[str, tuple[str, str | None]] = {
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


def split_pin(name: str) -> tuple[str, int]:
    """(family, number) of a default pin name: `config_out[3]` -> ('config_out', 3); ValueError for another name."""
    match = PIN.match(name)
    if match is None:
        raise ValueError(f"{name!r} is not a pin name")
    return match.group(1), int(match.group(2))


def typed_text(part: Element) -> str | None:
    """The text of an expression part the operator typed (a character or a token); None for a variable or pin."""
    if part.tag == "ExpressionChar":
        return part.get("character", "")
    if part.tag == "ExpressionToken":
        return part.get("token", "")
    return None


def if_kind(node: Element) -> str | None:
    """'If', 'ElseIf', 'Else' for the nodes of an if chain (5.x `<If type=...>` or separate tags), else None."""
    if node.tag == "If":
        return node.get("type", "If")
    return node.tag if node.tag in IF_CHAIN_TAILS else None


def grouped_if_chains(nodes: list[Element]) -> list[list[Element]]:
    """`nodes` in order, an If together with the ElseIf/Else siblings that follow it: `[[If, ElseIf, Else], [Set]]`.

    An ElseIf or Else with no If before it stands alone (a reader refuses it)."""
    groups: list[list[Element]] = []
    for node in nodes:
        if if_kind(node) in IF_CHAIN_TAILS and groups and if_kind(groups[-1][0]) == "If":
            groups[-1].append(node)
        else:
            groups.append([node])
    return groups


def if_branches(chain: list[Element], first_children: list[Element]) -> tuple[list[Element], list[Element]]:
    """(the If's own nodes, every branch in order) of an If chain `chain` whose If has the children
    `first_children`: an ElseIf/Else among those children is a branch, as is each sibling after the If."""
    nested = [child for child in first_children if if_kind(child) in IF_CHAIN_TAILS]
    then_nodes = [child for child in first_children if child not in nested]
    return then_nodes, [chain[0], *nested, *chain[1:]]


def node_children(tree: ProgramTree, element: Element) -> list[Element]:
    """The nodes under `element`'s `<children>` (references followed, placeholders dropped)."""
    holder = element.find("children")
    if holder is None:
        return []
    nodes = [tree.resolve(child) for child in holder]
    return [node for node in nodes if node.tag != "Placeholder"]


def field_text(node: Element, name: str) -> str:
    """A field given as a child element's text or as an attribute (PolyScope writes both forms)."""
    text = node.findtext(name)
    return (text if text is not None else node.get(name, "")).strip()


def digital_on(node: Element) -> bool:
    """Whether a Set or Wait node's digital value is on (`1`, `true`, `on`, `high`: as PolyScope versions write it)."""
    return field_text(node, "digitalValue").lower() in TRUE_WORDS


def analog_comparison(node: Element) -> str:
    """The URScript comparison of an analog input Wait (`analogComparison` 0: `<`, 1: `>`, 2: `==`; `>` when
    unset)."""
    return {"0": "<", "1": ">", "2": "=="}.get(field_text(node, "analogComparison"), ">")
