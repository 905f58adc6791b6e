"""PolyScope expressions and I/O pins as URScript text.

An expression is stored as a sequence of parts, one XML element each: `<ExpressionChar character="x"/>` (typed
characters), `<ExpressionToken token=" and "/>`, `<ExpressionVariable>` (a program variable, by name or reference)
and `<ExpressionIO>` (an I/O pin by its PolyScope name, read as the matching getter). A pin is named
`digital_in[2]`, `config_out[0]`, `tool_in[1]`, `analog_in[0]`, `GP_bool_out[64]`, ...: PolyScope's default names,
or the names the program's installation gave them (polyscope_format.installation; `ProgramTree.pin_aliases`).

Comparisons typed on the pendant are stored as symbols (`≟`, `≠`, `≤`, `≥`, `≔`) and become `==`, `!=`, `<=`, `>=`,
`=`.

>>> read_pin("digital_in[3]"), write_pin("config_out[1]", "True")
('get_standard_digital_in(3)', 'set_configurable_digital_out(1, True)')
"""
from xml.etree.ElementTree import Element

from polyscope_format.nodes import IDENTIFIER, PENDANT_SYMBOLS, PIN, PIN_FUNCTIONS, typed_text
from polyscope_format.urp_file import ProgramTree

from .errors import UrpError

# PolyScope pin family -> (URScript getter, URScript setter or None); some programs spell the configurable pins out
_PINS = {**PIN_FUNCTIONS, "configurable_in": PIN_FUNCTIONS["config_in"],
         "configurable_out": PIN_FUNCTIONS["config_out"]}


def _pin_functions(name: str) -> tuple[str | None, str | None, int]:
    match = PIN.match(name.strip())
    if match is None or match.group(1) not in _PINS:
        raise UrpError(f"I/O pin {name!r} is neither one of PolyScope's default pin names nor named in the "
                       "program's installation")
    getter, setter = _PINS[match.group(1)]
    return getter, setter, int(match.group(2))


def read_pin(name: str) -> str:
    """URScript that reads pin `name` (e.g. `digital_in[3]` -> `get_standard_digital_in(3)`)."""
    getter, _, number = _pin_functions(name)
    if getter is None:
        raise UrpError(f"I/O pin {name!r} cannot be read by sim_ursim")
    return f"{getter}({number})"


def write_pin(name: str, value: str) -> str:
    """URScript that sets pin `name` to the URScript expression `value`."""
    _, setter, number = _pin_functions(name)
    if setter is None:
        raise UrpError(f"I/O pin {name!r} is an input: it cannot be set")
    return f"{setter}({number}, {value})"


def pin_name(tree: ProgramTree, pin: Element | None, where: Element) -> str:
    """The PolyScope name of a `<pin>` element (following a reference)."""
    if pin is None:
        raise UrpError(f"{tree.path_of(where)}: the node names no I/O pin")
    name = tree.resolve(pin).get("referencedName") or tree.resolve(pin).get("name")
    if not name:
        raise UrpError(f"{tree.path_of(pin)}: the pin has no name")
    return tree.pin_aliases.get(name, name)


def variable_name(tree: ProgramTree, variable: Element | None, where: Element) -> str:
    """The name of a program variable element (`<variable name=...>` or a reference to one)."""
    if variable is None:
        raise UrpError(f"{tree.path_of(where)}: the node names no variable")
    name = tree.resolve(variable).get("name")
    if not name or not IDENTIFIER.match(name):
        raise UrpError(f"{tree.path_of(variable)}: {name!r} is not a variable name")
    return name


def expression_text(tree: ProgramTree, expression: Element | None, where: Element) -> str:
    """The URScript text of an `<expression>` element; UrpError for an empty or unknown expression part."""
    if expression is None:
        raise UrpError(f"{tree.path_of(where)}: the node has no expression")
    parts = [_part_text(tree, part) for part in expression]
    text = "".join(parts).strip().translate(PENDANT_SYMBOLS)
    if not text:
        raise UrpError(f"{tree.path_of(where)}: the node's expression is empty (PolyScope would not run it either)")
    return text


def _part_text(tree: ProgramTree, part: Element) -> str:
    typed = typed_text(part)
    if typed is not None:
        return typed
    if part.tag == "ExpressionVariable":
        return variable_name(tree, next(iter(part), None), part)
    if part.tag == "ExpressionIO":
        return read_pin(pin_name(tree, part.find("pin"), part))
    raise UrpError(f"{tree.path_of(part)}: expression part <{part.tag}> is not supported by sim_ursim")
