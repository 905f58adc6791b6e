"""The one URScript program of a planned cell program (or a --from/--to part), reporting its running step.

Before each step the program publishes its 1-based position k in two ways a watcher can read independently:
`write_output_integer_register(STEP_REGISTER, k)` (RTDE `output_int_register_<STEP_REGISTER>`) and a key
message `textmsg("ur3dq_step:", k)` on the primary interface. After the last step it publishes N + 1 (done). A
wait-input that times out publishes −k, logs `ur3dq_fail:` k and halts, so the run fails naming that step.
A kept-script step (URScript kept from a PolyScope program by `import-urp --keep-script`) is the one exception to
the rule below: its lines are the program's own, written as they were kept.

Every statement comes from ur3dq.urscript: names appear in `#` comments reduced to printable ASCII, and a message
step's text is an escaped literal. Joint targets are those checked by the planner; movel/movep take them as joints
(FK on the controller) so the controller reaches exactly the checked configuration.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence

from ur3dq import urscript
from ur3dq.program.plan import PlannedStep
from ur3dq.program.steps import AnalogOut, Comment, DigitalOut, KeptScript, Message, Step, Wait, WaitInput

STEP_REGISTER = 22       # output_int_register_22: ur_rtde's control script uses the low registers
STEP_KEY = "ur3dq_step:"
FAIL_KEY = "ur3dq_fail:"
_MOVE_FUNCTIONS = {"joint": "movej", "linear": "movel", "process": "movep"}


def _report(position: int) -> list[str]:
    return [urscript.write_output_integer_register_statement(STEP_REGISTER, position),
            urscript.key_message_statement(STEP_KEY, position)]


def _waypoint_line(planned: PlannedStep) -> str:
    if planned.move is None or planned.joints is None or planned.acceleration is None or planned.speed is None:
        raise ValueError(f"{planned.step.who}: not a planned waypoint")
    function = _MOVE_FUNCTIONS[planned.move]
    return urscript.move_statement(function, planned.joints, planned.acceleration, planned.speed, planned.blend,
                                   t=0 if function == "movel" else None)


def _action_lines(step: Step, position: int) -> list[str]:
    """The statements of one action step."""
    if isinstance(step, DigitalOut):
        return [urscript.set_digital_out_statement(step.output, step.pin, step.on)]
    if isinstance(step, AnalogOut):
        return [urscript.set_analog_out_statement(step.pin, step.value)]
    if isinstance(step, Wait):
        return [urscript.sleep_statement(step.seconds)]
    if isinstance(step, Message):
        return [urscript.textmsg_statement(step.text, "message")]
    if isinstance(step, Comment):
        return [f"# {urscript.comment_text(step.text)}"] if step.text else []
    if isinstance(step, KeptScript):
        return [f"# URScript kept from {urscript.comment_text(step.origin)}: run as it is, not path-checked",
                *step.script.splitlines()]
    if isinstance(step, WaitInput):
        failed = [urscript.write_output_integer_register_statement(STEP_REGISTER, -position),
                  urscript.key_message_statement(FAIL_KEY, position), "halt"]
        return urscript.wait_for_digital_input_statements(step.input, step.pin, step.on, step.timeout, failed)
    raise TypeError(f"no URScript for step {step!r}")


def program_script(plan: Sequence[PlannedStep], program_name: str = "ur3dq_program", header: Iterable[str] = (),
                   first_position: int = 1, restore_tcp: Iterable[float] | None = None) -> str:
    """The URScript text of `plan` (PlannedStep list from plan_program): ``def program_name(): ... end``.

    Parameters
    ----------
    plan : sequence of PlannedStep
    program_name : str
        The program's identifier.
    header : iterable of str
        Comment lines above the program.
    first_position : int
        The number of the first step (a --from part keeps the numbers of the whole program).
    restore_tcp : UR pose vector, optional
        The TCP to set again at the end when a waypoint's taught TCP changed it, so that the controller's TCP is
        what the driver knows. set_tcp is sent before a waypoint whose taught TCP differs from the active one.
    """
    urscript.check_identifier(program_name)
    if not plan:
        raise ValueError("the program has no steps to run")
    body: list[str] = []
    active_tcp = None
    for offset, planned in enumerate(plan):
        position = first_position + offset
        body.append(f"# step {position}: {urscript.comment_text(planned.step.name)} ({planned.step.kind})")
        body.extend(_report(position))
        if planned.joints is not None:
            if planned.tcp_offset is not None and planned.tcp_offset != active_tcp:
                body.append(urscript.set_tcp_statement(planned.tcp_offset))
                active_tcp = planned.tcp_offset
            body.append(_waypoint_line(planned))
        else:
            body.extend(_action_lines(planned.step, position))
    if restore_tcp is not None and active_tcp is not None and tuple(restore_tcp) != active_tcp:
        body.append(urscript.set_tcp_statement(restore_tcp))
    body.extend(_report(first_position + len(plan)))
    return urscript.program(program_name, body, header)
