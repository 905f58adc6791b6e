"""Text for people: numbers in the units the user asked for, and the rich tables the commands print (pure)."""
from __future__ import annotations

import math

from rich.table import Table

JOINT_LABELS = ("base", "shoulder", "elbow", "wrist 1", "wrist 2", "wrist 3")


def angle_text(radians: float, deg: bool) -> str:
    """One angle as text: degrees with 3 decimals and a ° sign when `deg`, else radians with 6 decimals."""
    return f"{math.degrees(radians):.3f}°" if deg else f"{radians:.6f}"


def angles_text(values, deg: bool) -> str:
    """Joint angles (radians in) as one bracketed line in degrees or radians."""
    return "[" + ", ".join(angle_text(float(v), deg) for v in values) + "]"


def pose_vector_text(pose, deg: bool) -> str:
    """A UR pose vector [x, y, z, rx, ry, rz]: metres with 6 decimals, rotation vector in degrees or radians."""
    x, y, z, *rotation = (float(v) for v in pose)
    return f"p[{x:.6f}, {y:.6f}, {z:.6f}, " + ", ".join(angle_text(r, deg) for r in rotation) + "]"


def coefficients_text(values) -> str:
    """Dual-quaternion coefficients [rw rx ry rz | dw dx dy dz] on one line, 9 decimals."""
    values = [float(v) for v in values]
    return "[" + " ".join(f"{v:.9f}" for v in values[:4]) + " | " + " ".join(f"{v:.9f}" for v in values[4:]) + "]"


def distance_text(metres: float, radians: float) -> str:
    """A pose distance as millimetres and degrees."""
    return f"{metres * 1000:.3f} mm / {math.degrees(radians):.3f}°"


def unit_label(deg: bool) -> str:
    """The angle unit shown in column headers."""
    return "deg" if deg else "rad"


def key_value_table(title: str, rows) -> Table:
    """A two-column table of (label, value) rows."""
    table = Table(title=title, show_header=False, title_justify="left")
    table.add_column("what", style="bold")
    table.add_column("value", overflow="fold")
    for label, value in rows:
        table.add_row(label, value)
    return table


def joint_solutions_table(title: str, solutions, deg: bool, extra_columns=()) -> Table:
    """A table with one row per joint vector; `extra_columns` = [(header, [text per row])]."""
    table = Table(title=title, title_justify="left")
    table.add_column("#", justify="right")
    for label in JOINT_LABELS:
        table.add_column(f"{label} ({unit_label(deg)})", justify="right")
    for header, _ in extra_columns:
        table.add_column(header, justify="right")
    for index, q in enumerate(solutions):
        cells = [angle_text(float(v), deg) for v in q] + [values[index] for _, values in extra_columns]
        table.add_row(str(index + 1), *cells)
    return table
