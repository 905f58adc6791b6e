"""What check_path returns: the PathCheckResult, one StepReport per checked move, and the read-only Figures of a
report's margins and worst samples.

The reports of a big plan are a StepReports sequence: the sampled moves' reports as check_path built them, and the
joint moves the clearance bounds certified (pathcheck.bounds) as the bounds' columns, each of their reports built
when it is read: a big store's plan has 10⁵ certified moves, whose reports would cost much of the whole check,
and a margins table reads a few of them (StepReports.smallest_margins, positions_named).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Container, Iterator, Mapping, Sequence
from typing import TypeAlias, TypeVar, overload

import numpy as np

from ur3dq.array_types import FloatArray, IntArray
from ur3dq.errors import SafetyCheckError, literal
from ur3dq.pathcheck.checks import Problem
from ur3dq.pathcheck.path_plan import PathSegment
from ur3dq.units import SI, Units, Wording, worded

#: A figure's type: float for margins, int for sample indices.
Value = TypeVar("Value")


class Figures(Mapping[str, Value]):
    """An immutable {check: number} mapping of a StepReport.

    A StepReport's margins, or its worst samples: a tuple of the numbers beside a tuple of the check names that
    reports share (smaller than a dict, and a big plan has 10⁵ reports); reports with the same worst samples share
    one."""

    __slots__ = ("_keys", "_values")

    def __init__(self, keys: tuple[str, ...], values: tuple[Value, ...]) -> None:
        self._keys, self._values = keys, values

    def __getitem__(self, key: str) -> Value:
        try:
            return self._values[self._keys.index(key)]
        except ValueError:
            raise KeyError(key) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._keys)

    def __len__(self) -> int:
        return len(self._keys)

    def __contains__(self, key: object) -> bool:
        return key in self._keys

    # Tuples, not the mixins' views: those look each value up again, and a margins table reads 10⁵ reports.
    def keys(self) -> tuple[str, ...]:   # type: ignore[override]  # a tuple is a fine keys view here
        """The check names."""
        return self._keys

    def values(self) -> tuple[Value, ...]:   # type: ignore[override]  # a tuple, as keys()
        """The numbers, in the order of keys()."""
        return self._values

    def items(self) -> tuple[tuple[str, Value], ...]:   # type: ignore[override]  # a tuple, as keys()
        """(check, number) pairs."""
        return tuple(zip(self._keys, self._values))

    def __repr__(self) -> str:
        return repr(dict(self.items()))


def figures(values: dict[str, Value]) -> Figures[Value]:
    """The Figures of a dict {check: number}."""
    return Figures(tuple(values), tuple(values.values()))


@dataclasses.dataclass(frozen=True, slots=True)  # slots: one per move, 10⁵ in a big plan
class StepReport:
    """What the check saw on one move: its samples and its smallest margins.

    fraction (n,), joints (n, 6), tcp (n, 3) m (all None when the check was asked not to keep samples); margins:
    {check: smallest margin over the move (≥ 0 passes), in the check's unit: m for clearances, |sin| for
    wrist/elbow, m for shoulder, rad for joint limits, fraction of the maximum for joint speed}; worst: {check:
    index of the sample with that smallest margin} (both read-only mappings, Figures); end_joints (6,): where the
    next move starts (None if this one could not be followed); samples: n, how many samples were checked.
    """

    name: str
    move: str
    fraction: FloatArray | None
    joints: FloatArray | None
    tcp: FloatArray | None
    margins: Mapping[str, float]
    worst: Mapping[str, int]
    end_joints: FloatArray | None
    samples: int

    def to_dict(self) -> dict[str, object]:
        """The report as JSON-ready values (margins rounded to 6 decimals, no samples)."""
        return {"name": self.name, "move": self.move, "samples": self.samples,
                "margins": {k: round(float(v), 6) for k, v in self.margins.items()},
                "end_joints": None if self.end_joints is None else [float(v) for v in self.end_joints]}


#: A group of CertifiedMoves rows: (first row, margin keys, margins (K, M) floats, worst keys, worst (K, M) ints).
_Group: TypeAlias = tuple[int, tuple[str, ...], FloatArray, tuple[str, ...], IntArray]


class CertifiedMoves:
    """The joint moves the bounds certified, as columns.

    The joint moves the bounds certified, as columns: row r is segments[r] (a PathSegment, which it ends on), with
    margins[check][r], worst[check][r] (sample index) and samples[r] from a bounds.Certification; row_of maps the
    plan's move index to its row. Rows are added a group of moves at a time (one group per TCP). `position[r]`: the
    move's place among the StepReports, set by check_path as it goes."""

    def __init__(self) -> None:
        self.row_of: dict[int, int] = {}
        self.segments: list[PathSegment] = []
        self.position: list[int] = []
        self._groups: list[_Group] = []
        self._samples: list[int] = []
        self._shared: dict[tuple[int, ...], Figures[int]] = {}   # worst samples -> their Figures, shared

    def add(self, index: list[int], segments: list[PathSegment], margins: dict[str, FloatArray],
            worst: dict[str, IntArray], samples: IntArray) -> None:
        """Add a group of certified moves.

        Add a group of M rows: move indices and PathSegments (M each), margins and worst {check: (M,) array},
        samples (M,)."""
        first, count = len(self.segments), len(segments)
        if not count:
            return
        self.row_of.update(zip(index, range(first, first + count)))
        self.segments.extend(segments)
        self.position.extend([-1] * count)
        self._groups.append((first, tuple(margins), np.array(list(margins.values()), dtype=float).reshape(-1, count),
                             tuple(worst), np.array(list(worst.values()), dtype=int).reshape(-1, count)))
        self._samples.extend(samples.tolist())

    def _group(self, row: int) -> _Group:
        for group in reversed(self._groups):
            if group[0] <= row:
                return group
        raise IndexError(row)

    def report(self, row: int) -> StepReport:
        """The StepReport of row `row` (no samples kept; it ends on its target), its numbers as Python floats."""
        first, margin_keys, margins, worst_keys, worst = self._group(row)
        sample: tuple[int, ...] = tuple(worst[:, row - first].tolist())
        if sample not in self._shared:
            self._shared[sample] = Figures(worst_keys, sample)
        segment = self.segments[row]
        return StepReport(segment.name, segment.move, None, None, None,
                          Figures(margin_keys, tuple(margins[:, row - first].tolist())), self._shared[sample],
                          segment.target_joints, self._samples[row])

    def smallest(self) -> list[tuple[str, float, int]]:
        """[(check, margin, position)]: per group and check, the row with the smallest margin (the first such)."""
        found = []
        for first, margin_keys, margins, _, _ in self._groups:
            rows = np.argmin(margins, axis=1)
            for check, row, values in zip(margin_keys, rows.tolist(), margins):
                found.append((check, float(values[row]), self.position[first + row]))
        return found

    def samples(self) -> int:
        """How many samples the bounds evaluated, over all certified moves."""
        return sum(self._samples)


class StepReports(Sequence[StepReport]):
    """The StepReports of a check, in plan order.

    The StepReports of a check in plan order (PathCheckResult.steps): each entry a StepReport, or the int row of
    a move in `certified` (CertifiedMoves), whose report is built when read."""

    __slots__ = ("_entries", "_certified")

    def __init__(self, entries: list[StepReport | int], certified: CertifiedMoves | None = None) -> None:
        self._entries, self._certified = entries, certified

    def __len__(self) -> int:
        return len(self._entries)

    @overload
    def __getitem__(self, index: int) -> StepReport: ...

    @overload
    def __getitem__(self, index: slice) -> list[StepReport]: ...

    def __getitem__(self, index: int | slice) -> StepReport | list[StepReport]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        entry = self._entries[index]
        if isinstance(entry, int):
            assert self._certified is not None   # only certified moves are kept as rows
            return self._certified.report(entry)
        return entry

    def __repr__(self) -> str:
        return f"StepReports({len(self)} moves)"

    def smallest_margins(self) -> dict[str, tuple[float, int]]:
        """{check: (smallest margin over every move, the position of the first move with it)}."""
        found = [] if self._certified is None else self._certified.smallest()
        found += [(check, value, position) for position, entry in enumerate(self._entries)
                  if isinstance(entry, StepReport) for check, value in entry.margins.items()]
        smallest: dict[str, tuple[float, int]] = {}
        for check, value, position in sorted(found, key=lambda item: item[2]):
            if check not in smallest or value < smallest[check][0]:
                smallest[check] = (value, position)
        return smallest

    def positions_named(self, names: Container[str]) -> list[int]:
        """The positions of the moves named in `names` (a set), in order."""
        segments = [] if self._certified is None else self._certified.segments
        return [position for position, entry in enumerate(self._entries)
                if (segments[entry].name if isinstance(entry, int) else entry.name) in names]

    def samples(self) -> int:
        """How many samples the check evaluated over all moves."""
        return sum(entry.samples for entry in self._entries if isinstance(entry, StepReport)) + \
            (0 if self._certified is None else self._certified.samples())


@dataclasses.dataclass(frozen=True)
class PathCheckResult:
    """The result of check_path.

    ok: no problem; problems: every failed check (at most one per move and check, at its worst sample);
    steps: one StepReport per checked move (StepReports); unchecked: names of moves that could not be
    checked (no start); limits: {check: the limit its margins are measured from} (a margin m means a measured
    value of limit + m: |sin θ5| for "wrist", a clearance in metres for "cell", ...; "joint_speed" is the
    fraction of the top speed allowed, and its margin the fraction left)."""

    problems: tuple[Problem, ...]
    steps: StepReports
    unchecked: tuple[str, ...] = ()
    limits: dict[str, float] = dataclasses.field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when no check failed and every move was checked."""
        return not self.problems and not self.unchecked

    def summary(self, units: Units = SI) -> str:
        """One line: the first problem (with how many more), its numbers in `units`, or that the path is clear."""
        return worded(*self.summary_wording(), units)

    def summary_wording(self) -> Wording:
        """(summary's ``units.worded`` text, its values): to carry it into an error's message."""
        if self.problems:
            more = len(self.problems) - 1
            text, measured = self.problems[0].wording()
            return text + (f" (+{more} more problem{'s' * (more > 1)})" if more else ""), measured
        if self.unchecked:
            return literal(f"steps {', '.join(map(repr, self.unchecked))} could not be checked (no known start)"), ()
        return f"path clear: {len(self.steps)} moves, {self.steps.samples()} samples checked", ()

    def refusal(self) -> SafetyCheckError:
        """The error that refuses a motion along this failed path: "path check: " and the summary, its numbers
        shown in the units of whoever reads it (UR3DQError.shown_in)."""
        text, measured = self.summary_wording()
        return SafetyCheckError.from_wording("path check: " + text, measured)

    def to_dict(self) -> dict[str, object]:
        """The result as JSON-ready values."""
        return {"ok": self.ok, "problems": [p.to_dict() for p in self.problems],
                "steps": [s.to_dict() for s in self.steps], "unchecked": list(self.unchecked)}
