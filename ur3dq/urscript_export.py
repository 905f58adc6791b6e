"""A URScript program (`.script`) that replays planned poses with movej, for the pendant or the controller's port.

Only generated text and numbers reach the program; pose names and the store path appear only inside comments,
reduced to printable ASCII so no character can end the comment or confuse the controller's parser.
"""
from __future__ import annotations

from ur3dq.robot.script import check_identifier, format_number, movej_statement, set_tcp_statement

COMMENT_MAX_LENGTH = 100
_PRINTABLE_ASCII = frozenset(chr(code) for code in range(0x20, 0x7F))


def comment_text(text: str) -> str:
    """`text` safe inside a URScript `#` comment: printable ASCII only (others become `?`), ≤ 100 characters."""
    cleaned = "".join(char if char in _PRINTABLE_ASCII else "?" for char in str(text))
    return cleaned if len(cleaned) <= COMMENT_MAX_LENGTH else cleaned[:COMMENT_MAX_LENGTH - 3] + "..."


def replay_program(steps, a: float, v: float, blend: float = 0.0, loops: int = 1, tcp_offset=None,
                   program_name: str = "ur3dq_poses", header=()) -> str:
    """The `.script` text: `def program_name(): ... end` moving through `steps` (PlanStep-like: .pose.name,
    .joints in rad) `loops` times with movej a (rad/s²), v (rad/s), blend radius r (m); optional set_tcp first."""
    check_identifier(program_name)
    if not steps:
        raise ValueError("steps must hold at least one pose to export")
    if not (isinstance(loops, int) and loops >= 1):
        raise ValueError(f"loops must be a whole number ≥ 1, got {loops!r}")
    lines = [f"# {comment_text(line)}" for line in header]
    lines.append(f"def {program_name}():")
    if tcp_offset is not None:
        lines.append(f"  {set_tcp_statement(tcp_offset)}")
    body = []
    last = len(steps) - 1
    for index, step in enumerate(steps):
        # the last move of each pass ends at rest: a blend there would have nothing to blend into
        radius = blend if index < last else 0.0
        body.append(f"# {index + 1}: {comment_text(step.pose.name)}")
        body.append(movej_statement(step.joints, a, v, radius))
    if loops == 1:
        lines.extend(f"  {line}" for line in body)
    else:
        lines.append("  ur3dq_loop = 0")
        lines.append(f"  while ur3dq_loop < {loops}:")
        lines.extend(f"    {line}" for line in body)
        lines.append("    ur3dq_loop = ur3dq_loop + 1")
        lines.append("  end")
    lines.append("end")
    return "\n".join(lines) + "\n"


def describe_speeds(a: float, v: float, blend: float) -> str:
    """A one-line summary of the motion parameters for the program's header comment."""
    return (f"movej a = {format_number(a)} rad/s^2, v = {format_number(v)} rad/s, "
            f"blend r = {format_number(blend)} m; joint targets in radians")
