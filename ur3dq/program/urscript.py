"""One URScript program for a whole planned cell program (or a --from/--to part), reporting its running step.

Before each step the program publishes its 1-based position k in two ways a watcher can read independently:
`write_output_integer_register(STEP_REGISTER, k)` (RTDE `output_int_register_<STEP_REGISTER>`) and a key
message `textmsg("ur3dq_step:", k)` on the primary interface. After the last step it publishes N + 1 (done). A
wait-input that times out publishes −k, logs `ur3dq_fail:` k and halts, so the run fails naming that step.

Only generated identifiers, numbers and sanitised literals reach the program: names appear in `#` comments
reduced to printable ASCII, and a message step's text goes through `sanitise_text` (no quote or backslash can
end the literal). Joint targets are those checked by the planner; movel/movep take them as joints (FK on the
controller) so the controller reaches exactly the checked configuration.
"""
from __future__ import annotations

from ur3dq.program.steps import AnalogOut, DigitalOut, Message, Wait, WaitInput
from ur3dq.robot.script import check_identifier, format_number, format_vector, sanitise_text, set_tcp_statement
from ur3dq.urscript_export import comment_text

STEP_REGISTER = 22       # output_int_register_22: ur_rtde's control script uses the low registers
STEP_KEY = "ur3dq_step:"
FAIL_KEY = "ur3dq_fail:"
_MOVE_FUNCTIONS = {"joint": "movej", "linear": "movel", "process": "movep"}
_SETTERS = {"standard": "set_standard_digital_out", "tool": "set_tool_digital_out",
            "configurable": "set_configurable_digital_out"}
_GETTERS = {"standard": "get_standard_digital_in", "tool": "get_tool_digital_in",
            "configurable": "get_configurable_digital_in"}


def _report(position: int) -> list[str]:
    return [f"write_output_integer_register({STEP_REGISTER}, {position})", f'textmsg("{STEP_KEY}", {position})']


def _waypoint_lines(planned) -> list[str]:
    function = _MOVE_FUNCTIONS[planned.move]
    arguments = [format_vector(planned.joints, 6, "q"), f"a={format_number(planned.acceleration, 'a')}",
                 f"v={format_number(planned.speed, 'v')}"]
    if function == "movel":
        arguments.append("t=0")
    arguments.append(f"r={format_number(planned.blend, 'r')}")
    return [f"{function}({', '.join(arguments)})"]


def _action_lines(step, position: int) -> list[str]:
    """The statements of one action step (all arguments are validated numbers and fixed identifiers)."""
    if isinstance(step, DigitalOut):
        return [f"{_SETTERS[step.output]}({step.pin}, {'True' if step.on else 'False'})"]
    if isinstance(step, AnalogOut):
        return [f"set_standard_analog_out({step.pin}, {format_number(step.value)})"]
    if isinstance(step, Wait):
        return [f"sleep({format_number(step.seconds)})"]
    if isinstance(step, Message):
        return [f"textmsg({sanitise_text(step.text, 'message')})"]
    if isinstance(step, WaitInput):
        level = "True" if step.on else "False"
        return [
            "ur3dq_waited = 0.0",
            f"while {_GETTERS[step.input]}({step.pin}) != {level}:",
            f"  if ur3dq_waited >= {format_number(step.timeout)}:",
            f"    write_output_integer_register({STEP_REGISTER}, {-position})",
            f'    textmsg("{FAIL_KEY}", {position})',
            "    halt",
            "  end",
            "  sync()",
            "  ur3dq_waited = ur3dq_waited + get_steptime()",
            "end",
        ]
    raise TypeError(f"no URScript for step {step!r}")


def program_script(plan, program_name: str = "ur3dq_program", header=(), first_position: int = 1,
                   restore_tcp=None) -> str:
    """The `.script` text of `plan` (PlannedStep list from plan_program): `def program_name(): ... end`.

    Steps are numbered from `first_position` (a --from part keeps the numbers of the whole program). set_tcp is
    sent before a waypoint whose taught TCP offset differs from the active one; `restore_tcp` (UR pose vector)
    is set again at the end, so the controller's TCP is what the driver knows.
    """
    check_identifier(program_name)
    if not plan:
        raise ValueError("the program has no steps to run")
    lines = [f"# {comment_text(line)}" for line in header]
    lines.append(f"def {program_name}():")
    body: list[str] = []
    active_tcp = None
    for offset, planned in enumerate(plan):
        position = first_position + offset
        body.append(f"# step {position}: {comment_text(planned.step.name)} ({planned.step.kind})")
        body.extend(_report(position))
        if planned.joints is not None:
            if planned.tcp_offset != active_tcp:
                body.append(set_tcp_statement(planned.tcp_offset))
                active_tcp = planned.tcp_offset
            body.extend(_waypoint_lines(planned))
        else:
            body.extend(_action_lines(planned.step, position))
    if restore_tcp is not None and active_tcp is not None and tuple(restore_tcp) != active_tcp:
        body.append(set_tcp_statement(restore_tcp))
    body.extend(_report(first_position + len(plan)))
    lines.extend(f"  {line}" for line in body)
    lines.append("end")
    return "\n".join(lines) + "\n"
