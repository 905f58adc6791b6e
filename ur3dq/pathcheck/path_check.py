"""check_path: sample every move of a plan as the controller would run it and check each sample.

Blend zones are approximated conservatively: the unblended corner path (both moves in full, through the waypoint)
is checked, and inside the blend zone — the samples whose TCP is within the blend radius r of the waypoint, on the
incoming and the outgoing move — every clearance margin (self-collision, cell) is raised by r. The controller's
blended TCP path stays inside the sphere of radius r around the waypoint, between the two moves; the links are
assumed to deviate from the corner path by no more than r too (an approximation: near the base a link moves less
than the TCP, so this holds for the usual arm poses). A blend radius larger than half of either move is reported.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TypeAlias

import numpy as np

from ur3dq import dqarray
from ur3dq.array_types import FloatArray
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics import ur_ik
from ur3dq.kinematics.models import JOINT_NAMES, URModel
from ur3dq.pathcheck import bounds, sampling
from ur3dq.pathcheck.cell import Cell
from ur3dq.pathcheck.checks import Margins, Problem, StepChecker, joint_limits
from ur3dq.pathcheck.path_plan import PathPlan, PathSegment
from ur3dq.pathcheck.reports import CertifiedMoves, PathCheckResult, StepReport, StepReports, figures
from ur3dq.units import ANGLE, LENGTH, Measured

BRANCH_TOLERANCE = 1e-3   # rad: a linear move ending further than this from its planned joints ended elsewhere

#: The arm (with the segment's TCP) and its StepChecker for a segment.
ArmFor: TypeAlias = Callable[[PathSegment], tuple[URModel, StepChecker]]
#: A move in check_path's window: (segment, its samples, TCP positions (n, 3) m), its row among the certified
#: moves, or None (not sampled).
WindowEntry: TypeAlias = tuple[PathSegment, sampling.SampledMove, FloatArray] | int | None


def check_path(model: URModel, plan: PathPlan, cell: Cell | None = None, margins: Margins | None = None,
               keep_samples: bool = True) -> PathCheckResult:
    """Check a whole path before the arm moves.

    Parameters
    ----------
    model : URModel
        The arm with its TCP (a segment with its own `tcp_offset` runs with that one instead).
    plan : PathPlan
        The start joints and the moves, in execution order.
    cell : Cell, optional
        Floor, keep-out and keep-in boxes, tool (``load_cell``); None: no obstacles, no tool.
    margins : Margins, optional
        The checks' limits and resolutions (default ``Margins()``).
    keep_samples : bool
        False leaves each StepReport's samples out (fraction, joints, tcp are None; the problems are the same):
        a big plan's samples take gigabytes, and only a drawing of the path needs them. Joint moves between
        known joints are then first checked by clearance bounds, all at once (pathcheck.bounds): a move whose
        every point provably keeps its margins is not sampled densely, and no point of it is more than
        margins.tcp_resolution below a check's smallest margin over the plan.

    Returns
    -------
    PathCheckResult
        Never raises for a failed check: read ``.ok`` and ``.problems``.

    Examples
    --------
    >>> from ur3dq.kinematics import robot_model
    >>> from ur3dq.pathcheck import PathPlan, PathSegment
    >>> q0 = [0.0, -1.2, 1.0, -1.4, -1.57, 0.0]
    >>> plan = PathPlan(q0, [PathSegment("turn", target_joints=[0.5, -1.2, 1.0, -1.4, -1.57, 0.0])])
    >>> result = check_path(robot_model("ur3"), plan)
    >>> result.ok, result.steps[0].name
    (True, 'turn')
    """
    margins = margins or Margins()
    arm_for = _ArmsByTcp(model, cell, margins)
    q: np.ndarray | None = np.array(plan.start_joints)
    problems: list[Problem] = []
    unchecked: list[str] = []
    steps: list[StepReport | int] = []   # StepReports' entries
    certified = None if keep_samples else _certified_moves(plan, arm_for)
    certified_row: dict[int, int] = {} if certified is None else certified.row_of
    # Moves are checked one behind the sampling: a move's blend zones need its neighbours' samples, and no
    # other move's (the window holds at most three, so memory does not grow with the plan).
    window: dict[int, WindowEntry] = {}
    for index, segment in enumerate(plan.segments):
        if index in certified_row:
            window[index] = certified_row[index]   # an int: the row of its report in `certified`
            q = segment.target_joints
        elif q is None:
            unchecked.append(segment.name)
            window[index] = None
        else:
            window[index], q = _sampled_entry(arm_for(segment)[0], segment, index, q, margins, problems)
        if index >= 1:
            _check_move(plan, window, index - 1, arm_for, problems, steps, certified)
            window.pop(index - 2, None)
    if plan.segments:
        _check_move(plan, window, len(plan.segments) - 1, arm_for, problems, steps, certified)
    problems.sort(key=lambda p: (p.step_index, p.fraction))
    return PathCheckResult(tuple(problems), StepReports(steps, certified), tuple(unchecked),
                           _limits(margins, cell))


class _ArmsByTcp:
    """The arm with a segment's TCP and its StepChecker, built once per TCP the plan uses."""

    def __init__(self, model: URModel, cell: Cell | None, margins: Margins) -> None:
        self.model, self.cell, self.margins = model, cell, margins
        self.by_tcp: dict[tuple[float, ...] | None, tuple[URModel, StepChecker]] = {}

    def __call__(self, segment: PathSegment) -> tuple[URModel, StepChecker]:
        if segment.tcp_offset not in self.by_tcp:
            arm = self.model if segment.tcp_offset is None else self.model.with_tcp(segment.tcp_offset)
            self.by_tcp[segment.tcp_offset] = arm, StepChecker(arm, self.cell, self.margins)
        return self.by_tcp[segment.tcp_offset]


def _sampled_entry(arm: URModel, segment: PathSegment, index: int, q: np.ndarray, margins: Margins,
             problems: list[Problem]) -> tuple[WindowEntry, np.ndarray | None]:
    """The window entry of a move from `q` sampled densely, and the joints it ends at; its problems are added."""
    move = _sample(arm, segment, index, q, margins)
    if isinstance(move, Problem):   # the target itself cannot be solved, or the move is too long
        problems.append(move)
        return None, segment.target_joints
    end, end_problem = _end_joints(segment, index, move)
    if end_problem is not None:
        problems.append(end_problem)
    return (segment, move, dqarray.translation_unchecked(move.poses)), end


def _limits(margins: Margins, cell: Cell | None) -> dict[str, float]:
    """{check: the limit its margins are measured from}."""
    return {"wrist": margins.wrist, "elbow": margins.elbow, "shoulder": margins.shoulder,
            "joint_limit": margins.joint_limit, "joint_speed": margins.joint_speed,
            "self_collision": margins.self_collision, "cell": margins.cell_margin_in(cell)}


def _check_move(plan: PathPlan, window: dict[int, WindowEntry], index: int, arm_for: ArmFor,
                problems: list[Problem], steps: list[StepReport | int], certified: CertifiedMoves | None) -> None:
    """Run every check on the samples of move `index` (window[index]); add its problems and its StepReport to
    `steps` (a move the bounds certified: its row in `certified`, a CertifiedMoves, or None when samples are
    kept)."""
    entry = window[index]
    if entry is None:
        return
    if isinstance(entry, int):
        assert certified is not None   # only certified moves are kept as rows
        certified.position[entry] = len(steps)
        steps.append(entry)
        return
    segment, move, tcp = entry
    extra, blend_problem = _blend_allowance(plan, window, index, tcp)
    if blend_problem is not None:
        problems.append(blend_problem)
    scale = _path_scale(move) if segment.cartesian else 0.0
    checker = arm_for(segment)[1]
    results = checker.margins_of(segment, move.joints, move.fraction, tcp, extra, scale) if len(tcp) else {}
    problems.extend(checker.problems(index, segment, results, move.fraction, tcp, extra))
    margins_seen = {check: float(np.min(values[0])) for check, values in results.items() if len(values[0])}
    # Interval checks (joint steps, speeds) name the sample that ends their worst interval.
    worst = {check: int(np.argmin(values[0])) + (len(values[0]) < len(tcp))
             for check, values in results.items() if len(values[0])}
    end = move.joints[-1] if move.unreachable_at is None and len(move.joints) else None
    kept = (move.fraction, move.joints, tcp) if certified is None else (None, None, None)
    fraction, joints, kept_tcp = kept
    steps.append(StepReport(segment.name, segment.move, fraction, joints, kept_tcp, figures(margins_seen),
                            figures(worst), end, len(tcp)))


def _sample(model: URModel, segment: PathSegment, index: int, q: FloatArray,
            margins: Margins) -> sampling.SampledMove | Problem:
    """The SampledMove of move `index` from joints q (6,), or the Problem when the target itself cannot be solved
    or the move is too long to sample (then it is not sampled)."""
    try:
        return _sampled(model, segment, index, q, margins)
    except sampling.TooManySamples as error:
        return _unsampled(model, segment, index, error)


def _unsampled(model: URModel, segment: PathSegment, index: int, error: sampling.TooManySamples) -> Problem:
    """The Problem of a move not sampled: a joint target outside the joint limits if that is why, else its length."""
    target = segment.target_joints
    pose = model.fk(target).to_array() if target is not None else segment.target_pose
    assert pose is not None   # a segment has target_joints or target_pose
    where = tuple(float(v) for v in dqarray.translation_unchecked(pose))
    if target is not None:
        outside = (target < model.joint_lower) | (target > model.joint_upper)
        if outside.any():
            joint = int(np.argmax(outside))
            return Problem(segment.name, index, "joint_limit", 1.0, where,
                           f"target joint {joint + 1} ({JOINT_NAMES[joint]}) at {{0}} lies outside its limits [{{1}}, "
                           "{2}] (move not sampled)", "use a target within the joint limits",
                           (Measured(float(target[joint]), ANGLE, None), *joint_limits(model, joint)))
    return Problem(segment.name, index, "sampling", 1.0, where,
                   f"the move needs {error.needed:.3g} samples at the check's resolutions, more than "
                   f"{sampling.MAX_SAMPLES_PER_MOVE} (not checked)", "split it into shorter moves, or check it at "
                   "coarser resolutions")


def _sampled(model: URModel, segment: PathSegment, index: int, q: FloatArray,
             margins: Margins) -> sampling.SampledMove | Problem:
    """The SampledMove of move `index` from joints q (6,), or the Problem when the target itself cannot be
    solved."""
    if segment.move == "joint":
        target = segment.target_joints
        if target is None:
            pose = segment.target_pose
            assert pose is not None   # a segment has target_joints or target_pose
            try:
                target = model.ik(pose, q)
            except UnreachablePoseError as error:
                where = dqarray.translation_unchecked(pose)
                reason, measured = error.wording()
                return Problem(segment.name, index, "reach", 1.0, tuple(map(float, where)),
                               f"target unreachable: {reason}", "move the target inside the arm's reach", measured)
        return sampling.sample_joint_move(model, q, target, margins.tcp_resolution, margins.joint_resolution)
    pose = segment.target_pose if segment.target_pose is not None else model.fk(segment.target_joints).to_array()
    return sampling.sample_linear_move(model, q, pose, margins.tcp_resolution, margins.joint_resolution)


def _end_joints(segment: PathSegment, index: int,
                move: sampling.SampledMove) -> tuple[FloatArray | None, Problem | None]:
    """(joints (6,) where the next move starts or None, Problem or None) after a sampled move."""
    if move.unreachable_at is not None:
        assert move.unreachable_pose is not None   # set with unreachable_at
        where = tuple(float(v) for v in dqarray.translation_unchecked(move.unreachable_pose))
        problem = Problem(segment.name, index, "reach", move.unreachable_at, where,
                          "the straight line leaves the arm's reach here (no IK solution)",
                          "keep the line inside the reach (shorter, or via a waypoint), or make it a joint move")
        return segment.target_joints, problem
    end = move.joints[-1]
    planned = segment.target_joints
    if segment.cartesian and planned is not None:
        apart = np.abs(ur_ik.wrap_angle(end - planned))
        if float(apart.max()) > BRANCH_TOLERANCE:
            tcp = tuple(float(v) for v in dqarray.translation_unchecked(move.poses[-1]))
            joint = int(np.argmax(apart))
            return end, Problem(segment.name, index, "branch", 1.0, tcp,
                                f"the line ends on another IK branch than the planned joints (joint {joint + 1} "
                                "differs by {0})", "plan the target on the start's branch, or reach it with a joint "
                                "move", (Measured(float(apart[joint]), ANGLE, 3, fine=True),))
    return end, None


def _path_scale(move: sampling.SampledMove) -> float:
    """The controller's path 'distance' of a Cartesian move: max(length m, turn rad) (sim_ursim.trajectories)."""
    if len(move.poses) < 2 or move.unreachable_at is not None:
        return 0.0
    metres, radians = sampling.line_length(move.poses[0], move.poses[-1])
    return float(max(metres, radians))


def _blend_allowance(plan: PathPlan, window: dict[int, WindowEntry], index: int,
                     tcp: FloatArray) -> tuple[FloatArray, Problem | None]:
    """(extra margin (n,) m inside the blend zones of move `index` with TCP positions `tcp` (n, 3) m, Problem if a
    blend radius is too large); `window` holds the moves index − 1 .. index + 1 (None where not sampled)."""
    extra = np.zeros(len(tcp))
    problem = None
    segment = plan.segments[index]

    def length(i: int) -> float:   # TCP travel of move i (m); ∞ for a move not sampled, or the first move from an
        entry = window.get(i)      # unknown start (a stand-in of length 0): neither bounds the blend
        if i == 0 and not plan.start_known:
            return np.inf
        return float(np.sum(np.linalg.norm(np.diff(entry[2], axis=0), axis=1))) if isinstance(entry, tuple) else np.inf

    if segment.blend > 0 and len(tcp) and index + 1 < len(plan.segments):
        extra = np.maximum(extra, np.where(np.linalg.norm(tcp - tcp[-1], axis=1) < segment.blend, segment.blend, 0))
        shortest = min(length(index), length(index + 1))
        if segment.blend > 0.5 * shortest:
            problem = Problem(segment.name, index, "blend", 1.0, tuple(map(float, tcp[-1])),
                              "blend radius {0} is more than half of a neighbouring move ({1} of TCP travel)",
                              "lower the blend radius to at most half of the shorter move",
                              (Measured(segment.blend, LENGTH, 3, fine=True), Measured(shortest, LENGTH, 3, fine=True)))
    previous = plan.segments[index - 1] if index > 0 else None
    if previous is not None and previous.blend > 0 and len(tcp) and window.get(index - 1) is not None:
        extra = np.maximum(extra, np.where(np.linalg.norm(tcp - tcp[0], axis=1) < previous.blend, previous.blend, 0))
    return extra, problem


def _certified_moves(plan: PathPlan, arm_for: ArmFor) -> CertifiedMoves:
    """The joint moves the bounds certify (pathcheck.bounds), per TCP, as CertifiedMoves. Candidates: joint moves
    to known joints from known joints (the start, or a joint move's target before them), outside blend zones (whose
    allowance needs the neighbours' samples)."""
    candidates: dict[tuple[float, ...] | None, list[tuple[int, np.ndarray]]] = {}   # tcp_offset -> [(index, start)]
    start: FloatArray | None = plan.start_joints   # where a candidate after this segment starts; None: no candidate
    for index, segment in enumerate(plan.segments):
        joint_move = segment.move == "joint" and segment.target_joints is not None and segment.blend == 0
        if joint_move and start is not None:
            candidates.setdefault(segment.tcp_offset, []).append((index, start))
        start = segment.target_joints if joint_move else None
    certified = CertifiedMoves()
    for moves in candidates.values():
        segments = [plan.segments[index] for index, _ in moves]
        checker = arm_for(segments[0])[1]
        result = bounds.certify_joint_moves(checker, np.array([start for _, start in moves]),
                                            np.array([segment.target_joints for segment in segments]))
        kept = np.flatnonzero(result.certified)
        certified.add([moves[k][0] for k in kept.tolist()], [segments[k] for k in kept.tolist()],
                      {check: values[kept] for check, values in result.margins.items()},
                      {check: values[kept] for check, values in result.worst.items()}, result.samples[kept])
    return certified
