"""The checks run at every sample of a sampled move, and the problems they report.

Each check reduces to a per-sample margin (≥ 0 passes) so a step's smallest margins come out of the same arrays.
Branch, singularity and joint-speed checks apply to linear/process moves only: a joint move interpolates the
joints, so it cannot change IK branch, passes through a singular configuration harmlessly, and the controller
scales its speed to the joints' limits.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import TypeAlias

import numpy as np

from ur3dq.array_types import FloatArray, IntArray
from ur3dq.errors import literal
from ur3dq.kinematics.models import JOINT_NAMES, URModel
from ur3dq.pathcheck import geometry
from ur3dq.pathcheck.cell import Cell
from ur3dq.pathcheck.geometry import BODY_NAMES
from ur3dq.pathcheck.path_plan import PathSegment
from ur3dq.units import ANGLE, ANGULAR_SPEED, LENGTH, LINEAR_SPEED, SI, Measured, Units, Wording, worded

#: Capsule/box pairs whose cheap lower-bound clearance is more than this beyond the margin are not refined (m).
EXACT_RANGE = 0.05

CHECKS = ("reach", "branch", "wrist", "elbow", "shoulder", "joint_limit", "joint_speed", "self_collision", "cell",
          "blend", "sampling")

#: StepChecker.margins_of's result: {check: (margin per sample or interval, detail arrays (indices, values))}.
SampleMargins: TypeAlias = dict[str, tuple[FloatArray | IntArray, ...]]


@dataclasses.dataclass(frozen=True)
class Margins:
    """Sampling resolutions and the margins of every check (user-settable; defaults near the controller's).

    tcp_resolution (m) and joint_resolution (rad): largest TCP chord / joint change between samples.
    max_joint_step (rad): a larger joint change between samples after refinement is a flip (branch change).
    wrist: smallest |sin θ5|; elbow: smallest |sin θ3|; shoulder (m): smallest distance of the wrist centre from the
    base axis in the arm's plane (√(x5² + y5² − d4²); 0 = shoulder singular).
    joint_limit (rad): clearance kept from every joint limit. joint_speed: largest fraction of a joint's maximum
    speed a linear/process move may need at its requested speed (sim_ursim stops at 1.05).
    self_collision (m): clearance between non-adjacent link capsules. cell (m): clearance to the cell's floor,
    keep-out boxes and keep-in box; None = the cell file's margin.
    """

    tcp_resolution: float = 0.001
    joint_resolution: float = math.radians(0.5)
    max_joint_step: float = math.radians(2.0)
    wrist: float = 0.02
    elbow: float = 0.02
    shoulder: float = 0.03
    joint_limit: float = 0.0
    joint_speed: float = 1.0
    self_collision: float = 0.0
    cell: float | None = None

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if value is None and field.name == "cell":
                continue
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"margin {field.name} must be a number ≥ 0, got {value!r}")
        if self.tcp_resolution <= 0 or self.joint_resolution <= 0 or self.joint_speed <= 0:
            raise ValueError("tcp_resolution, joint_resolution and joint_speed must be > 0")

    def cell_margin_in(self, cell: Cell | None) -> float:
        """The clearance kept to `cell`'s obstacles (m): `cell` here, else the cell file's margin, else 0."""
        return self.cell if self.cell is not None else (cell.margin if cell else 0.0)


@dataclasses.dataclass(frozen=True)
class Problem:
    """A failed check: the step (name, index), where (fraction of the move, TCP position (3,) m), what failed and
    what would fix it.

    `what` and `fix` are ``units.worded`` texts whose numbers are the `measured` values, kept in SI until a person
    reads them: ``line(units)``, ``message_in(units)`` and ``hint_in(units)`` write them in that person's units;
    ``message`` and ``hint`` read as ``ur3dq check`` prints them without --deg or --mm (positions, joint angles
    and speeds in m and rad; small values, such as clearances and angles from a singularity, in mm and °).

    >>> from ur3dq.units import LENGTH, Measured, Units
    >>> problem = Problem("a", 0, "cell", 0.5, (0.3, 0.1, 0.25), 'tool capsule {0} inside "box"', "go around",
    ...                   (Measured(0.012, LENGTH, 3, fine=True),))
    >>> print(problem.line())
    step 'a' at 50% of the move (TCP 0.3000, 0.1000, 0.2500 m): tool capsule 12 mm inside "box"; go around
    >>> print(problem.line(Units(length="mm")))
    step 'a' at 50% of the move (TCP 300.0, 100.0, 250.0 mm): tool capsule 12 mm inside "box"; go around
    """

    step: str
    step_index: int
    check: str
    fraction: float
    tcp: tuple[float, ...]
    what: str
    fix: str
    measured: tuple[Measured, ...] = ()

    @property
    def message(self) -> str:
        """What failed, in the default units."""
        return self.message_in()

    @property
    def hint(self) -> str:
        """What would fix it, in the default units."""
        return self.hint_in()

    def message_in(self, units: Units = SI) -> str:
        """What failed, its numbers in `units`."""
        return worded(self.what, self.measured, units)

    def hint_in(self, units: Units = SI) -> str:
        """What would fix it, its numbers in `units`."""
        return worded(self.fix, self.measured, units)

    def line(self, units: Units = SI) -> str:
        """One line naming the step, where along it, what failed and what would fix it, its numbers in `units`."""
        return worded(*self.wording(), units)

    def wording(self) -> Wording:
        """(line's ``units.worded`` text, its values): to carry the line into an error's message."""
        first = len(self.measured)
        where = ", ".join(f"{{{first + i}}}" for i in range(len(self.tcp)))
        # units.position_text's precision (0.1 mm), as the screen writes the same position
        tcp = tuple(Measured(v, LENGTH, 4, unit=i == len(self.tcp) - 1) for i, v in enumerate(self.tcp))
        return (f"step {literal(repr(self.step))} at {self.fraction:.0%} of the move (TCP {where}): {self.what}; "
                f"{self.fix}"), self.measured + tcp

    def to_dict(self) -> dict[str, object]:
        """The problem as JSON-ready values (SI; the message and hint as `message` and `hint` read)."""
        return {"step": self.step, "step_index": self.step_index, "check": self.check,
                "fraction": self.fraction, "tcp": list(self.tcp), "message": self.message, "hint": self.hint}


class StepChecker:
    """Runs every check on the samples of one move; holds the model's capsules and the cell (built once)."""

    def __init__(self, model: URModel, cell: Cell | None, margins: Margins) -> None:
        self.model = model
        self.cell = cell
        self.margins = margins
        self.cell_margin = margins.cell_margin_in(cell)
        self.capsules = geometry.link_capsules(model, cell.tool if cell else None)
        bodies = self.capsules.body
        pairs = [(i, j) for a, b in geometry.SELF_PAIRS for i in np.flatnonzero(bodies == a)
                 for j in np.flatnonzero(bodies == b)]
        self.pair_a = np.array([p[0] for p in pairs], dtype=int)
        self.pair_b = np.array([p[1] for p in pairs], dtype=int)
        self.cell_capsules = np.flatnonzero(bodies != 0)   # the base stands in the cell by design
        self.obstacles = self._obstacles()

    def _obstacles(self) -> list[str]:
        if self.cell is None:
            return []
        names = [f'keep-out box "{box.name}"' for box in self.cell.boxes]
        if self.cell.floor_z is not None:
            names.append("the floor")
        if self.cell.keep_in is not None:
            names.append("the keep-in box")
        return names

    # ------------------------------------------------------------------------------------------- per sample
    def margins_of(self, segment: PathSegment, joints: FloatArray, fraction: FloatArray, tcp: FloatArray,
                   extra: FloatArray, path_scale: float) -> SampleMargins:
        """{check: (margin (n,) or (n-1,) per sample/interval, detail arrays)} for one move's samples.

        Samples: joints (n, 6) rad at path fractions (n,), TCP positions (n, 3) m. `extra` (n,) m is added to the
        clearance margins (blend zones); `path_scale` = the controller's path 'distance' of a Cartesian move (m or
        rad, for the joint speeds)."""
        m = self.margins
        out: SampleMargins = {}
        steps = np.abs(np.diff(joints, axis=0))
        if len(steps) and segment.cartesian:   # a joint move interpolates the joints: it cannot change branch
            out["branch"] = (m.max_joint_step - steps.max(axis=1), np.argmax(steps, axis=1), steps.max(axis=1))
        out["joint_limit"] = (*self.limit_room(joints), joints)
        frames = geometry.dh_frames(self.model, joints)
        if segment.cartesian:
            sin5, sin3 = np.abs(np.sin(joints[:, 4])), np.abs(np.sin(joints[:, 2]))
            wrist_centre = frames[:, 5, :2, 3]
            d4 = geometry.body_model(self.model).dh.d[3]
            radial = np.einsum("ni,ni->n", wrist_centre, wrist_centre) - d4 ** 2
            shoulder = np.sqrt(np.maximum(radial, 0.0))
            out["wrist"] = (sin5 - m.wrist, sin5)
            out["elbow"] = (sin3 - m.elbow, sin3)
            out["shoulder"] = (shoulder - m.shoulder, shoulder)
            if len(steps) and path_scale > 0:
                rate = steps / np.maximum(np.diff(fraction), 1e-300)[:, None] * (segment.speed / path_scale)
                ratio = rate / self.model.max_joint_speed
                out["joint_speed"] = (m.joint_speed - ratio.max(axis=1), np.argmax(ratio, axis=1),
                                      ratio.max(axis=1), rate)
        gap, flat = self._clearances(frames, float(extra.max(initial=0.0)))
        if gap is not None:
            worst = np.argmin(gap, axis=1)
            clearance = gap[np.arange(len(gap)), worst]
            out["self_collision"] = (clearance - m.self_collision - extra, worst, clearance)
        if flat is not None:
            worst = np.argmin(flat, axis=1)
            value = flat[np.arange(len(flat)), worst]
            out["cell"] = (value - self.cell_margin - extra, worst, value)
        return out

    def limit_room(self, joints: FloatArray) -> tuple[FloatArray, IntArray]:
        """(smallest room (n,) rad of joints (n, 6) from their limits less the joint_limit margin, which joint)."""
        lower = self.model.joint_lower + self.margins.joint_limit
        upper = self.model.joint_upper - self.margins.joint_limit
        with np.errstate(invalid="ignore"):   # ±inf limits (UR3 wrist 3)
            room = np.minimum(joints - lower, upper - joints)
        return room.min(axis=1), np.argmin(room, axis=1)

    def _clearances(self, frames: FloatArray, extra_max: float, pairs: slice | IntArray = slice(None),
                    cell: bool = True) -> tuple[FloatArray | None, FloatArray | None]:
        """(self gaps (n, p) m of the capsule pairs `pairs` (indices or a slice of pair_a/pair_b) or None, cell
        clearances (n, cell capsules × obstacles) m or None when the cell is absent or `cell` is False) at DH
        frames (n, 7, 4, 4); `extra_max`: the largest blend allowance (which pairs need exact distances)."""
        a, b = geometry.capsule_points(frames, self.capsules)
        radius = self.capsules.radius
        gap = flat = None
        first, second = self.pair_a[pairs], self.pair_b[pairs]
        if len(first):
            gap = geometry.segment_segment_distance(a[:, first], b[:, first], a[:, second], b[:, second]) \
                - radius[first] - radius[second]
        if self.obstacles and cell:
            clearance = self._cell_clearance(a[:, self.cell_capsules], b[:, self.cell_capsules],
                                             radius[self.cell_capsules], extra_max)
            flat = clearance.reshape(len(clearance), -1)
        return gap, flat

    def clearance_margins(self, joints: FloatArray, pairs: slice | IntArray = slice(None),
                          cell: bool = True) -> tuple[FloatArray, FloatArray]:
        """Self-collision and cell clearance margins at joint vectors.

        (self-collision margins (n, p), cell margins (n, cell capsules × obstacles)) m at joints (n, 6): each
        capsule pair's (of `pairs`, indices or a slice of pair_a/pair_b) and, if `cell`, each capsule/obstacle
        column's clearance minus its margin (≥ 0 passes); an absent check gives (n, 0). A cell column may be a
        lower bound of its clearance (EXACT_RANGE)."""
        gap, flat = self._clearances(geometry.dh_frames(self.model, joints), 0.0, pairs, cell)
        empty = np.zeros((len(joints), 0))
        return (empty if gap is None else gap - self.margins.self_collision,
                empty if flat is None else flat - self.cell_margin)

    def _cell_clearance(self, a: FloatArray, b: FloatArray, radius: FloatArray, extra_max: float) -> FloatArray:
        """(n, C, obstacles) clearances m of capsules a→b (n, C, 3) with radii (C,) to the cell's obstacles."""
        assert self.cell is not None   # only called when the cell has obstacles
        columns = []
        if self.cell.boxes:
            lo = np.array([box.lo for box in self.cell.boxes])
            hi = np.array([box.hi for box in self.cell.boxes])
            a_, b_ = a[:, :, None], b[:, :, None]
            distance = geometry.segment_box_bound(a_, b_, lo, hi)
            # Only capsule/box pairs whose cheap lower bound comes within EXACT_RANGE of the margin need the exact
            # distance; the others keep the bound (their reported clearance is then a lower bound, > the range).
            near = distance - radius[None, :, None] < self.cell_margin + extra_max + EXACT_RANGE
            if near.any():
                index = np.nonzero(near)
                distance[index] = geometry.segment_box_distance(a[index[0], index[1]], b[index[0], index[1]],
                                                                lo[index[2]], hi[index[2]])
            columns.append(distance - radius[None, :, None])
        if self.cell.floor_z is not None:
            columns.append((np.minimum(a[..., 2], b[..., 2]) - radius - self.cell.floor_z)[..., None])
        if self.cell.keep_in is not None:
            box = self.cell.keep_in
            room = np.minimum(np.minimum(a, b) - box.lo, box.hi - np.maximum(a, b)).min(axis=-1)
            columns.append((room - radius)[..., None])
        return np.concatenate(columns, axis=-1)

    # ------------------------------------------------------------------------------------------- problems
    def problems(self, index: int, segment: PathSegment, results: SampleMargins, fraction: FloatArray,
                 tcp: FloatArray, extra: FloatArray) -> list[Problem]:
        """The failed checks of move `index` (each at its worst sample) as Problems: `results` from margins_of on
        its samples at path fractions (n,), TCP positions (n, 3) m, blend allowances `extra` (n,) m."""
        found = []
        for check, (margin, *detail) in results.items():
            if not len(margin) or float(np.min(margin)) >= 0:
                continue
            k = int(np.argmin(margin))
            sample = min(k + 1, len(fraction) - 1) if check in ("branch", "joint_speed") else k
            what, fix, measured = self._describe(check, segment, k, detail, extra[sample])
            found.append(Problem(segment.name, index, check, float(fraction[sample]),
                                 tuple(float(v) for v in tcp[sample]), what, fix, measured))
        return found

    def _describe(self, check: str, segment: PathSegment, k: int, detail: Sequence[FloatArray | IntArray],
                  extra: float) -> tuple[str, str, tuple[Measured, ...]]:
        """(what, fix, their measured values) of a failed `check` at its worst sample or interval k, from
        margins_of's `detail` (Problem's texts and values)."""
        m = self.margins
        if check == "branch":
            joint, step = int(detail[0][k]), float(detail[1][k])
            return (f"IK branch change: joint {joint + 1} ({JOINT_NAMES[joint]}) jumps {{0}} between samples "
                    "(> {1})", "the arm would flip: split the move with a waypoint on one branch, or use a joint move",
                    (_fine_angle(step), _fine_angle(m.max_joint_step)))
        if check == "joint_limit":
            joint = int(detail[0][k])
            return (f"joint {joint + 1} ({JOINT_NAMES[joint]}) at {{0}} passes its limit [{{1}}, {{2}}] "
                    "(margin {3})", "use targets whose joints stay nearer the middle of the range (another ±2π turn)",
                    (Measured(float(detail[1][k, joint]), ANGLE), *joint_limits(self.model, joint),
                     Measured(m.joint_limit, ANGLE, 3)))
        if check in ("wrist", "elbow"):
            return self._singular(check, float(detail[0][k]))
        if check == "shoulder":
            return ("shoulder singular: wrist centre {0} from the base axis < {1}",
                    "route the line away from above/below the base, or make it a joint move",
                    (_fine_length(float(detail[0][k])), _fine_length(m.shoulder)))
        if check == "joint_speed":
            return self._too_fast(segment, int(detail[0][k]), float(detail[1][k]), float(detail[2][k, detail[0][k]]))
        if check == "self_collision":
            pair, clearance = int(detail[0][k]), float(detail[1][k])
            first = BODY_NAMES[self.capsules.body[self.pair_a[pair]]]
            second = BODY_NAMES[self.capsules.body[self.pair_b[pair]]]
            return (f"self-collision: {first} capsule {_clearance_text(clearance, 'the ' + second + ' capsule')}"
                    f"{_margin_text(extra)}",
                    "change the wrist orientation or the elbow configuration of the target, or add a waypoint",
                    _clearance_values(clearance, m.self_collision, extra))
        if check == "cell":
            flat, clearance = int(detail[0][k]), float(detail[1][k])
            capsule, obstacle = divmod(flat, len(self.obstacles))
            body = BODY_NAMES[self.capsules.body[self.cell_capsules[capsule]]]
            name = self.obstacles[obstacle]
            other_move = "make it a joint move" if segment.cartesian else "use a linear move there"
            hint = {"the floor": "raise the targets, or add a waypoint that keeps the arm higher",
                    "the keep-in box": "move the targets inward, or add a waypoint that stays inside"}.get(
                name, f"add a waypoint that goes around it, move the targets, or {other_move}")
            return (f"{body} capsule {_clearance_text(clearance, literal(name))}{_margin_text(extra)}",
                    literal(hint), _clearance_values(clearance, self.cell_margin, extra))
        raise AssertionError(check)

    def _singular(self, check: str, sine: float) -> tuple[str, str, tuple[Measured, ...]]:
        """(what, fix, values) of a wrist or elbow singularity passed at |sin θ| = `sine`."""
        keep = getattr(self.margins, check)
        values = (_fine_angle(_from_singular(sine)), _fine_angle(_from_singular(keep)))
        if check == "wrist":
            return (f"wrist singular: wrist 2 passes {{0}} from 0°/180° (keep ≥ {{1}}, |sin θ5| ≥ {keep:g})",
                    "tilt the tool so wrist 2 stays away from 0°/180° along the line, or make it a joint move", values)
        return (f"elbow singular (arm stretched or folded): the elbow passes {{0}} from straight (keep ≥ {{1}}, "
                f"|sin θ3| ≥ {keep:g})", "keep the line further inside the reach, or make it a joint move", values)

    def _too_fast(self, segment: PathSegment, joint: int, ratio: float,
                  needed: float) -> tuple[str, str, tuple[Measured, ...]]:
        """(what, fix, values) of joint `joint` needing `needed` rad/s, `ratio` × its top speed, on `segment`."""
        share = self.margins.joint_speed
        return (f"joint {joint + 1} ({JOINT_NAMES[joint]}) would need {{0}} at {{1}}, over {share:g} × its {{2}}",
                "lower the step's speed to ≤ {3} or keep away from the singularity",
                (Measured(needed, ANGULAR_SPEED, 2), Measured(segment.speed, LINEAR_SPEED, None),
                 Measured(float(self.model.max_joint_speed[joint]), ANGULAR_SPEED, 2),
                 Measured(segment.speed * share / ratio, LINEAR_SPEED)))


def joint_limits(model: URModel, joint: int) -> tuple[Measured, Measured]:
    """`model`'s lower and upper limit of joint `joint` as numbers alone (written [lower, upper] after the joint's
    angle, which carries the unit)."""
    return (Measured(float(model.joint_lower[joint]), ANGLE, unit=False),
            Measured(float(model.joint_upper[joint]), ANGLE, unit=False))


def _from_singular(sine: float) -> float:
    """How far (rad) a joint whose |sin| is `sine` is from its singular angles (0 or π)."""
    return math.asin(min(1.0, max(0.0, float(sine))))


def _fine_angle(radians: float) -> Measured:
    """A small angle (a joint step, an angle from a singularity) to 0.1°."""
    return Measured(radians, ANGLE, 3, fine=True)


def _fine_length(metres: float, si_digits: int = 3) -> Measured:
    """A small length (a clearance, a margin, a blend radius) to 1 mm, or 0.1 mm with `si_digits` 4."""
    return Measured(metres, LENGTH, si_digits, fine=True)


def _clearance_text(clearance: float, what: str) -> str:
    """How far a capsule is from `what` (a worded name) by a clearance {0} (negative: {0} is the depth inside)."""
    if what == "the keep-in box":
        return "{0} outside the keep-in box" if clearance < 0 else "{0} inside the keep-in box's walls"
    return f"{{0}} inside {what}" if clearance < 0 else f"{{0}} from {what}"


def _clearance_values(clearance: float, margin: float, extra: float) -> tuple[Measured, ...]:
    """The values of _clearance_text and _margin_text: the clearance (a depth when < 0), the margin, the blend."""
    shown = _fine_length(-clearance) if clearance < 0 else _fine_length(clearance, 4)
    return shown, _fine_length(margin), _fine_length(extra)


def _margin_text(extra: float) -> str:
    """The margin {1} kept, and the blend allowance {2} when there is one."""
    return " (margin {1} + blend {2})" if extra > 0 else " (margin {1})"
