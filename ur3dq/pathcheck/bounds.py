"""Joint moves certified by clearance bounds, all moves at once: dense sampling only where no bound shows that a
move keeps its margins.

A joint move runs q(s) = q0 + s·Δq, s ∈ [0, 1]. Turning joint k by dθ moves a point at distance ρ from the joint's
axis by at most ρ·|dθ|, and a capsule fixed in DH frame f moves with joints 1…f. So along a move:
* the distance between two capsules in frames f ≤ g changes with joints f+1…g only (frame f sees the first
  capsule still and the second moved by those alone): by at most L = Σ_{k=f+1..g} |Δq_k|·ρ_k per unit of s, ρ_k
  bounding the distance of the frame-g capsule's points from joint k's axis;
* a capsule's distance to a fixed obstacle (a box, the floor, a keep-in wall) changes by at most Σ_{k≤f} |Δq_k|·ρ_k.
ρ_k holds in every configuration: the translations of links k…f, Σ √(a_i² + d_i²) (a link moves its origin by
a_i·x_i + d_i·z_{i−1}, and x_i ⊥ z_{i−1}) less link k's d_k, which runs along joint k's own axis, plus the capsule
end point's distance from its frame's origin.

A margin m(s) with Lipschitz constant L·w on an interval of length w, and lower bounds m0, m1 of it at the two
ends, keeps min m ≥ (m0 + m1 − L·w)/2 there. It also bends down by at most C per unit s²: a clearance is a distance
less a constant offset (radii and margin), the least over the capsules' point pairs (or over a capsule's points, to a
convex obstacle or a plane) of a distance g(s) = |x(s)| with g″ ≤ |x″| + |x′|²/|x|. A point at distance ρ_k from
joint k's axis has |x″| ≤ H = Σ_k |Δq_k|·ρ_k·(2·Σ_{j<k} |Δq_j| + |Δq_k|) (∂²x/∂θj∂θk = z_j × (z_k × (x − o_k)) for
j ≤ k, by Jacobi's identity), |x′| ≤ L and |x| ≥ offset + the Lipschitz bound, so C = H + L²/(offset + that bound)
while it is positive. The least of such functions lies above its chord less C/2·(s − s0)(s1 − s): the bound is the
larger of the two. An interval whose bound is under its target is halved, for every move at once, up to MAX_DEPTH
times; a move left with such an interval, or with a sample that fails, is not certified,
and the caller samples it densely as before (sampling.sample_joint_move). A certified move passes at every point,
so its dense samples would too: the check's verdicts and problems are the dense check's.

The target of a column is 0 (its margin holds) or, when higher, the smallest margin of its check sampled so far in
the batch: an interval that might hold the plan's smallest margin is refined too, so that the caller can report
that margin from dense samples (path_check._refine_smallest).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ur3dq.array_types import BoolArray, FloatArray, IntArray
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import geometry
from ur3dq.pathcheck.checks import StepChecker

#: Halvings of a move before it is sampled densely (64 intervals; a dense joint move has ~20–100 samples).
MAX_DEPTH = 6
#: Configurations evaluated per call of the clearance kernels, and moves bisected together: bounds the temporary
#: arrays (a configuration's take ~2 kB; a move's intervals up to 2^MAX_DEPTH × ~0.5 kB).
_CHUNK = 2048
_BLOCK = 2048


@dataclasses.dataclass(frozen=True)
class Certification:
    """The result of the bound check of M joint moves.

    The bound check of M joint moves. certified (M,) bool: every point of the move keeps every margin (and the
    move need not be sampled densely); lower {check: (M,)} a lower bound of the move's smallest margin over the
    whole move; margins {check: (M,)} the smallest margin at the move's evaluated samples; worst {check: (M,)}
    the index of that sample among the move's samples in path order; samples (M,) how many were evaluated.
    Checks: "joint_limit" (exact: joints move linearly, so the ends hold the smallest room), and
    "self_collision" / "cell" where the checker has them."""

    certified: BoolArray
    lower: dict[str, FloatArray]
    margins: dict[str, FloatArray]
    worst: dict[str, IntArray]
    samples: IntArray


def lever_arms(model: URModel, capsules: geometry.Capsules) -> FloatArray:
    """How far each capsule's points can be from each joint's axis.

    (6, C) m: a bound, in every configuration, of the distance of capsule c's points from joint k + 1's axis;
    0 where that joint does not move the capsule (k + 1 > the capsule's frame)."""
    link = np.hypot(model.dh.a, model.dh.d)
    reach = np.maximum(np.linalg.norm(capsules.a, axis=1), np.linalg.norm(capsules.b, axis=1))
    levers = np.zeros((6, len(reach)))
    for k in range(6):
        # Link k + 1's own d runs along joint k + 1's axis: only its a moves points away from that axis.
        chain = np.array([abs(model.dh.a[k]) + link[k + 1:frame].sum() for frame in capsules.frame])
        levers[k] = np.where(capsules.frame >= k + 1, chain + reach, 0.0)
    return levers


def column_rates(checker: StepChecker, levers: FloatArray) -> FloatArray:
    """How fast each clearance column can change per radian of each joint.

    (K, 6) m/rad: how fast each clearance column of checker.clearance_margins can change per radian of each
    joint (self-collision pairs, then cell capsule × obstacle columns)."""
    frame = checker.capsules.frame
    rows = []
    for i, j in zip(checker.pair_a, checker.pair_b):
        low, high = (i, j) if frame[i] <= frame[j] else (j, i)
        row = levers[:, high].copy()
        row[:frame[low]] = 0.0   # joints 1…f turn both capsules together
        if frame[low] < 6 and _on_axis(checker.capsules, low):
            row[frame[low]] = 0.0   # a capsule on joint f + 1's axis is symmetric about it: the base, the shoulder
        rows.append(row)
    rows.extend(levers[:, c] for c in checker.cell_capsules for _ in checker.obstacles)
    return np.array(rows, dtype=float).reshape(-1, 6)


def _on_axis(capsules: geometry.Capsules, c: int) -> bool:
    """True when capsule c's segment lies on the z axis of its frame (the axis of the next joint)."""
    return not (np.any(capsules.a[c, :2]) or np.any(capsules.b[c, :2]))


def certify_joint_moves(checker: StepChecker, q0: FloatArray, q1: FloatArray) -> Certification:
    """Certify joint moves by clearance bounds, without dense samples.

    Certify the joint moves q0 → q1 ((M, 6) rad each) on `checker` (a checks.StepChecker: model, capsules,
    cell, margins). See the module docstring."""
    count = len(q0)
    rates = column_rates(checker, lever_arms(geometry.body_model(checker.model), checker.capsules))   # (K, 6)
    offsets = column_offsets(checker)
    limit_margin, limit_worst = _joint_limit(checker, q0, q1)
    failed = limit_margin < 0
    pending = np.zeros(count, dtype=bool)
    records = _Records(_groups(checker), checker.margins.tcp_resolution, count)
    # A block of moves at a time: a move's intervals double at each depth, and so would the arrays of all moves.
    carried: tuple[FloatArray, FloatArray] | None = None   # (joints, margins) at the end of the block before
    for first in range(0, count, _BLOCK):
        block = slice(first, min(first + _BLOCK, count))
        moves = np.arange(block.start, block.stop)
        ends = _evaluate(checker, q1[block])
        starts = _start_margins(checker, q0[block], q1[block], ends, carried)
        carried = q1[block.stop - 1], ends[-1]
        failed[block] |= (starts < 0).any(axis=1) | (ends < 0).any(axis=1)
        records.add(moves, np.zeros(len(moves)), starts)
        records.add(moves, np.ones(len(moves)), ends)
        delta = q1[block] - q0[block]
        rate, bend = column_slopes(rates, np.abs(delta))
        slopes = _Slopes(rate, bend, offsets)
        _bisect(checker, q0[block], delta, slopes, moves, starts, ends, records, failed, pending)
        records.close_block(block.start, len(moves))
    margins, worst, samples = dict(records.margins), dict(records.worst), records.samples
    margins["joint_limit"], worst["joint_limit"] = limit_margin, np.where(limit_worst, samples - 1, 0)
    return Certification(~failed & ~pending, {**records.lower, "joint_limit": limit_margin}, margins, worst, samples)


def _bisect(checker: StepChecker, q0: FloatArray, delta: FloatArray, slopes: _Slopes, move: IntArray, m0: FloatArray,
            m1: FloatArray, records: _Records, failed: BoolArray, pending: BoolArray) -> None:
    """Halve the intervals of a block of B moves — starts q0 (B, 6), steps delta (B, 6), their columns' _Slopes,
    indices `move` (B,) among all moves, margins m0, m1 (B, K) at their starts and ends — while their bound is
    below the records' targets; mark in place (by index among all moves): failed (a sample below 0), pending (an
    interval still open at MAX_DEPTH); the bounds of the final intervals go to `records`."""
    first = move[0]
    s0, s1 = np.zeros(len(move)), np.ones(len(move))
    for depth in range(MAX_DEPTH + 1):
        bound = interval_bound(m0, m1, (s1 - s0)[:, None], slopes.rate[move - first], slopes.bend[move - first],
                               slopes.offset)
        short = bound < records.targets()
        open_ = short.any(axis=1) & ~failed[move]
        records.bound(move[~open_], bound[~open_])
        if depth == MAX_DEPTH or not open_.any():
            pending[move[open_]] = True
            return
        move, s0, s1, m0, m1, bound = move[open_], s0[open_], s1[open_], m0[open_], m1[open_], bound[open_]
        # Only the columns some open interval is short on are evaluated at the middles (often one capsule pair of
        # fifteen). Every other column's bound holds on the whole interval, so on both halves: it is kept in the
        # records now, and the halves carry +inf for it (never short again).
        needed = short[open_].any(axis=0)
        records.bound(move, np.where(needed, np.inf, bound))
        middle = 0.5 * (s0 + s1)
        values = _evaluate(checker, q0[move - first] + middle[:, None] * delta[move - first], np.flatnonzero(needed))
        failed[move[(values < 0).any(axis=1)]] = True
        records.add(move, middle, values)
        move, s0, s1 = np.concatenate((move, move)), np.concatenate((s0, middle)), np.concatenate((middle, s1))
        m0, m1 = np.concatenate((m0, values)), np.concatenate((values, m1))


def column_offsets(checker: StepChecker) -> FloatArray:
    """What each clearance column subtracts from a distance.

    (K,) m: what each clearance column of checker.clearance_margins subtracts from a distance — the capsules'
    radii and the check's margin (the distance is the margin plus this)."""
    radius = checker.capsules.radius
    pairs = radius[checker.pair_a] + radius[checker.pair_b] + checker.margins.self_collision
    cell = np.repeat(radius[checker.cell_capsules], len(checker.obstacles)) + checker.cell_margin
    return np.concatenate((pairs, cell)).astype(float)


def column_slopes(rates: FloatArray, steps: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The rate and bend bounds of each column along each move.

    (L (M, K) m, H (M, K) m) of M joint moves with joint steps |Δq| `steps` (M, 6) rad and column rates `rates`
    (K, 6) m/rad: how fast each column's points move and how fast that speed turns, per unit of the move's
    parameter s (see the module docstring). A joint with rate 0 does not move the column's pair apart."""
    moving = steps[:, None, :] * (rates > 0)            # (M, K, 6): the joints that move each column
    before = np.cumsum(moving, axis=2) - moving          # Σ_{j<k} |Δq_j| over those joints
    return steps @ rates.T, np.einsum("mkj,kj->mk", moving * (2.0 * before + moving), rates)


@dataclasses.dataclass(frozen=True)
class _Slopes:
    """A block's column_slopes — rate L (B, K), bend H (B, K) — and the columns' offsets (K,)."""

    rate: FloatArray
    bend: FloatArray
    offset: FloatArray


def interval_bound(m0: FloatArray, m1: FloatArray, width: FloatArray, rate: FloatArray, bend: FloatArray,
                   offset: FloatArray) -> FloatArray:
    """A lower bound of a column's margin over an interval of a move.

    A lower bound of a column's margin over an interval of `width` (of the move's parameter s; (B, 1)) from lower
    bounds m0, m1 of it at the ends, the move's column_slopes `rate`, `bend` and the columns' `offset` (all (B, K)
    or broadcastable): the larger of the Lipschitz bound and the chord bound (module docstring). +inf ends (columns
    not evaluated) give +inf."""
    lipschitz = 0.5 * (m0 + m1 - rate * width)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        near = offset + lipschitz   # the least distance on the interval is at least this
        bend = np.where(near > 0, bend + rate * rate / near, np.inf) * width * width
        # the least of m0 + (m1 − m0)·t − bend/2·t·(1 − t) over t in [0, 1]
        t = np.clip(0.5 - (m1 - m0) / bend, 0.0, 1.0)
        chord = m0 + (m1 - m0) * t - 0.5 * bend * t * (1.0 - t)
        # bend 0: nothing moves (m0 = m1); +inf: no curvature bound (the interval may come near a contact)
        chord = np.where(bend > 0, np.where(np.isfinite(bend), chord, -np.inf), np.minimum(m0, m1))
    return np.where(np.isfinite(lipschitz), np.fmax(lipschitz, chord), lipschitz)


def _column_counts(checker: StepChecker) -> tuple[int, int]:
    """(self-collision columns P, all columns K) of checker.clearance_margins: P capsule pairs, then one column per
    cell capsule and obstacle."""
    pairs = len(checker.pair_a)
    return pairs, pairs + len(checker.cell_capsules) * len(checker.obstacles)


def _groups(checker: StepChecker) -> dict[str, slice]:
    """{check: column slice} of checker.clearance_margins' columns, for the checks the checker has."""
    pairs, total = _column_counts(checker)
    named = {"self_collision": slice(0, pairs), "cell": slice(pairs, total)}
    return {name: columns for name, columns in named.items() if columns.stop > columns.start}


def _evaluate(checker: StepChecker, joints: FloatArray, columns: IntArray | None = None) -> FloatArray:
    """(n, K) clearance margins of joints (n, 6), n ≥ 1, computed in chunks: all columns, or only `columns`
    (indices; the others +inf). The cell's columns are computed together (one kernel for all of them)."""
    pairs, total = _column_counts(checker)
    if columns is None:
        columns = np.arange(total)
    chosen_pairs, cell = columns[columns < pairs], bool(np.any(columns >= pairs))
    values = np.full((len(joints), total), np.inf)
    for i in range(0, len(joints), _CHUNK):
        gap, flat = checker.clearance_margins(joints[i:i + _CHUNK], chosen_pairs, cell)
        values[i:i + _CHUNK, chosen_pairs] = gap
        if cell:
            values[i:i + _CHUNK, pairs:] = flat
    return values


def _start_margins(checker: StepChecker, q0: FloatArray, q1: FloatArray, ends: FloatArray,
                   carried: tuple[FloatArray, FloatArray] | None) -> FloatArray:
    """(B, K) margins at the starts of a block of moves q0 → q1 with margins `ends` (B, K) at their ends: a move
    that starts where the one before it ended shares its values, the first one those `carried` (joints (6,),
    margins (K,)) from the block before (None: none)."""
    starts = np.empty_like(ends)
    shared = np.zeros(len(q0), dtype=bool)
    shared[1:] = np.all(q0[1:] == q1[:-1], axis=1)
    starts[shared] = ends[np.flatnonzero(shared) - 1]
    if carried is not None and np.array_equal(q0[0], carried[0]):
        shared[0], starts[0] = True, carried[1]
    if not shared.all():
        starts[~shared] = _evaluate(checker, q0[~shared])
    return starts


def _joint_limit(checker: StepChecker, q0: FloatArray, q1: FloatArray) -> tuple[FloatArray, BoolArray]:
    """(smallest room (M,) rad of the move from its joint limits, True where the end has it rather than the start).
    Joints move linearly, so a move's ends hold its smallest room."""
    room0, room1 = checker.limit_room(q0)[0], checker.limit_room(q1)[0]
    return np.minimum(room0, room1), room1 < room0


class _Records:
    """What the bisection found: per move its smallest sampled margin per check (and which sample, in path order),
    its sample count and its smallest interval bound per check, reduced one block of moves at a time; and the
    smallest sampled margin per check so far (the bisection's targets)."""

    def __init__(self, groups: dict[str, slice], tolerance: float, count: int) -> None:
        self.groups, self.tolerance = groups, tolerance
        self.smallest = dict.fromkeys(groups, np.inf)
        self.margins = {name: np.full(count, np.inf) for name in groups}
        self.worst = {name: np.zeros(count, dtype=int) for name in groups}
        self.lower = {name: np.full(count, np.inf) for name in groups}
        self.samples = np.zeros(count, dtype=int)
        # the open block's samples (move, fraction, per-check values) and bounds (move, per-check bounds)
        self._samples: list[tuple[IntArray, FloatArray, FloatArray]] = []
        self._bounds: list[tuple[IntArray, FloatArray]] = []

    def _per_check(self, values: FloatArray) -> FloatArray:
        """(n, checks) the smallest of each check's columns of values (n, K)."""
        if not self.groups:
            return np.zeros((len(values), 0))
        return np.stack([values[:, columns].min(axis=1) for columns in self.groups.values()], axis=1)

    def add(self, move: IntArray, fraction: FloatArray, values: FloatArray) -> None:
        """Keep samples: their moves (n,), path fractions (n,) and margins (n, K)."""
        per_check = self._per_check(values)
        self._samples.append((move, fraction, per_check))
        for k, name in enumerate(self.groups):
            if len(move):
                self.smallest[name] = min(self.smallest[name], float(per_check[:, k].min()))

    def bound(self, move: IntArray, bounds: FloatArray) -> None:
        """Keep lower bounds (n, K) of the margins on intervals of the moves `move` (n,)."""
        self._bounds.append((move, self._per_check(bounds)))

    def targets(self) -> FloatArray:
        """(K,) what each column's bound must reach: 0, or its check's smallest sampled margin when higher."""
        columns = [np.full(c.stop - c.start, max(0.0, self.smallest[name] - self.tolerance))
                   for name, c in self.groups.items()]
        return np.concatenate(columns) if columns else np.zeros(0)

    def close_block(self, first: int, size: int) -> None:
        """Reduce the samples and bounds kept for moves first … first + size − 1 to their figures, and drop them."""
        move, fraction, values = (np.concatenate(parts) for parts in zip(*self._samples))
        move = move - first
        order = np.lexsort((fraction, move))
        samples = np.bincount(move, minlength=size)
        start = np.concatenate(([0], np.cumsum(samples)[:-1]))
        position = np.empty(len(order), dtype=int)
        position[order] = np.arange(len(order))
        block = slice(first, first + size)
        self.samples[block] = samples
        for k, name in enumerate(self.groups):
            smallest = np.lexsort((values[:, k], move))[start]   # each move's record with its smallest margin
            self.margins[name][block] = values[smallest, k]
            self.worst[name][block] = position[smallest] - start
        if self._bounds:
            move, values = (np.concatenate(parts) for parts in zip(*self._bounds))
            order = np.argsort(move, kind="stable")
            move, values = move[order] - first, values[order]
            heads = np.flatnonzero(np.concatenate(([True], move[1:] != move[:-1])))
            reduced = np.minimum.reduceat(values, heads, axis=0)
            for k, name in enumerate(self.groups):
                self.lower[name][first + move[heads]] = reduced[:, k]
        self._samples, self._bounds = [], []
