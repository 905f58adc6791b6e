"""Record and replay as a library: the joint target for each recorded pose (planned before the arm moves), the
replay itself on a connected Robot with progress through a callback, and reading the arm's pose as a Pose.

No click or rich here: the CLI (ur3dq/cli) and any script share these functions.

Planning is pure. Each pose is solved with its own recorded TCP offset, so the flange goes where it was when the
pose was recorded. IK runs once per pose (`ik_all`, every FK-verified solution); among those solutions and their
±2π variants inside the limits the planner takes the one closest to the pose's recorded joints when it has them,
else to the previous target (the arm's joints for the first pose) — the same choice as `model.ik`.

Replay (`execute_plan`) moves through the plan with `Robot.movej` (or one blended `movej_path`); every move is
checked and watched to its end by the driver; Ctrl-C between moves sends stopj too. `replay_script` writes the
same replay as one URScript program (a `.script` file for the pendant or the controller's port 30002).
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from ur3dq import urscript
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import ConnectionLostError, JointLimitError, SafetyCheckError, UnreachablePoseError
from ur3dq.kinematics import ur_ik
from ur3dq.pose import Pose
from ur3dq.robot import motion

SOURCE_RECORDED = "recorded joints"
SOURCE_IK_RECORDED = "IK nearest recorded"
SOURCE_IK_PREVIOUS = "IK nearest previous"
SOURCE_IK_ZERO = "IK nearest zero"  # no robot joints known (dry run without a robot)
#: rad: a pose's recorded joints this close to its batch IK answer are that answer (the FK filter's scale, 1e-9)
RECORDED_SOLUTION = 1e-9

MAX_STATUS_AGE_S = 1.0  # a reading older than this is a frozen stream, not the arm's pose

TCP_RECORDED = "recorded"  # replay puts the flange where it was when recorded (the recorded TCP's pose)
TCP_CURRENT = "current"    # replay puts the controller's current TCP on the recorded TCP pose

# progress(description, moves done, moves in all): called before each move and once at the end
ProgressCallback = Callable[[str, int, int], None]


@dataclasses.dataclass(frozen=True, slots=True)  # slots: one per pose, 10⁵ in a big store
class PlanStep:
    """One move of a replay: the pose, its joint target (rad, shape (6,)), how it was chosen, the move's figures."""

    pose: Pose
    joints: np.ndarray
    source: str
    solutions: int           # FK-verified IK solutions of the pose (0 when replaying recorded joints)
    travel: float | None     # largest joint travel from the previous target (rad); None when the start is unknown
    duration: float | None   # movej seconds at 100 % speed; None when the start is unknown
    fk_error_m: float        # model FK of the target vs the recorded pose
    fk_error_rad: float


@dataclasses.dataclass(frozen=True)
class Reached:
    """Where one replayed move ended: the TCP the controller reports vs the pose the replay aimed that TCP at."""

    step: PlanStep
    error_m: float
    error_rad: float
    seconds: float
    target: DualQuaternion  # where the replay aimed the controller's current TCP
    target_off_m: float     # how far that target is from the recorded TCP pose (0 unless the TCP changed)


def tcp_pose_for(pose: Pose, tcp_now: DualQuaternion) -> DualQuaternion:
    """Where the TCP `tcp_now` (flange frame) is when the flange sits where `pose` put it: σ·tcp_rec⁻¹·tcp_now."""
    return pose.dq * DualQuaternion.from_ur_pose(pose.tcp_offset).inverse() * tcp_now


class TaughtWithTcp(Protocol):
    """Anything taught with a TCP offset (flange frame, UR pose vector): a Pose, a program's resolved Target."""

    @property
    def tcp_offset(self) -> Sequence[float]: ...


def tcp_changed(pose: TaughtWithTcp, tcp_now: DualQuaternion, tol_m: float = 1e-4, tol_rad: float = 1e-3) -> bool:
    """True if `pose` was recorded with a TCP offset other than `tcp_now` (beyond 0.1 mm / 1 mrad)."""
    metres, radians = DualQuaternion.from_ur_pose(pose.tcp_offset).distance(tcp_now)
    return metres > tol_m or radians > tol_rad


def retarget_to_tcp(pose: Pose, tcp_now: DualQuaternion) -> Pose:
    """The pose with another TCP offset, the TCP pose kept.

    `pose` with the TCP offset `tcp_now`, same TCP pose: replaying it puts the current TCP where the recorded
    TCP was (the flange ends elsewhere than when recorded). Recorded joints are dropped: they belong to the old TCP."""
    return dataclasses.replace(pose, tcp_offset=tuple(float(v) for v in tcp_now.to_ur_pose()), joints=None) \
        if tcp_changed(pose, tcp_now) else pose


def nearest_variant(model, solutions, reference: np.ndarray) -> np.ndarray:
    """The solution variant nearest a reference within the limits.

    Among `solutions` (FK-verified, canonical) and their ±2π variants inside the limits, the one nearest
    `reference` (Σ Δq², per joint since the cost and the limits are per joint: ur_ik.nearest_variant, the rule `ik`
    applies); UnreachablePoseError if none fits."""
    best, best_cost = None, math.inf
    for solution in solutions:
        q = ur_ik.nearest_variant(model, solution, reference)
        if not np.all(np.isfinite(q)):
            continue
        cost = float(np.sum((q - reference) ** 2))
        if cost < best_cost:
            best, best_cost = q, cost
    if best is None:
        raise UnreachablePoseError("outside limits — every solution has a joint outside the joint limits")
    return best


def choose_joints(model, pose: Pose, previous, replay_recorded_joints: bool,
                  solvers: dict | None = None) -> tuple[np.ndarray, str, int]:
    """The joint target of one pose, how it was chosen, and its IK solution count.

    (joint target (6,), source, number of IK solutions) for `pose` on `model` (a robot_model; its TCP is
    ignored: the pose's recorded TCP offset is used). `solvers` caches `model.with_tcp(offset)` per offset across
    calls (building a model is costly; a store's poses usually share one TCP)."""
    solver = _solver(model, pose.tcp_offset, {} if solvers is None else solvers)
    if replay_recorded_joints:
        if pose.joints is None:
            raise ValueError(f"pose {pose.name!r} has no recorded joints (imported from thesis lines?); "
                             "replay it without --joints")
        if pose.robot_model != model.name:
            raise ValueError(f"pose {pose.name!r} was recorded on a {pose.robot_model}; its joints mean nothing "
                             f"on this {model.name}: replay it without --joints")
        q = np.asarray(pose.joints, dtype=float)
        try:
            solver.check_joints(q)
        except (JointLimitError, ValueError) as error:
            raise JointLimitError(f"pose {pose.name!r}: {error}") from None
        return q, SOURCE_RECORDED, 0
    if pose.joints is not None:
        reference, source = np.asarray(pose.joints, dtype=float), SOURCE_IK_RECORDED
    elif previous is not None:
        reference, source = np.asarray(previous, dtype=float), SOURCE_IK_PREVIOUS
    else:
        reference, source = np.zeros(6), SOURCE_IK_ZERO
    try:
        solutions = solver.ik_all(pose.dq, q_ref=reference)
        if not solutions:
            raise UnreachablePoseError("no solution passed the FK check")
        # ik, not the nearest of ik_all's list: at a singular pose ik_all gives one member of each family, while
        # ik (and ik_batch, which plan_replay uses for recorded joints) takes the member nearest the reference
        q = solver.ik(pose.dq, reference)
    except UnreachablePoseError as error:
        raise error.prefixed(f"pose {pose.name!r} is unreachable on the {model.name}: ") from None
    return q, source, len(solutions)


def _choose_all(model, poses: Sequence[Pose], start: np.ndarray | None, replay_recorded_joints: bool,
                max_joint_travel: float | None) -> list[tuple[np.ndarray, str, int]]:
    """(joints, source, solutions) of each pose, each nearest the one before (the first nearest `start`)."""
    solvers: dict[tuple[float, ...], Any] = {}
    batch = {} if replay_recorded_joints else _solve_recorded(model, poses, solvers)
    chosen: list[tuple[np.ndarray, str, int]] = []
    for index, pose in enumerate(poses):
        found = batch.get(index)
        if found is None:
            previous = chosen[-1][0] if chosen else start
            try:
                found = choose_joints(model, pose, previous, replay_recorded_joints, solvers)
            except (UnreachablePoseError, JointLimitError, ValueError):
                # the poses before come first, as pose by pose: a move among them that swings too far
                _check_travel(poses, _travels(start, [q for q, *_ in chosen]), max_joint_travel)
                raise
        chosen.append(found)
    return chosen


def plan_replay(model, poses: Sequence[Pose], start_joints=None, a: float = 1.4, v: float = 1.05,
                replay_recorded_joints: bool = False, max_joint_travel: float | None = None) -> list[PlanStep]:
    """The replay plan of `poses`: a joint target for each, chosen before the arm moves.

    Parameters
    ----------
    model : URModel
        The arm (``ur3dq.kinematics.robot_model``); each pose is solved with its own recorded TCP offset.
    poses : sequence of Pose
    start_joints : (6,) array_like, optional
        Where the arm is (rad); None when unknown (a dry run), then the first move has no travel or time.
    a, v : float
        movej acceleration (rad/s²) and speed (rad/s), for the time figures.
    replay_recorded_joints : bool
        Use each pose's recorded joints instead of solving IK.
    max_joint_travel : float, optional
        Refuse a move that swings a joint further than this (rad).

    Returns
    -------
    list of PlanStep

    Raises
    ------
    UnreachablePoseError, JointLimitError, SafetyCheckError
        Naming the pose: nothing moves unless the whole plan is sound.

    Examples
    --------
    >>> from ur3dq.kinematics import robot_model
    >>> from ur3dq.pose import Pose
    >>> ur3 = robot_model("ur3")
    >>> q = [0.0, -1.2, 1.0, -1.4, -1.57, 0.0]
    >>> pick = Pose.from_dual_quaternion("pick", ur3.fk(q), "ur3", joints=tuple(q))
    >>> [(step.pose.name, step.source) for step in plan_replay(ur3, [pick])]
    [('pick', 'IK nearest recorded')]
    """
    motion.trapezoid_durations([], a, v)   # a and v checked before any IK (the durations come last)
    start = None if start_joints is None else np.asarray(start_joints, dtype=float)
    chosen = _choose_all(model, poses, start, replay_recorded_joints, max_joint_travel)
    joints = [q for q, *_ in chosen]
    travels = _travels(start, joints)
    _check_travel(poses, travels, max_joint_travel)
    durations = _durations(travels, a, v)
    errors = model.fk_errors(joints, [pose.dual_quaternion for pose in poses], [pose.tcp_offset for pose in poses])
    return [PlanStep(pose, q, source, count, travel, duration, metres, radians)
            for pose, (q, source, count), travel, duration, metres, radians
            in zip(poses, chosen, travels, durations, *errors)]


def _travels(start, joints: list) -> list:
    """The leading joint travel (rad, motion.leading_travel) of each move through `joints` ((6,) each) from
    `start` ((6,) or None: the first move's is None)."""
    if not joints:
        return []
    travel = motion.leading_travels(joints if start is None else [start, *joints]).tolist()
    return [None] + travel if start is None else travel


def _check_travel(poses, travels: list, max_joint_travel) -> None:
    """SafetyCheckError naming the first pose whose move swings a joint further than `max_joint_travel` (rad)."""
    if max_joint_travel is None:
        return
    for pose, travel in zip(poses, travels):
        if travel is not None and travel > max_joint_travel:
            raise SafetyCheckError(
                f"pose {pose.name!r}: a joint would travel {travel:.3f} rad in one move, more than --max-travel "
                f"{max_joint_travel:.3f} rad (record an intermediate pose, or raise --max-travel)")


def _durations(travels: list, a: float, v: float) -> list:
    """movej seconds at 100 % speed (motion.trapezoid_durations) of each move's travel; None where it is None."""
    known = [travel for travel in travels if travel is not None]   # None leads (_travels), if anywhere
    return [None] * (len(travels) - len(known)) + motion.trapezoid_durations(known, a, v).tolist()


def _solve_recorded(model, poses: Sequence[Pose], solvers: dict) -> dict:
    """{index: (joints (6,), SOURCE_IK_RECORDED, number of IK solutions)} of the poses whose recorded joints are a
    solution of their pose on `model` (within RECORDED_SOLUTION rad: what choose_joints would pick, since nothing is
    nearer), found in one batch per TCP offset (ik_batch). The other poses (unreachable, or recorded with another
    TCP or arm) are left out, for choose_joints."""
    groups: dict = {}
    for index, pose in enumerate(poses):
        if pose.joints is not None:   # a Pose's tcp_offset is a tuple of floats: a key as it is
            groups.setdefault(pose.tcp_offset, []).append(index)
    solved: dict[int, tuple[np.ndarray, str, int]] = {}
    for tcp_offset, indices in groups.items():
        solver = _solver(model, tcp_offset, solvers)
        targets = np.array([poses[i].dual_quaternion for i in indices], dtype=float)
        hints = np.array([poses[i].joints for i in indices], dtype=float)
        joints = solver.ik_batch(targets, hints)
        counts = np.sum(~np.isnan(ur_ik.ik_all_batch(solver, targets, q_ref=hints)[:, :, 0]), axis=1)
        # NaN rows (unreachable) compare False
        recorded = (np.abs(joints - hints) <= RECORDED_SOLUTION).all(axis=1) & (counts > 0)
        kept = np.flatnonzero(recorded)
        solved.update(zip(np.array(indices)[kept].tolist(),
                          zip(joints[kept], [SOURCE_IK_RECORDED] * len(kept), counts[kept].tolist())))
    return solved


def _solver(model, tcp_offset, solvers: dict):
    """`model.with_tcp(tcp_offset)`, built once per offset in `solvers`."""
    key = tuple(map(float, tcp_offset))
    if key not in solvers:
        solvers[key] = model.with_tcp(tcp_offset)
    return solvers[key]


def loop_closing_travel(steps: Sequence[PlanStep]) -> float:
    """The largest joint travel (rad) from the plan's last target back to its first, the move between loops."""
    return motion.leading_travel(steps[-1].joints, steps[0].joints)


def read_pose(robot, name: str, note: str = "") -> Pose:
    """The arm's current TCP pose as a Pose.

    The arm's current TCP pose as a Pose named `name` (one status reading, so joints and TCP belong together);
    ConnectionLostError if the state stream is frozen."""
    status = robot.state()
    if status.age > MAX_STATUS_AGE_S:
        raise ConnectionLostError(f"the robot's state stream is frozen ({status.age:.1f} s old); pose not recorded")
    return Pose.from_dual_quaternion(
        name, DualQuaternion.from_ur_pose(status.tcp_pose), robot.model_name, joints=status.joints,
        robot_serial=robot.serial_number, tcp_offset=robot.model.tcp.to_ur_pose(), note=note)


def _reached(robot, step: PlanStep, target: DualQuaternion, seconds: float) -> Reached:
    """Where `robot` ended after the move of `step` aimed at `target`."""
    error_m, error_rad = robot.tcp_pose().distance(target)
    return Reached(step, error_m, error_rad, seconds, target, target.distance(step.pose.dq)[0])


def _no_progress(description: str, done: int, total: int) -> None:
    """The default progress callback: report nothing."""


def execute_plan(robot, steps: Sequence[PlanStep], a: float, v: float, blend: float = 0.0, loops: int = 1,
                 progress: ProgressCallback = _no_progress) -> list[Reached]:
    """Move the robot through a replay plan; return where each move ended.

    Move `robot` through `steps` `loops` times; returns where each move ended (with `blend` > 0, metres, the
    whole run is one blended program and only its end is measured). `progress(description, done, total)` is
    called before each move and at the end. Each Reached compares the controller's TCP with where the replay
    aimed that TCP (the recorded pose when the TCP is unchanged). Ctrl-C or any fault stops the arm (the driver
    sends stopj) and propagates."""
    results = []
    tcp_now = robot.model.tcp
    expected = [tcp_pose_for(step.pose, tcp_now) for step in steps]
    total = len(steps) * loops
    try:
        if blend > 0:
            progress(f"blended path through {total} poses", 0, total)
            seconds = robot.movej_path([s.joints for s in steps] * loops, blend=blend, a=a, v=v,
                                       expected_poses=expected * loops)
            progress("done", total, total)
            return [_reached(robot, steps[-1], expected[-1], seconds)]
        for loop in range(loops):
            for index, (step, pose) in enumerate(zip(steps, expected)):
                progress(f"pass {loop + 1}/{loops}: {step.pose.name}", loop * len(steps) + index, total)
                seconds = robot.movej(step.joints, a=a, v=v, expected_pose=pose)
                results.append(_reached(robot, step, pose, seconds))
        progress("done", total, total)
    except KeyboardInterrupt:
        robot.stop()  # the driver already stops a motion it was watching; this covers a Ctrl-C between moves
        raise
    return results


def replay_script(steps: Sequence[PlanStep], a: float, v: float, blend: float = 0.0, loops: int = 1,
                  tcp_offset: Sequence[float] | None = None, program_name: str = "ur3dq_poses",
                  header: Sequence[str] = ()) -> str:
    """A URScript program moving through the planned `steps` with movej, `loops` times.

    Parameters
    ----------
    steps : sequence of PlanStep
        The plan (plan_replay); each step's pose name is written only in a comment.
    a, v : float
        movej acceleration (rad/s²) and speed (rad/s).
    blend : float
        Blend radius (m) between poses; the last move of each pass ends at rest.
    loops : int
        How many passes.
    tcp_offset : UR pose vector, optional
        Set with set_tcp before the first move.
    program_name : str
        The program's identifier.
    header : sequence of str
        Comment lines above the program.
    """
    if not steps:
        raise ValueError("steps must hold at least one pose to export")
    body = []
    last = len(steps) - 1
    for index, step in enumerate(steps):
        body.append(f"# {index + 1}: {urscript.comment_text(step.pose.name)}")
        body.append(urscript.movej_statement(step.joints, a, v, blend if index < last else 0.0))
    if loops != 1:
        body = urscript.repeat(loops, body)
    first = [] if tcp_offset is None else [urscript.set_tcp_statement(tcp_offset)]
    return urscript.program(program_name, first + body, header)


def describe_speeds(a: float, v: float, blend: float) -> str:
    """A one-line summary of replay_script's motion parameters, for its header."""
    return (f"movej a = {urscript.format_number(a)} rad/s^2, v = {urscript.format_number(v)} rad/s, "
            f"blend r = {urscript.format_number(blend)} m; joint targets in radians")
