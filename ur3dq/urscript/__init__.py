"""URScript text: the one writer every program ur3dq sends or exports goes through.

Three layers, each a module:

- `text`: values as URScript source — lossless numbers, vectors and poses, escaped string literals, comment text,
  identifiers and fresh program names;
- `statements`: one function per statement (motion, TCP, I/O, messages, registers, waits), each returning a line
  (or a block of lines) whose every value went through `text`;
- `programs`: the program skeleton (`def name(): ... end` with header comments), loops, a statement put first.

The driver (ur3dq.robot), the cell-program runner (ur3dq.program.script) and the pose export (ur3dq.replay) build
their programs from these; no other module writes URScript.

Examples
--------
>>> from ur3dq import urscript
>>> print(urscript.program("ur3dq_move_1", [urscript.movej_statement([0, -1.57, 0, -1.57, 0, 0], a=1.4, v=1.05)]),
...       end="")
def ur3dq_move_1():
  movej([0.0, -1.57, 0.0, -1.57, 0.0, 0.0], a=1.4, v=1.05, r=0.0)
end
"""
from ur3dq.urscript.programs import first_statement_added, movej_program, program, repeat
from ur3dq.urscript.statements import (
    end_freedrive_statements,
    freedrive_statements,
    key_message_statement,
    move_statement,
    movej_statement,
    rtde_set_watchdog_statement,
    set_analog_out_statement,
    set_digital_out_statement,
    set_tcp_statement,
    sleep_statement,
    stopj_statement,
    textmsg_statement,
    wait_for_digital_input_statements,
    write_output_integer_register_statement,
)
from ur3dq.urscript.text import (
    check_identifier,
    comment_text,
    format_number,
    format_pose,
    format_vector,
    new_program_name,
    sanitise_text,
)

__all__ = [
    "check_identifier", "comment_text", "end_freedrive_statements", "first_statement_added", "format_number",
    "format_pose", "format_vector", "freedrive_statements", "key_message_statement", "move_statement",
    "movej_program", "movej_statement", "new_program_name", "program", "repeat", "rtde_set_watchdog_statement",
    "sanitise_text", "set_analog_out_statement", "set_digital_out_statement", "set_tcp_statement",
    "sleep_statement", "stopj_statement", "textmsg_statement", "wait_for_digital_input_statements",
    "write_output_integer_register_statement",
]
