"""Trajectory maths of the simulator's motion engine: trapezoidal profiles and the segments the controller executes.

Every segment answers `advance(dt, q, qd) -> q_next` once per control cycle; `dt` is already scaled by the speed
slider where the segment is a planned trajectory. Segments know nothing about threads, safety or clients.
"""
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import kinematics


@dataclass(frozen=True)
class Trapezoid:
    """Trapezoidal (or triangular) speed profile over `distance` ≥ 0: accelerate, cruise at `peak`, decelerate."""

    distance: float
    peak: float
    acceleration: float
    accel_time: float
    duration: float

    def position(self, t: float) -> float:
        """Distance travelled at time t (clamped to [0, duration])."""
        t = min(max(t, 0.0), self.duration)
        if self.duration == 0.0:
            return self.distance
        if t < self.accel_time:
            return 0.5 * self.acceleration * t * t
        cruise_end = self.duration - self.accel_time
        if t <= cruise_end:
            return 0.5 * self.acceleration * self.accel_time**2 + self.peak * (t - self.accel_time)
        remaining = self.duration - t
        return self.distance - 0.5 * self.acceleration * remaining * remaining

    def speed(self, t: float) -> float:
        """Speed along the profile at time t (0 outside [0, duration])."""
        if t <= 0.0 or t >= self.duration:
            return 0.0
        if t < self.accel_time:
            return self.acceleration * t
        if t > self.duration - self.accel_time:
            return self.acceleration * (self.duration - t)
        return self.peak


def trapezoid(distance: float, speed: float, acceleration: float) -> Trapezoid:
    """Fastest profile covering `distance` with at most `speed` and `acceleration` (triangular when too short)."""
    if distance < 0 or speed <= 0 or acceleration <= 0:
        raise ValueError(f"trapezoid needs distance ≥ 0, speed > 0, acceleration > 0; got {distance}, {speed}, "
                         f"{acceleration}")
    if distance == 0.0:
        return Trapezoid(0.0, 0.0, acceleration, 0.0, 0.0)
    if distance >= speed * speed / acceleration:
        accel_time = speed / acceleration
        return Trapezoid(distance, speed, acceleration, accel_time, distance / speed + accel_time)
    accel_time = math.sqrt(distance / acceleration)
    return Trapezoid(distance, acceleration * accel_time, acceleration, accel_time, 2 * accel_time)


def timed_trapezoid(distance: float, duration: float, acceleration: float) -> Trapezoid:
    """Profile covering `distance` in exactly `duration`: uses `acceleration` when it allows, else a triangle."""
    if duration <= 0:
        raise ValueError(f"motion time t must be > 0, got {duration}")
    if distance == 0.0:
        return Trapezoid(0.0, 0.0, acceleration, 0.0, duration)
    discriminant = acceleration * acceleration * duration * duration - 4 * acceleration * distance
    if acceleration > 0 and discriminant >= 0:
        # D = v (T - v/a) solved for the slower root v: the profile accelerates with `a` then cruises.
        peak = (acceleration * duration - math.sqrt(discriminant)) / 2
        return Trapezoid(distance, peak, acceleration, peak / acceleration, duration)
    # `a` too small to make it in time: the triangle with the acceleration that exactly fits.
    needed = 4 * distance / (duration * duration)
    return Trapezoid(distance, needed * duration / 2, needed, duration / 2, duration)


def synchronised_joint_profile(delta_q: np.ndarray, speed: float, acceleration: float, duration: float,
                               max_speeds: np.ndarray, max_accelerations: np.ndarray) -> Trapezoid:
    """Leading-axis profile for movej: the longest travel leads with a, v (or time t); slower joints are scaled to it.

    `speed` is lowered (and `acceleration` capped) so that no joint exceeds its own limit after scaling.
    """
    travel = np.abs(np.asarray(delta_q, dtype=float))
    leading = float(travel.max()) if travel.size else 0.0
    if leading == 0.0:
        return Trapezoid(0.0, 0.0, max(acceleration, 1e-9), 0.0, max(duration, 0.0))
    ratios = travel / leading  # in [0, 1]: joint i moves at ratio_i × the leading axis' speed
    # The cap is min(limit_i / ratio_i), taken as 1 / max(ratio_i / limit_i): a joint with a tiny travel (ratio
    # 1e-300) then adds a tiny term instead of overflowing a division, and a still joint adds nothing.
    speed_cap = 1.0 / float(np.max(ratios / np.asarray(max_speeds, dtype=float)))
    accel_cap = 1.0 / float(np.max(ratios / np.asarray(max_accelerations, dtype=float)))
    acceleration = min(acceleration, accel_cap)
    if duration > 0:
        profile = timed_trapezoid(leading, duration, acceleration)
        if profile.peak <= speed_cap * (1 + 1e-9):
            return profile
        # The requested time would exceed a joint's speed limit: stretch it, as the controller's limiter does.
    return trapezoid(leading, min(speed, speed_cap), acceleration)


class JointMove:
    """movej segment: every joint on the same normalised trapezoid from q_start to q_end."""

    kind = "movej"

    def __init__(self, q_start: np.ndarray, q_end: np.ndarray, profile: Trapezoid):
        self.q_start = np.array(q_start, dtype=float)
        self.q_end = np.array(q_end, dtype=float)
        self.profile = profile
        self.elapsed = 0.0

    @property
    def finished(self) -> bool:
        return self.elapsed >= self.profile.duration

    def sample(self) -> np.ndarray:
        """Joints at the current trajectory time."""
        if self.profile.distance == 0.0:
            return self.q_end.copy() if self.finished else self.q_start.copy()
        fraction = self.profile.position(self.elapsed) / self.profile.distance
        return self.q_start + (self.q_end - self.q_start) * fraction

    def advance(self, dt: float, q: np.ndarray | None = None) -> np.ndarray:
        """Move trajectory time on by dt (already speed-slider scaled); return the joints there (`q` unused)."""
        self.elapsed = min(self.elapsed + dt, self.profile.duration)
        return self.sample()


class LinearMove:
    """movel segment: TCP on a straight line (orientation at constant angular rate); joints by IK every cycle."""

    kind = "movel"

    def __init__(self, start_matrix: np.ndarray, end_matrix: np.ndarray, q_start: np.ndarray, q_end: np.ndarray,
                 profile: Trapezoid, solve_ik: Callable[[np.ndarray, np.ndarray], np.ndarray]):
        self.start_matrix = start_matrix
        self.end_matrix = end_matrix
        self.q_start = np.array(q_start, dtype=float)
        self.q_end = np.array(q_end, dtype=float)
        self.profile = profile
        self.elapsed = 0.0
        self._solve_ik = solve_ik
        self._last_q = self.q_start.copy()

    @property
    def finished(self) -> bool:
        return self.elapsed >= self.profile.duration

    def sample(self) -> np.ndarray:
        """Joints placing the TCP at the current point of the line (IK seeded with the previous cycle's joints)."""
        # At the end too, IK from the previous cycle keeps the joints continuous (q_end is only the planned guess).
        fraction = self.profile.position(self.elapsed) / self.profile.distance if self.profile.distance else 1.0
        target = kinematics.interpolate_pose(self.start_matrix, self.end_matrix, fraction)
        self._last_q = self._solve_ik(kinematics.matrix_to_pose(target), self._last_q)
        return self._last_q.copy()

    def advance(self, dt: float, q: np.ndarray | None = None) -> np.ndarray:
        """Move trajectory time on by dt (already speed-slider scaled); return the joints there (`q` unused)."""
        self.elapsed = min(self.elapsed + dt, self.profile.duration)
        return self.sample()


def linear_profile(start_matrix: np.ndarray, end_matrix: np.ndarray, start_q: np.ndarray, acceleration: float,
                   speed: float, duration: float, max_speeds: np.ndarray,
                   solve_ik: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> Trapezoid:
    """Profile of a movel: with speed and acceleration, or in the time t = `duration` > 0 — exactly t when the
    joints can follow, else slowed as a controller's speed scaling slows it: the fastest trapezoid (same
    acceleration) whose joint speeds stay within FEASIBLE_SPEED_FRACTION of `max_speeds`.

    The joints' travel per metre of path is sampled by IK at LINEAR_FEASIBILITY_SAMPLES points along the line; a
    point without IK solution leaves the timed profile (the motion then stops the arm where it fails, as before).
    """
    if duration <= 0:
        return trapezoid(linear_distance(start_matrix, end_matrix), speed, acceleration)
    distance = linear_distance(start_matrix, end_matrix)
    profile = timed_trapezoid(distance, duration, acceleration)
    if distance == 0.0:
        return profile
    step = distance / LINEAR_FEASIBILITY_SAMPLES
    q = np.asarray(start_q, dtype=float)
    steepest = np.zeros(6)  # rad of joint travel per metre of path, per joint
    for k in range(1, LINEAR_FEASIBILITY_SAMPLES + 1):
        target = kinematics.interpolate_pose(start_matrix, end_matrix, k / LINEAR_FEASIBILITY_SAMPLES)
        try:
            q_next = solve_ik(kinematics.matrix_to_pose(target), q)
        except kinematics.IKError:
            return profile
        steepest = np.maximum(steepest, np.abs(q_next - q) / step)
        q = q_next
    overspeed = float(np.max(steepest * profile.peak / np.asarray(max_speeds, dtype=float)))
    if overspeed <= FEASIBLE_SPEED_FRACTION:
        return profile
    return trapezoid(distance, profile.peak * FEASIBLE_SPEED_FRACTION / overspeed, profile.acceleration)


LINEAR_FEASIBILITY_SAMPLES = 32
FEASIBLE_SPEED_FRACTION = 0.9  # of the joint speed limit: margin for the joint speeds between samples


def plan_joint_move(start_q: np.ndarray, q: np.ndarray, acceleration: float, speed: float, duration: float,
                    max_speeds: np.ndarray, max_accelerations: np.ndarray) -> JointMove:
    """The movej segment from start_q to q (synchronised_joint_profile), planned when the move starts."""
    profile = synchronised_joint_profile(q - start_q, speed, acceleration, duration, max_speeds, max_accelerations)
    return JointMove(start_q, q, profile)


def plan_linear_move(start_matrix: np.ndarray, end_matrix: np.ndarray, start_q: np.ndarray, q_end: np.ndarray,
                     acceleration: float, speed: float, duration: float, max_speeds: np.ndarray,
                     solve_ik: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> LinearMove:
    """The movel segment from the TCP frame start_matrix (joints start_q) to end_matrix (linear_profile)."""
    profile = linear_profile(start_matrix, end_matrix, start_q, acceleration, speed, duration, max_speeds, solve_ik)
    return LinearMove(start_matrix, end_matrix, start_q, q_end, profile, solve_ik)

def linear_distance(start_matrix: np.ndarray, end_matrix: np.ndarray) -> float:
    """Leading 'distance' of a movel: the larger of the path length (m) and the rotation angle (rad, read as m)."""
    length = float(np.linalg.norm(end_matrix[:3, 3] - start_matrix[:3, 3]))
    return max(length, kinematics.rotation_angle_between(start_matrix, end_matrix))


_TIME_EPSILON = 1e-9  # s: float sums of control periods that equal a commanded time


def step_towards(value: float, goal: float, step: float) -> float:
    """`value` moved towards `goal` by at most `step` (≥ 0)."""
    return min(goal, value + step) if goal > value else max(goal, value - step)


def ramp_towards(current: np.ndarray, target: np.ndarray, max_change: float) -> np.ndarray:
    """Vector `current` moved towards `target` by at most `max_change` (largest component), direction kept."""
    difference = np.asarray(target, dtype=float) - current
    largest = float(np.max(np.abs(difference))) if difference.size else 0.0
    if largest <= max_change or largest == 0.0:
        return np.array(target, dtype=float)
    return current + difference * (max_change / largest)


class SpeedRamp:
    """A speed command's speed vector (joint speeds, or a TCP twist) ramping to `target` at `acceleration`; after
    `duration` (if > 0) to zero.

    A script's `speedj` / `speedl` with t > 0 is held (`hold_owner`, the commanding script thread): it moves whole
    control cycles until it has moved `duration` of trajectory time, then the arm waits, without moving, for that
    thread's next command. On a controller the script threads run inside the control cycle, in lockstep with it
    (UR's manual: speedj and speedl return "after time t"; URCL's External Control script streams one
    `speedj(qd, a, steptime)` per control cycle and integrates its splines assuming each runs exactly t, and its
    speedl thread one `speedl(twist, 40, steptime)` per cycle). Here the interpreter needs real time between the
    return and the next command; moving on meanwhile made every step longer than planned (URCL's 3 s pre-positioning
    spline of trajectory_streaming_example travelled 1.6 times its distance). Released (`release()`: the thread waits
    for something else, or ended) it ramps to zero like a timed command.

    The arm moves in whole cycles (the controller computes one set-point per cycle), and a thread's commands use up
    the cycle's time as the manual's thread scheduling says: a t shorter than the cycle leaves the rest of the cycle
    to the same thread (`unused_time`), whose next held command takes it first (`start_within`) — four
    `speedj(qd, a, 0.002)` in one 8 ms CB3 cycle, the cycle moving at qd (docs/ursim.md).
    """

    def __init__(self, start: np.ndarray, target: np.ndarray, acceleration: float, duration: float,
                 hold_owner: object = None):
        self.speed = np.array(start, dtype=float)
        self.target = np.array(target, dtype=float)
        self.acceleration = acceleration
        self.duration = duration
        self.elapsed = 0.0
        self.hold_owner = hold_owner if duration > 0 else None
        self.idle_cycles = 0  # cycles a held segment has waited, not moving, for its thread's next command

    @property
    def holding(self) -> bool:
        """True once a held segment has moved its time: the arm waits for its thread's next command."""
        return self.hold_owner is not None and self.duration - self.elapsed <= _TIME_EPSILON

    @property
    def unused_time(self) -> float:
        """Time of the cycle just moved that lies beyond this held command's t, while no cycle has passed since: the
        same thread's next held command starts within it. 0 once a cycle has gone by without a command."""
        if not self.holding or self.idle_cycles:
            return 0.0
        return max(0.0, self.elapsed - self.duration)

    def start_within(self, moved: float) -> None:
        """This held command begins in a cycle already moved for `moved` s beyond the thread's previous command: that
        much of its time is already used (all of it when t ≤ moved: the command is over, the arm holds)."""
        self.elapsed = moved

    def release(self) -> None:
        """No next command is coming from the holding thread: finish like a timed command (ramp to rest)."""
        self.hold_owner = None

    @property
    def finished(self) -> bool:
        return (self.duration > 0 and self.elapsed >= self.duration and not np.any(self.speed)
                and self.hold_owner is None)

    @property
    def commanded_speed(self) -> np.ndarray:
        """The speed the ramp has reached (trajectory time: before the speed slider)."""
        return self.speed.copy()

    def ramp(self, dt: float) -> float:
        """Ramp the speed over dt; return how long the arm moves at it this cycle (a held segment moves only for
        what is left of its time, then not at all)."""
        if self.hold_owner is not None:
            if self.holding:
                self.idle_cycles += 1
                return 0.0
            goal = self.target  # a whole cycle, even when less of the command's time is left (see the class)
        else:
            goal = self.target if (self.duration <= 0 or self.elapsed + dt < self.duration) else np.zeros(6)
        self.elapsed += dt
        self.speed = ramp_towards(self.speed, goal, self.acceleration * dt)
        return dt


class JointSpeed(SpeedRamp):
    """speedj segment: the joint speeds ramp (SpeedRamp)."""

    kind = "speedj"

    def advance(self, dt: float, q: np.ndarray) -> np.ndarray:
        """Joints after dt at the ramped speed."""
        moving = self.ramp(dt)
        return q + self.speed * moving if moving else np.array(q, dtype=float)


class CartesianSpeed(SpeedRamp):
    """speedl segment: the TCP twist [v; ω] (base frame) ramps (SpeedRamp); joints follow by IK each cycle."""

    kind = "speedl"

    def __init__(self, xd_start: np.ndarray, xd_target: np.ndarray, acceleration: float, duration: float,
                 tcp_matrix_of: Callable[[np.ndarray], np.ndarray],
                 solve_ik: Callable[[np.ndarray, np.ndarray], np.ndarray], hold_owner: object = None):
        super().__init__(xd_start, xd_target, acceleration, duration, hold_owner)
        self._tcp_matrix_of = tcp_matrix_of
        self._solve_ik = solve_ik

    def advance(self, dt: float, q: np.ndarray) -> np.ndarray:
        """Joints after moving the TCP by the ramped twist for dt."""
        moving = self.ramp(dt)
        if not moving:
            return np.array(q, dtype=float)
        current = self._tcp_matrix_of(q)
        target = np.eye(4)
        target[:3, 3] = current[:3, 3] + self.speed[:3] * moving
        target[:3, :3] = kinematics.rotation_vector_to_matrix(self.speed[3:] * moving) @ current[:3, :3]
        return self._solve_ik(kinematics.matrix_to_pose(target), q)


class ServoTarget:
    """servoj segment: reach `q_target` linearly within `duration` from the command, speed clipped to `max_speeds`.

    lookahead_time and gain are accepted by the controller but their smoothing is not modelled (documented).
    """

    kind = "servoj"

    def __init__(self, q_target: np.ndarray, duration: float, max_speeds: np.ndarray):
        self.q_target = np.array(q_target, dtype=float)
        self.duration = duration
        self.max_speeds = np.asarray(max_speeds, dtype=float)
        self.elapsed = 0.0

    @property
    def finished(self) -> bool:
        return False  # holds its target until the next command replaces it or a stop ends it

    def advance(self, dt: float, q: np.ndarray) -> np.ndarray:
        """Joints after dt of linear travel towards the target."""
        remaining = max(self.duration - self.elapsed, dt)
        self.elapsed += dt
        speed = (self.q_target - q) / remaining
        speed = np.clip(speed, -self.max_speeds, self.max_speeds)
        step = speed * dt
        overshoot = np.abs(step) >= np.abs(self.q_target - q)
        return np.where(overshoot, self.q_target, q + step)


class Stop:
    """stopj / stopl / protective stop: every joint's speed falls linearly to zero together (path kept)."""

    kind = "stop"

    def __init__(self, qd_start: np.ndarray, deceleration: float):
        self.qd = np.array(qd_start, dtype=float)
        self.deceleration = deceleration

    @property
    def finished(self) -> bool:
        return not np.any(self.qd)

    def advance(self, dt: float, q: np.ndarray) -> np.ndarray:
        """Joints after dt of deceleration."""
        self.qd = ramp_towards(self.qd, np.zeros(6), self.deceleration * dt)
        return q + self.qd * dt
