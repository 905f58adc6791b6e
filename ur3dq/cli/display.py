"""Text for people: numbers in the units the user asked for, and the rich tables the commands print (pure)."""
from __future__ import annotations

import contextlib
import math

from rich.console import Console
from rich.markup import escape  # user text (pose names) is shown as typed, never read as markup
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
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


def count_text(count: int, noun: str) -> str:
    """`1 pose`, `2 poses`: a count with its noun in the right number (regular plurals only)."""
    return f"{count} {noun}" + ("" if count == 1 else "s")


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


def pose_rows(model, pose, deg: bool) -> list[tuple[str, str]]:
    """What record-pose shows about a reading: joints, TCP pose, dual quaternion, and `model`'s FK check."""
    metres, radians = model.fk(pose.joints).distance(pose.dq)
    return [
        ("joints", angles_text(pose.joints, deg)),
        ("TCP pose", pose_vector_text(pose.ur_pose, deg)),
        ("dual quaternion", coefficients_text(pose.dual_quaternion)),
        ("thesis line", pose.dq.to_thesis_line()),
        ("TCP offset", pose_vector_text(pose.tcp_offset, deg)),
        ("model FK check", f"{distance_text(metres, radians)} from the controller's TCP"),
    ]


NARROW_WIDTH = 120  # below this many columns the tables use compact numbers that wrap between values


def compact_angles_text(values, deg: bool) -> str:
    """Joint angles on a narrow terminal: space-separated (so they wrap between values), 3 decimals (1 in °)."""
    return " ".join(f"{math.degrees(float(v)):.1f}°" if deg else f"{float(v):.3f}" for v in values)


def compact_pose_text(pose, deg: bool) -> str:
    """A UR pose vector on a narrow terminal: metres with 3 decimals, then the rotation as compact_angles_text."""
    return " ".join(f"{float(v):.3f}" for v in pose[:3]) + " " + compact_angles_text(pose[3:], deg)


def plan_table(steps, deg: bool, title: str, width: int | None = None) -> Table:
    """The replay plan (ur3dq.replay.PlanStep list): chosen joints, how they were chosen, travel, time, FK residual.
    Narrower than NARROW_WIDTH columns, the numbers are compact and wrap; the pose name is never cut."""
    narrow = width is not None and width < NARROW_WIDTH
    table = Table(title=title, title_justify="left")
    for header in ("#", "pose", "joints", "chosen by", "travel", "time", "FK check"):
        table.add_column(header, overflow="fold", no_wrap=header in ("pose", "#") or (header == "joints"
                                                                                         and not narrow))
    for index, step in enumerate(steps, start=1):
        travel = "—" if step.travel is None else angle_text(step.travel, deg)
        seconds = "—" if step.duration is None else f"{step.duration:.2f} s"
        source = step.source + (f" (of {step.solutions})" if step.solutions else "")
        joints = compact_angles_text(step.joints, deg) if narrow else angles_text(step.joints, deg)
        if narrow:
            travel = "—" if step.travel is None else (f"{math.degrees(step.travel):.1f}°" if deg
                                                      else f"{step.travel:.3f}")
        table.add_row(str(index), escape(step.pose.name), joints, source, travel, seconds,
                      distance_text(step.fk_error_m, step.fk_error_rad))
    return table


def reached_table(results, title: str) -> Table:
    """Where each replayed pose ended (ur3dq.replay.Reached list) vs where the replay aimed the current TCP: the
    recorded TCP pose, or — replaying the flange of a pose recorded with another TCP — a point that far from it."""
    table = Table(title=title, title_justify="left")
    for header in ("#", "pose", "aimed at", "error", "move time"):
        table.add_column(header)
    for index, result in enumerate(results, start=1):
        aimed = "recorded TCP pose" if result.target_off_m < 1e-4 else \
            f"recorded flange: {result.target_off_m * 1000:.1f} mm from the recorded TCP"
        table.add_row(str(index), escape(result.step.pose.name), aimed, distance_text(result.error_m, result.error_rad),
                      f"{result.seconds:.2f} s")
    return table


@contextlib.contextmanager
def progress_bar(console: Console):
    """A rich progress bar on `console`; yields the callback ur3dq.replay.execute_plan reports to."""
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
               TimeElapsedColumn())
    with Progress(*columns, console=console, transient=False) as progress:
        task = progress.add_task("moving", total=None)

        def report(description: str, done: int, total: int) -> None:
            progress.update(task, description=escape(description), completed=done, total=total)

        yield report
