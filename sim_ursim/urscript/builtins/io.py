"""URScript I/O built-ins: digital outputs and inputs, the analog output, the general-purpose registers.

Digital I/O is numbered as URScript numbers it: in the flat functions (`set_digital_out`, `get_digital_in`), 0-7 are
the standard, 8-15 the configurable and 16-17 the tool channels; the `standard_`/`configurable_`/`tool_` functions
number their own group from 0. The getters and the register functions are table-driven: one row names the built-in,
the `controller.io` attribute it reads and its size. Every call reads `controller.io` when it runs.
"""
from collections.abc import Callable
from typing import Any

from sim_ursim.urscript.builtins.arguments import as_integer, as_number, controller_call
from sim_ursim.urscript.builtins.registry import builtin, register
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import ScriptError

# (local index offset into the flat 0-17 numbering, channel count) of each digital group
_GROUPS: dict[str, tuple[int, int]] = {"standard": (0, 8), "configurable": (8, 8), "tool": (16, 2)}


def _digital_out_group(n: Any) -> tuple[str, int]:
    """(group, local index) of a flat set_digital_out index: 0-7 standard, 8-15 configurable, 16-17 tool."""
    index = as_integer(n, "n")
    for group, (first, count) in _GROUPS.items():
        if first <= index < first + count:
            return group, index - first
    raise ScriptError(f"runtime_error:digital output {index} does not exist (0..17):")


def _set_out(ctx: ThreadContext, group: str, index: Any, value: Any) -> None:
    setter = getattr(ctx.controller.io, f"set_{group}_digital_out")
    controller_call(setter, as_integer(index, "n"), bool(value))


def _get_bit(word: int, index: Any, count: int, what: str) -> bool:
    index = as_integer(index, "n")
    if not 0 <= index < count:
        raise ScriptError(f"runtime_error:{what} {index} does not exist (0..{count - 1}):")
    return bool((int(word) >> index) & 1)


@builtin
def set_digital_out(ctx: ThreadContext, n, b):
    """Digital output n (0-7 standard, 8-15 configurable, 16-17 tool) on or off."""
    group, index = _digital_out_group(n)
    _set_out(ctx, group, index, b)


def _group_setter(group: str) -> Callable[..., None]:
    def setter(ctx: ThreadContext, n, b):
        _set_out(ctx, group, n, b)

    first, count = _GROUPS[group]
    setter.__name__ = f"set_{group}_digital_out"
    setter.__doc__ = f"{group.capitalize()} digital output n (0-{count - 1}) on or off."
    return setter


for _group in _GROUPS:
    register(f"set_{_group}_digital_out", _group_setter(_group))

# built-in name, controller.io attribute (an int bit word), channel count, what the error message calls a channel
_BIT_GETTERS: tuple[tuple[str, str, int, str], ...] = (
    ("get_digital_out", "digital_output_bits", 18, "digital output"),
    ("get_standard_digital_out", "standard_digital_outputs", 8, "standard digital output"),
    ("get_configurable_digital_out", "configurable_digital_outputs", 8, "configurable digital output"),
    ("get_tool_digital_out", "tool_digital_outputs", 2, "tool digital output"),
    ("get_digital_in", "digital_input_bits", 18, "digital input"),
    ("get_standard_digital_in", "standard_digital_inputs", 8, "standard digital input"),
    ("get_configurable_digital_in", "configurable_digital_inputs", 8, "configurable digital input"),
    ("get_tool_digital_in", "tool_digital_inputs", 2, "tool digital input"),
)


def _bit_getter(name: str, attribute: str, count: int, what: str) -> Callable[..., bool]:
    def getter(ctx: ThreadContext, n):
        return _get_bit(getattr(ctx.controller.io, attribute), n, count, what)

    getter.__name__, getter.__doc__ = name, f"State of {what} n (0-{count - 1})."
    return getter


for _row in _BIT_GETTERS:
    register(_row[0], _bit_getter(*_row))


@builtin("set_standard_analog_out", "set_analog_out")
def set_standard_analog_out(ctx: ThreadContext, n, f):
    """Standard analog output n (0-1) to the ratio f (0..1)."""
    controller_call(ctx.controller.io.set_analog_out, as_integer(n, "n"), as_number(f, "f"))


@builtin
def get_standard_analog_out(ctx: ThreadContext, n):
    """The ratio (0..1) standard analog output n (0-1) is set to (PolyScope reads an analog output so)."""
    index = as_integer(n, "n")
    outputs = ctx.controller.io.analog_outputs
    if not 0 <= index < len(outputs):
        raise ScriptError(f"runtime_error:analog output {index} does not exist (0..{len(outputs) - 1}):")
    return float(outputs[index])


# register kind -> (URScript name of the kind, the Python value a read returns, how a written value is checked)
_REGISTER_KINDS: dict[str, tuple[str, Callable[[Any], Any], Callable[[Any], Any]]] = {
    "int": ("integer", int, lambda v: as_integer(v, "value")),
    "double": ("float", float, lambda v: as_number(v, "value")),
    "bit": ("boolean", bool, bool),
}


def _register_reader(bank: str, kind: str) -> Callable[..., Any]:
    array_name = f"{bank}_{kind}_registers"
    script_kind, convert, _ = _REGISTER_KINDS[kind]

    def read(ctx: ThreadContext, address):
        values = getattr(ctx.controller.io, array_name)
        index = as_integer(address, "address")
        if not 0 <= index < len(values):
            raise ScriptError(f"runtime_error:{bank} {kind} register {index} does not exist (0..{len(values) - 1}):")
        return convert(values[index])

    read.__name__ = f"read_{bank}_{script_kind}_register"
    read.__doc__ = f"Value of the {bank} {script_kind} register at `address`."
    return read


def _register_writer(kind: str) -> Callable[..., None]:
    script_kind, _, check = _REGISTER_KINDS[kind]

    def write(ctx: ThreadContext, address, value):
        setter = getattr(ctx.controller.io, f"set_{kind}_register")
        controller_call(setter, "output", as_integer(address, "address"), check(value))

    write.__name__ = f"write_output_{script_kind}_register"
    write.__doc__ = f"Set the output {script_kind} register at `address` (read by RTDE clients)."
    return write


for _kind, (_script_kind, _, _) in _REGISTER_KINDS.items():
    for _bank in ("input", "output"):
        register(f"read_{_bank}_{_script_kind}_register", _register_reader(_bank, _kind))
    register(f"write_output_{_script_kind}_register", _register_writer(_kind))
