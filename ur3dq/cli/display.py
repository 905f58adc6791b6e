"""Text for people: numbers in the units the user asked for, and the rich tables the commands print (pure)."""
from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from rich import box
from rich.console import Console, ConsoleOptions, JustifyMethod, RenderResult
from rich.markup import escape  # user text (pose names) is shown as typed, never read as markup
from rich.measure import Measurement
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from ur3dq.dualquat import DualQuaternion
from ur3dq.units import ANGLE, FINE, LENGTH, Units, show, to_display, unit_label

if TYPE_CHECKING:
    from ur3dq.replay import Reached

JOINT_LABELS = ("base", "shoulder", "elbow", "wrist 1", "wrist 2", "wrist 3")


# (angle unit, length unit) → the %-format of one angle / one length: 3 decimals of ° or mm, 6 of rad or m
_ANGLE_FORMAT = {"deg": "%.3f°", "rad": "%.6f"}
_LENGTH_FORMAT = {"mm": "%.3f", "m": "%.6f"}


def angle_text(radians: float, units: Units) -> str:
    """One angle as text: degrees with 3 decimals and a ° sign under --deg, else radians with 6 decimals."""
    return _ANGLE_FORMAT[units.angle] % to_display(radians, ANGLE, units)


def angles_text(values: Any, units: Units) -> str:
    """Joint angles (radians in) as one bracketed line in the person's angle unit."""
    scale = to_display(1.0, ANGLE, units)
    numbers = [v * scale for v in np.asarray(values, dtype=float).tolist()]
    # One %-format per line, not one per angle: a long replay plan formats 10⁵ of them.
    return _angles_format(units.angle, len(numbers)) % tuple(numbers)


@functools.cache
def _angles_format(angle: str, count: int) -> str:
    """The %-format of angles_text's line of `count` angles."""
    return "[" + ", ".join([_ANGLE_FORMAT[angle]] * count) + "]"


@functools.cache
def _pose_vector_format(units: Units) -> str:
    """The %-format of a whole pose vector in `units`."""
    return ("p[" + ", ".join([_LENGTH_FORMAT[units.length]] * 3) + ", "
            + ", ".join([_ANGLE_FORMAT[units.angle]] * 3) + "]")


def pose_vector_text(pose: Any, units: Units) -> str:
    """A UR pose vector [x, y, z, rx, ry, rz] in the person's units (pose_label names them)."""
    length, angle = to_display(1.0, LENGTH, units), to_display(1.0, ANGLE, units)
    x, y, z, rx, ry, rz = (float(v) for v in pose)
    # One %-format per pose, not a call per number: `poses list` formats 10⁵ of them.
    return _pose_vector_format(units) % (x * length, y * length, z * length, rx * angle, ry * angle, rz * angle)


def pose_label(what: str, units: Units) -> str:
    """A row label for a pose vector that names its units: 'TCP pose (mm, °)'."""
    return f"{what} ({unit_label(LENGTH, units)}, {unit_label(ANGLE, units)})"


def coefficients_text(values: Any) -> str:
    """Dual-quaternion coefficients [rw rx ry rz | dw dx dy dz] on one line, 9 decimals."""
    values = [float(v) for v in values]
    return "[" + " ".join(f"{v:.9f}" for v in values[:4]) + " | " + " ".join(f"{v:.9f}" for v in values[4:]) + "]"


def distance_text(metres: float, radians: float) -> str:
    """A pose distance as millimetres and degrees."""
    return f"{show(metres, LENGTH, FINE, 3)} / {to_display(radians, ANGLE, FINE):.3f}°"


def recorded_joints_warnings(poses: Any, model: Any = None) -> list[str]:
    """One line per pose whose recorded joints put its TCP elsewhere than its recorded pose (recorded_joints), on
    `model` (None: each pose's own nominal model): the pose, how far, the fix; short enough for 80 columns."""
    from ur3dq.recorded_joints import joints_off_pose  # imports the kinematics: only for commands that read poses

    return [f"warning: pose {off.pose.name!r}: joints {show(off.metres, LENGTH, FINE, 0)}, "
            f"{show(off.radians, ANGLE, FINE, 1)} off its pose; re-record it" for off in joints_off_pose(poses, model)]


def count_text(count: int, noun: str) -> str:
    """`1 pose`, `2 poses`: a count with its noun in the right number (regular plurals only)."""
    return f"{count} {noun}" + ("" if count == 1 else "s")


def angle_unit(units: Units) -> str:
    """The angle unit shown in column headers ('deg' or 'rad')."""
    return units.angle


class VectorCell:
    """A table cell of 6 numbers that wraps between its halves.

    A bracketed 6-number text (joints, a UR pose vector) that, when its cell is too narrow for one line, breaks
    between its halves (x y z | rx ry rz, base-shoulder-elbow | wrists) instead of wherever the width ends."""

    def __init__(self, text: str):
        parts = text.split(", ")
        self.one_line = text
        self.halves = text if len(parts) != 6 else ", ".join(parts[:3]) + ",\n" + ", ".join(parts[3:])

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        fits = len(self.one_line) <= options.max_width
        yield Text(self.one_line if fits else self.halves, overflow="fold")

    def __rich_measure__(self, console: Console, options: ConsoleOptions) -> Measurement:
        return Measurement(max(len(line) for line in self.halves.splitlines()), len(self.one_line))


def key_value_table(title: str, rows: Iterable[tuple[str, str]]) -> Table:
    """A two-column table of (label, value) rows; a 6-number value breaks between its halves when narrow."""
    table = Table(title=title, show_header=False, title_justify="left")
    table.add_column("what", style="bold", no_wrap=True)
    table.add_column("value", overflow="fold")
    for label, value in rows:
        table.add_row(label, VectorCell(value) if value.count(", ") == 5 and value.endswith("]") else value)
    return table


#: A cell of `fitted_table`: text with rich markup, or a VectorCell.
TableCell = str | VectorCell


@dataclasses.dataclass(frozen=True)
class Column:
    """One column of `fitted_table`: headers, alignment, wrapping, drop order.

    A column of `fitted_table`: its header (and a shorter one for narrow terminals), how its cells align, whether
    they may wrap between words, and when it is left out on a narrow terminal (1 = first; None = never)."""

    header: str
    narrow_header: str | None = None
    justify: JustifyMethod = "left"
    no_wrap: bool = False
    drop_order: int | None = None
    min_width: int | None = None


def fitted_table(title: str | None, columns: Sequence[Column], rows: Sequence[Sequence[TableCell]],
                 width: int | None) -> Table:
    """A rich table of `rows` (lists of cells, one per Column) that reads at `width` columns (None: unlimited).

    Below NARROW_WIDTH it is drawn without vertical rules and with the narrow headers; columns are then left out
    in their drop_order while the table's narrowest layout (every word whole) is still wider than `width`, and a
    caption names what was left out. The space left is shared out by ur3dq, not rich, whose squeezing can cut a
    short column to nothing. A no-wrap column (names) keeps every cell whole on one line, unless even the table of
    its never-dropped columns is too wide: then its cells fold over lines, but are never cut.
    """
    narrow = width is not None and width < NARROW_WIDTH
    measured = [_column_measure(column, [row[i] for row in rows], narrow) for i, column in enumerate(columns)]

    # each column's width, from the one measurement of its cells
    def widths_of(indices: list[int], no_wrap: list[bool], natural: bool) -> list[int]:
        return [max(columns[i].min_width or 0, measured[i][2] if natural else measured[i][1 if wrap_off else 0])
                for i, wrap_off in zip(indices, no_wrap)]

    kept = list(range(len(columns)))
    drop_orders = {i: column.drop_order for i, column in enumerate(columns) if column.drop_order is not None}
    while True:
        droppable = [i for i in kept if i in drop_orders]
        no_wrap = [columns[i].no_wrap for i in kept]
        if width is None or not droppable or _table_width(widths_of(kept, no_wrap, False), narrow) <= width:
            break
        kept.remove(min(droppable, key=drop_orders.__getitem__))
    shown, cells = [columns[i] for i in kept], [[row[i] for i in kept] for row in rows]
    if width is not None and _table_width(widths_of(kept, no_wrap, False), narrow) > width:
        # only the never-dropped columns are left and a name alone is longer than the room: it folds, whole
        shown = [dataclasses.replace(column, no_wrap=False) for column in shown]
        no_wrap = [False] * len(kept)
    widths = None
    if width is not None and _table_width(widths_of(kept, no_wrap, True), narrow) > width:
        widths = _shared_widths(widths_of(kept, no_wrap, False), widths_of(kept, no_wrap, True),
                                width - _table_width([0] * len(shown), narrow))
    table = _table(title, shown, cells, narrow, widths)
    left_out = [columns[i].header for i in range(len(columns)) if i not in kept]
    if left_out:
        table.caption = f"not shown at {width} columns: {', '.join(left_out)}"
        table.caption_justify = "left"
    return table


def _table(title: str | None, columns: Sequence[Column], rows: Iterable[Sequence[TableCell]], narrow: bool,
           widths: list[int] | None) -> Table:
    table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD if narrow else box.HEAVY_HEAD,
                  show_edge=not narrow, pad_edge=not narrow, collapse_padding=narrow)
    for index, column in enumerate(columns):
        table.add_column(_header(column, narrow), justify=column.justify, no_wrap=column.no_wrap, overflow="fold",
                         min_width=column.min_width, width=None if widths is None else widths[index])
    for row in rows:
        table.add_row(*row)
    return table


def _header(column: Column, narrow: bool) -> str:
    return column.narrow_header if narrow and column.narrow_header else column.header


def _table_width(column_widths: Sequence[int], narrow: bool) -> int:
    """The drawn width of columns this wide: two spaces between narrow columns; rules, padding and edges else."""
    count = len(column_widths)
    return sum(column_widths) + (2 * (count - 1) if narrow else 3 * (count - 1) + 4)


def _column_measure(column: Column, cells: Sequence[TableCell], narrow: bool) -> tuple[int, int, int]:
    """(longest word, longest unbreakable line, longest line) over the column's header and cells: its narrowest
    width when it may wrap, its narrowest when it may not, and its natural width."""
    measures = [_cell_widths(cell) for cell in [_header(column, narrow), *cells]]
    word, unbreakable, line = (max(measure[k] for measure in measures) for k in range(3))
    return word, unbreakable, line


def _cell_widths(cell: TableCell) -> tuple[int, int, int]:
    """(longest word, longest unbreakable piece, longest line) of a cell: a str with rich markup, or a VectorCell
    (which breaks only between its halves)."""
    if isinstance(cell, VectorCell):
        halves = max(len(line) for line in cell.halves.splitlines())
        return halves, halves, len(cell.one_line)
    lines = Text.from_markup(cell).plain.splitlines() or [""]
    longest = max(len(line) for line in lines)
    return max(len(word) for line in lines for word in line.split() or [""]), longest, longest


def _shared_widths(minimum: list[int], natural: list[int], room: int) -> list[int]:
    """Column widths within `room`: every column its minimum, the rest shared in proportion to what each still
    wants, never beyond its natural width; when the minimums do not fit, the widest column gives up the excess."""
    spare, wanted = room - sum(minimum), [n - m for m, n in zip(minimum, natural)]
    if spare < 0:  # a folding name wider than the room: it gives up the excess (its cells fold, whole)
        widest = max(range(len(minimum)), key=lambda i: minimum[i])
        return [max(8, m + spare) if i == widest else m for i, m in enumerate(minimum)]
    if not sum(wanted):
        return list(minimum)
    widths = [m + w * spare // sum(wanted) for m, w in zip(minimum, wanted)]
    for index in sorted(range(len(widths)), key=lambda i: natural[i] - widths[i], reverse=True):  # rounding left
        if sum(widths) < room and widths[index] < natural[index]:
            widths[index] += 1
    return widths


def joint_solutions_table(title: str, solutions: Any, units: Units, extra_columns: Any = (),
                          width: int | None = None) -> Table:
    """A table of joint vectors, one row each.

    A table with one row per joint vector; `extra_columns` = [(Column, [text per row])]. Narrower than
    NARROW_WIDTH the angles have 4 decimals (2 in degrees) so the six joints fit 80 columns."""
    narrow = width is not None and width < NARROW_WIDTH
    unit = angle_unit(units)
    deg = units.angle == "deg"
    columns = [Column("#", justify="right")]
    columns += [Column(f"{label} ({unit})", narrow_header=label, justify="right") for label in JOINT_LABELS]
    columns += [column for column, _ in extra_columns]
    rows = []
    for index, q in enumerate(solutions):
        angles = [(f"{to_display(float(v), ANGLE, units):.2f}" if deg else f"{float(v):.4f}") if narrow
                  else angle_text(float(v), units) for v in q]
        rows.append([str(index + 1), *angles, *(values[index] for _, values in extra_columns)])
    table = fitted_table(title, columns, rows, width)
    if narrow:  # the unit leaves the headers for the caption
        table.caption = "; ".join(filter(None, [f"joints in {unit}", str(table.caption or "")]))
        table.caption_justify = "left"
    return table


def pose_rows(model: Any, pose: Any, units: Units) -> list[tuple[str, str]]:
    """What record-pose shows about a reading: joints, TCP pose, dual quaternion, and `model`'s FK check."""
    metres, radians = model.fk(pose.joints).distance(pose.dq)
    return [
        (f"joints ({unit_label(ANGLE, units)})", angles_text(pose.joints, units)),
        (pose_label("TCP pose", units), pose_vector_text(pose.ur_pose, units)),
        ("dual quaternion", coefficients_text(pose.dual_quaternion)),
        ("thesis line", pose.dq.to_thesis_line()),
        (pose_label("TCP offset", units), pose_vector_text(pose.tcp_offset, units)),
        ("model FK check", f"{distance_text(metres, radians)} from the controller's TCP"),
    ]


NARROW_WIDTH = 120  # below this many columns the tables use compact numbers that wrap between values


def compact_angles_text(values: Any, units: Units) -> str:
    """Joint angles on a narrow terminal: space-separated (so they wrap between values), 3 decimals (1 in °)."""
    if units.angle == "deg":
        return " ".join(f"{to_display(float(v), ANGLE, units):.1f}°" for v in values)
    return " ".join(f"{float(v):.3f}" for v in values)


def compact_pose_text(pose: Any, units: Units) -> str:
    """A UR pose vector on a narrow terminal: metres with 3 decimals (mm with 1), then the rotation as
    compact_angles_text."""
    length = "%.1f" if units.length == "mm" else "%.3f"
    return " ".join(length % to_display(float(v), LENGTH, units) for v in pose[:3]) + " " + \
        compact_angles_text(pose[3:], units)


PLAIN_TABLE_ROWS = 2000  # beyond this, tables are printed as tab-separated lines (rich takes minutes to lay out)


def print_table(console: Console, title: str, columns: Sequence[Column], rows: Iterable[Sequence[str]],
                count: int | None = None) -> None:
    """Print a table of Columns at the console's width.

    A table of Columns on `console` that reads at its width (names are never cut or dropped); user text is
    shown as typed (no markup). `rows`: a sequence of rows (lists of text), or an iterable of `count` rows. A table
    of more than PLAIN_TABLE_ROWS rows is written as tab-separated lines as the rows come (10⁵ rows need no list of
    them), straight to the console's file (stderr under --json, like the table would be)."""
    if count is None:
        rows = list(rows)
        count = len(rows)
    if count > PLAIN_TABLE_ROWS:
        write = console.file.write
        write(title + "\n" + "\t".join(column.header for column in columns) + "\n")
        block = []
        for row in rows:
            block.append("\t".join(row))
            if len(block) == 1000:   # one write per 1000 lines: a write per line costs more than the text
                write("\n".join(block) + "\n")
                block = []
        if block:
            write("\n".join(block) + "\n")
        return
    # The title on its own line, unwrapped: a table's title wraps to the table's width, which would cut a store
    # path (and a Text is never read as markup).
    console.print(Text(title, no_wrap=True, overflow="ignore"))
    console.print(fitted_table(None, columns, [[escape(cell) for cell in row] for row in rows], console.width))


def plan_table(steps: Any, units: Units, title: str, width: int | None = None) -> Table:
    """The replay plan (ur3dq.replay.PlanStep list) as a table: replay_plan's columns and rows."""
    columns, rows = replay_plan(steps, units, width)
    return fitted_table(title, columns, [[escape(cell) for cell in row] for row in rows], width)


def replay_plan(steps: Any, units: Units, width: int | None = None) -> tuple[list[Column], Iterator[tuple[str, ...]]]:
    """The columns and rows of a replay plan's table.

    (Columns, an iterator of the rows in plain text) of the replay plan (ur3dq.replay.PlanStep list): chosen
    joints, how they were chosen, travel, time, FK residual. Narrower than NARROW_WIDTH columns, the joints are
    compact and wrap three per line, and the FK check, the time and how the joints were chosen are left out in that
    order while the table would not fit; the pose name is never cut."""
    narrow = width is not None and width < NARROW_WIDTH
    unit = angle_unit(units)
    joints_width = len(compact_angles_text([-3.14159] * 3, units)) if narrow else None
    columns = [Column("#", justify="right", no_wrap=True), Column("pose", no_wrap=True),
               Column(f"joints ({unit})", min_width=joints_width), Column("chosen by", drop_order=3),
               Column("travel", justify="right", no_wrap=True, drop_order=4),
               Column("time", justify="right", no_wrap=True, drop_order=2),
               Column("FK check", drop_order=1)]
    return columns, _replay_rows(steps, units, narrow)


def _replay_rows(steps: Any, units: Units, narrow: bool) -> Iterator[tuple[str, ...]]:
    """replay_plan's rows, one at a time."""
    deg = units.angle == "deg"
    for index, step in enumerate(steps, start=1):
        if narrow:
            joints = compact_angles_text(step.joints, units)
            travel = "—" if step.travel is None else (f"{to_display(step.travel, ANGLE, units):.1f}°" if deg
                                                      else f"{step.travel:.3f}")
        else:
            joints = angles_text(step.joints, units)
            travel = "—" if step.travel is None else angle_text(step.travel, units)
        yield (str(index), step.pose.name, joints, step.source + (f" (of {step.solutions})" if step.solutions else ""),
               travel, "—" if step.duration is None else f"{step.duration:.2f} s",
               distance_text(step.fk_error_m, step.fk_error_rad))


def reached_table(results: Iterable[Reached], title: str, width: int | None = None) -> Table:
    """A table of where each replayed pose ended.

    Where each replayed pose ended (ur3dq.replay.Reached list) vs where the replay aimed the current TCP: the
    recorded TCP pose, or — replaying the flange of a pose recorded with another TCP — a point that far from it."""
    columns = [Column("#", justify="right", no_wrap=True), Column("pose", no_wrap=True), Column("aimed at"),
               Column("error"), Column("move time", narrow_header="time", justify="right", drop_order=1)]
    rows = []
    for index, result in enumerate(results, start=1):
        aimed = "recorded TCP pose" if result.target_off_m < 1e-4 else \
            f"recorded flange: {result.target_off_m * 1000:.1f} mm from the recorded TCP"
        rows.append([str(index), escape(result.step.pose.name), aimed,
                     distance_text(result.error_m, result.error_rad), f"{result.seconds:.2f} s"])
    return fitted_table(title, columns, rows, width)


@contextlib.contextmanager
def progress_bar(console: Console) -> Iterator[Callable[[str, int, int], None]]:
    """A rich progress bar on `console`; yields the callback ur3dq.replay.execute_plan reports to."""
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
               TimeElapsedColumn())
    with Progress(*columns, console=console, transient=False) as progress:
        task = progress.add_task("moving", total=None)

        def report(description: str, done: int, total: int) -> None:
            progress.update(task, description=escape(description), completed=done, total=total)

        yield report


def pose_summary(pose: DualQuaternion) -> dict[str, Any]:
    """The JSON description of a pose: UR pose vector, dual-quaternion coefficients, thesis line (SI units)."""
    return {"ur_pose": pose.to_ur_pose().tolist(), "dual_quaternion": pose.to_array().tolist(),
            "thesis_line": pose.to_thesis_line()}
