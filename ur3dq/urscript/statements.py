"""URScript statements, one function each: every value is formatted by ur3dq.urscript.text.

A function returns one line of source (``..._statement``) or a list of lines (``..._statements``) without
indentation; ur3dq.urscript.programs indents them into a program.
"""
from __future__ import annotations

import operator
from collections.abc import Iterable, Sequence

from ur3dq.urscript.text import format_number, format_pose, format_vector, sanitise_text

MOVE_FUNCTIONS = ("movej", "movel", "movep")
#: The digital outputs and inputs by family: standard (DO0-7), tool (TO0-1), configurable (CO0-7).
DIGITAL_OUTPUT_SETTERS = {"standard": "set_standard_digital_out", "tool": "set_tool_digital_out",
                          "configurable": "set_configurable_digital_out"}
DIGITAL_INPUT_GETTERS = {"standard": "get_standard_digital_in", "tool": "get_tool_digital_in",
                         "configurable": "get_configurable_digital_in"}


def move_statement(function: str, q: Iterable[object], a: float, v: float, r: float = 0.0,
                   t: float | None = None) -> str:
    """A ``movej``/``movel``/``movep`` to the joint vector `q`.

    Parameters
    ----------
    function : {"movej", "movel", "movep"}
    q : sequence of 6 floats
        Joint target (rad); movel and movep reach it by the controller's FK, on a straight TCP path.
    a, v : float
        Acceleration and speed: rad/s², rad/s for movej; m/s², m/s for movel and movep.
    r : float
        Blend radius (m) into the next move.
    t : float, optional
        movel's time argument, written before `r` when given (0: the speed governs).

    Examples
    --------
    >>> move_statement("movel", [0, -1.5, 1, 0, 0, 0], a=1.2, v=0.25, t=0)
    'movel([0.0, -1.5, 1.0, 0.0, 0.0, 0.0], a=1.2, v=0.25, t=0, r=0.0)'
    """
    if function not in MOVE_FUNCTIONS:
        raise ValueError(f"move function must be one of {', '.join(MOVE_FUNCTIONS)}, got {function!r}")
    arguments = [format_vector(q, 6, "q"), f"a={format_number(a, 'a')}", f"v={format_number(v, 'v')}"]
    if t is not None:
        arguments.append("t=0" if t == 0 else f"t={format_number(t, 't')}")
    arguments.append(f"r={format_number(r, 'r')}")
    return f"{function}({', '.join(arguments)})"


def movej_statement(q: Iterable[object], a: float, v: float, r: float = 0.0) -> str:
    """``movej(q, a=, v=, r=)``: a joint-space move; a rad/s², v rad/s (the leading joint), r blend radius (m)."""
    return move_statement("movej", q, a, v, r)


def stopj_statement(a: float) -> str:
    """``stopj(a)``: decelerate every joint to rest at `a` rad/s²."""
    return f"stopj({format_number(a, 'a')})"


def set_tcp_statement(pose: Iterable[object]) -> str:
    """``set_tcp(p[...])``: the TCP offset as a UR pose vector in the flange frame (metres, rotation vector)."""
    return f"set_tcp({format_pose(pose, 'tcp')})"


def textmsg_statement(text: str, name: str = "text") -> str:
    """``textmsg("...")``: a message to the controller's log, the text escaped (`name` names it in errors)."""
    return f"textmsg({sanitise_text(text, name)})"


def key_message_statement(key: str, number: int) -> str:
    """``textmsg("key", n)``: a message a watcher recognises by its `key` (a fixed text) and reads `n` from."""
    return f"textmsg({sanitise_text(key, 'key')}, {_integer(number)})"


def sleep_statement(seconds: float) -> str:
    """``sleep(s)``: wait `seconds`."""
    return f"sleep({format_number(seconds, 'seconds')})"


def set_digital_out_statement(output: str, pin: int, on: bool) -> str:
    """``set_<output>_digital_out(pin, True|False)``; `output` is standard, tool or configurable."""
    return f"{_family(DIGITAL_OUTPUT_SETTERS, output)}({_integer(pin)}, {_boolean(on)})"


def set_analog_out_statement(pin: int, value: float) -> str:
    """``set_standard_analog_out(pin, value)``: `value` is the fraction 0..1 of the output's range."""
    return f"set_standard_analog_out({_integer(pin)}, {format_number(value, 'value')})"


def write_output_integer_register_statement(register: int, value: int) -> str:
    """``write_output_integer_register(register, value)``: RTDE ``output_int_register_<register>``."""
    return f"write_output_integer_register({_integer(register)}, {_integer(value)})"


def rtde_set_watchdog_statement(variable: str, min_frequency: float, action: str) -> str:
    """``rtde_set_watchdog(...)``: act when an RTDE input is not written often enough.

    ``rtde_set_watchdog("variable", f, "action")``: the controller acts (e.g. ``"stop"``) when the RTDE input
    `variable` is not written at least `min_frequency` times a second."""
    frequency = format_number(min_frequency, "min_frequency")
    return f"rtde_set_watchdog({sanitise_text(variable, 'variable')}, {frequency}, {sanitise_text(action, 'action')})"


def freedrive_statements(seconds: float) -> list[str]:
    """Statements that hold freedrive (hand guiding) for `seconds`, then leave it."""
    return ["freedrive_mode()", sleep_statement(seconds), "end_freedrive_mode()"]


def end_freedrive_statements() -> list[str]:
    """Statements that leave freedrive (a new program also aborts the one holding it)."""
    return ["end_freedrive_mode()"]


def wait_for_digital_input_statements(input_family: str, pin: int, on: bool, timeout: float,
                                      on_timeout: Sequence[str]) -> list[str]:
    """Statements that wait for a digital input, with a timeout.

    Statements that wait, one control cycle at a time, until a digital input reads `on`; after `timeout`
    seconds they run `on_timeout` (statements; end them with ``halt`` to stop the program there)."""
    getter = _family(DIGITAL_INPUT_GETTERS, input_family)
    return [
        "ur3dq_waited = 0.0",
        f"while {getter}({_integer(pin)}) != {_boolean(on)}:",
        f"  if ur3dq_waited >= {format_number(timeout, 'timeout')}:",
        *(f"    {line}" for line in on_timeout),
        "  end",
        "  sync()",
        "  ur3dq_waited = ur3dq_waited + get_steptime()",
        "end",
    ]


def _family(functions: dict[str, str], family: str) -> str:
    if family not in functions:
        raise ValueError(f"I/O family must be one of {', '.join(functions)}, got {family!r}")
    return functions[family]


def _integer(value: int) -> str:
    if isinstance(value, bool):
        raise ValueError(f"expected a whole number, got {value!r}")
    try:
        return str(operator.index(value))
    except TypeError:
        raise ValueError(f"expected a whole number, got {value!r}") from None


def _boolean(value: bool) -> str:
    return "True" if value else "False"
