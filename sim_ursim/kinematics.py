"""The simulator's own kinematics: plain standard-DH homogeneous matrices and a damped-Newton IK (numpy only).

Convention throughout: 4x4 homogeneous matrices map child to parent frame; a UR pose vector is
[x, y, z, rx, ry, rz] in metres with a rotation vector (axis * angle, radians); the TCP is flange · tcp_offset.
"""
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

Vector = Sequence[float] | np.ndarray  # joints [rad] or a pose vector [x, y, z, rx, ry, rz] (m, rad)
DH = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # standard DH columns (a, d, alpha, theta offset)


MIN_DAMPING = 1e-7  # smallest damping of the IK's least-squares steps (see inverse_kinematics)


class IKError(ValueError):
    """The numeric IK found no joint vector reaching the pose (unreachable, or singular from the given start)."""


def dh_matrix(a: float, d: float, alpha: float, theta: float) -> np.ndarray:
    """Standard DH transform of one row: Rz(theta) · Tz(d) · Tx(a) · Rx(alpha)."""
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([
        [ct, -st * ca, st * sa, a * ct],
        [st, ct * ca, -ct * sa, a * st],
        [0.0, sa, ca, d],
        [0.0, 0.0, 0.0, 1.0],
    ])


def joint_frames(dh: DH, q: Vector) -> list[np.ndarray]:
    """The 7 frames base→frame i (i = 0..6) of a standard-DH chain (a, d, alpha, theta offsets) at joints q."""
    a, d, alpha, theta = dh
    frames = [np.eye(4)]
    for i in range(6):
        frames.append(frames[-1] @ dh_matrix(a[i], d[i], alpha[i], theta[i] + q[i]))
    return frames


def flange_matrix(dh: DH, q: Vector) -> np.ndarray:
    """Base→flange (DH frame 6) transform at joints q."""
    return joint_frames(dh, q)[-1]


def rotation_vector_to_matrix(rotvec: Vector) -> np.ndarray:
    """Rodrigues: rotation matrix of a rotation vector (axis * angle, radians)."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return np.eye(3)
    kx, ky, kz = rotvec / angle
    k = np.array([[0.0, -kz, ky], [kz, 0.0, -kx], [-ky, kx, 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def matrix_to_rotation_vector(rotation: np.ndarray) -> np.ndarray:
    """Rotation vector (angle in [0, π]) of a rotation matrix, robust near 0 and π (via the unit quaternion)."""
    r = np.asarray(rotation, dtype=float)
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    # Shepperd's method: pick the largest of w, x, y, z to divide by, so no precision is lost near π.
    candidates = (trace, r[0, 0], r[1, 1], r[2, 2])
    k = max(range(4), key=candidates.__getitem__)  # the first largest, as np.argmax, without making an array
    if k == 0:
        w = math.sqrt(max(1.0 + trace, 0.0)) / 2
        x, y, z = (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w)
    elif k == 1:
        x = math.sqrt(max(1.0 + r[0, 0] - r[1, 1] - r[2, 2], 0.0)) / 2
        w, y, z = (r[2, 1] - r[1, 2]) / (4 * x), (r[0, 1] + r[1, 0]) / (4 * x), (r[0, 2] + r[2, 0]) / (4 * x)
    elif k == 2:
        y = math.sqrt(max(1.0 - r[0, 0] + r[1, 1] - r[2, 2], 0.0)) / 2
        w, x, z = (r[0, 2] - r[2, 0]) / (4 * y), (r[0, 1] + r[1, 0]) / (4 * y), (r[1, 2] + r[2, 1]) / (4 * y)
    else:
        z = math.sqrt(max(1.0 - r[0, 0] - r[1, 1] + r[2, 2], 0.0)) / 2
        w, x, y = (r[1, 0] - r[0, 1]) / (4 * z), (r[0, 2] + r[2, 0]) / (4 * z), (r[1, 2] + r[2, 1]) / (4 * z)
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    vector_norm = math.sqrt(x * x + y * y + z * z)
    if vector_norm < 1e-15:
        return np.zeros(3)
    angle = 2 * math.atan2(vector_norm, w)
    return np.array([x, y, z]) * (angle / vector_norm)


def pose_to_matrix(pose: Vector) -> np.ndarray:
    """4x4 transform of a UR pose vector [x, y, z, rx, ry, rz]; ValueError unless 6 finite numbers."""
    pose = checked_vector(pose, 6, "pose")
    matrix = np.eye(4)
    matrix[:3, :3] = rotation_vector_to_matrix(pose[3:])
    matrix[:3, 3] = pose[:3]
    return matrix


def matrix_to_pose(matrix: np.ndarray) -> np.ndarray:
    """UR pose vector [x, y, z, rx, ry, rz] of a 4x4 transform."""
    return np.concatenate([matrix[:3, 3], matrix_to_rotation_vector(matrix[:3, :3])])


def tcp_matrix(dh: DH, q: Vector, tcp_offset: Vector) -> np.ndarray:
    """Base→TCP transform: flange(q) · tcp_offset (a UR pose vector in the flange frame)."""
    return flange_matrix(dh, q) @ pose_to_matrix(tcp_offset)


def tcp_pose(dh: DH, q: Vector, tcp_offset: Vector) -> np.ndarray:
    """Forward kinematics: the UR pose vector of the TCP in the base frame at joints q."""
    return matrix_to_pose(tcp_matrix(dh, q, tcp_offset))


def checked_vector(values: object, length: int, name: str) -> np.ndarray:
    """`values` as a float array of `length` finite numbers; ValueError naming `name` otherwise."""
    try:
        array = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {length} numbers, got {values!r}") from None
    if array.shape != (length,):
        raise ValueError(f"{name} must be {length} numbers, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array.tolist()}")
    return array


def checked_number(value: object, name: str) -> float:
    """`value` as a finite float; ValueError naming `name` otherwise."""
    try:
        number = float(value)  # type: ignore[arg-type]  # anything else raises, below
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def checked_positive(value: object, name: str) -> float:
    """`value` as a finite float > 0; ValueError naming `name` otherwise."""
    number = checked_number(value, name)
    if number <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return number


def checked_non_negative(value: object, name: str) -> float:
    """`value` as a finite float ≥ 0; ValueError naming `name` otherwise."""
    number = checked_number(value, name)
    if number < 0:
        raise ValueError(f"{name} must be ≥ 0, got {value!r}")
    return number


def geometric_jacobian(dh: DH, q: Vector, tcp_offset: Vector) -> np.ndarray:
    """6x6 Jacobian mapping joint speeds to the TCP twist [v; ω] in the base frame (revolute joints about z_{i-1})."""
    frames = joint_frames(dh, q)
    return _jacobian_of(frames, frames[-1] @ pose_to_matrix(tcp_offset))


def _jacobian_of(frames: list[np.ndarray], tcp: np.ndarray) -> np.ndarray:
    """geometric_jacobian from the joint frames and the TCP matrix at the same joints."""
    stacked = np.array(frames[:6])                    # (6, 4, 4)
    z, lever = stacked[:, :3, 2].T, (tcp[:3, 3] - stacked[:, :3, 3]).T   # (3, 6) each: x, y, z rows
    jacobian = np.empty((6, 6))
    # z × lever for all six columns at once, as np.cross computes it (~10× cheaper than np.cross on 6 vectors)
    jacobian[0] = z[1] * lever[2] - z[2] * lever[1]
    jacobian[1] = z[2] * lever[0] - z[0] * lever[2]
    jacobian[2] = z[0] * lever[1] - z[1] * lever[0]
    jacobian[3:] = z
    return jacobian


def pose_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """6-vector from `current` to `target` transforms (base frame).

    [Δposition; rotation vector of R_target · R_currentᵀ].
    """
    position_error = target[:3, 3] - current[:3, 3]
    rotation_error = matrix_to_rotation_vector(target[:3, :3] @ current[:3, :3].T)
    return np.concatenate([position_error, rotation_error])


def inverse_kinematics(dh: DH, pose: Vector, q_near: Vector, tcp_offset: Vector, tolerance: float = 1e-10,
                       max_iterations: int = 100, damping: float = 1e-3) -> np.ndarray:
    """Joints reaching TCP `pose` by damped Newton steps from `q_near` (so the nearest branch); IKError if none."""
    target = pose_to_matrix(pose)
    offset = pose_to_matrix(tcp_offset)
    q = checked_vector(q_near, 6, "q_near").copy()
    for _ in range(max_iterations):
        frames = joint_frames(dh, q)   # once per step, for the error and the Jacobian (the control loop's cost)
        tcp = frames[-1] @ offset
        error = pose_error(target, tcp)
        if float(np.linalg.norm(error)) < tolerance:
            return q
        jacobian = _jacobian_of(frames, tcp)
        # Damped least squares, the damping shrinking with the error: robust far away, quadratic Newton close in.
        # The floor keeps J·Jᵀ + λ²I invertible at a singular pose (its rank-deficient J·Jᵀ plus a λ² below the
        # rounding of its entries would be singular); a 1e-7 damping leaves the convergence near-quadratic.
        error_norm = float(np.linalg.norm(error))
        lam = max(min(damping, error_norm), MIN_DAMPING)
        step = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + lam**2 * np.eye(6), error)
        # Cap the step so a far target is approached along the branch instead of jumping to another one.
        largest = float(np.max(np.abs(step)))
        if largest > 0.5:
            step *= 0.5 / largest
        q = q + step
    residual = float(np.linalg.norm(pose_error(target, tcp_matrix(dh, q, tcp_offset))))
    if residual < 1e-7:
        return q
    raise IKError(f"no joint solution reaches pose {np.round(pose, 6).tolist()} from the current joints "
                  f"(residual {residual:.2e}: out of reach or singular)")


def interpolate_pose(start: np.ndarray, end: np.ndarray, fraction: float) -> np.ndarray:
    """Pose `fraction` (0..1) of the way along the straight line start→end, orientation by constant angular rate."""
    relative = start[:3, :3].T @ end[:3, :3]
    step = rotation_vector_to_matrix(matrix_to_rotation_vector(relative) * fraction)
    result = np.eye(4)
    result[:3, :3] = start[:3, :3] @ step
    result[:3, 3] = start[:3, 3] + (end[:3, 3] - start[:3, 3]) * fraction
    return result


def rotation_angle_between(start: np.ndarray, end: np.ndarray) -> float:
    """Angle (rad, 0..π) of the rotation taking `start`'s orientation to `end`'s."""
    return float(np.linalg.norm(matrix_to_rotation_vector(start[:3, :3].T @ end[:3, :3])))


def _read_only(array: Vector) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


class ArmKinematics:
    """One arm's kinematics with its active TCP offset (a read-only pose vector in the flange frame).

    Replacing `tcp_offset` changes every answer at once. `poses_at(q)` keeps its last two answers while q and the
    offset are the same objects, so an idle control cycle costs nothing and a moving one computes the forward
    kinematics of its new joints only (its previous joints' were computed by the cycle before).
    """

    def __init__(self, dh: DH, tcp_offset: Vector):
        self.dh = dh
        self.tcp_offset = _read_only(tcp_offset)
        # The last two ((q, tcp_offset), poses_at's result), newest first; one tuple, replaced whole.
        self._cache: tuple[tuple[Any, Any], ...] = (((None, None), None),) * 2
        self._offset_matrix: tuple[Any, Any] = (None, None)  # (tcp_offset, its 4x4 transform)

    def with_fixed_tcp(self) -> "ArmKinematics":
        """This arm with today's TCP offset, kept when a later set_tcp replaces this one's: what a planned move
        uses from its command to its end, so that a TCP set while it still runs (blended) leaves its path alone."""
        return ArmKinematics(self.dh, self.tcp_offset)

    def tcp_matrix(self, q: Vector) -> np.ndarray:
        """Base→TCP transform at joints q."""
        return tcp_matrix(self.dh, q, self.tcp_offset)

    def tcp_pose(self, q: Vector) -> np.ndarray:
        """TCP pose vector in the base frame at joints q."""
        return tcp_pose(self.dh, q, self.tcp_offset)

    def solve_ik(self, pose: Vector, q_near: Vector, **options: Any) -> np.ndarray:
        """Joints reaching TCP `pose` nearest to q_near (options as `inverse_kinematics`); IKError if none."""
        return inverse_kinematics(self.dh, pose, q_near, self.tcp_offset, **options)

    def solve_planned(self, pose: Vector, q_near: Vector) -> np.ndarray:
        """`solve_ik` for planned motions: tighter and shorter than the defaults (it runs every cycle of a movel or
        speedl)."""
        return self.solve_ik(pose, q_near, tolerance=1e-11, max_iterations=50)

    def poses_at(self, q: np.ndarray) -> tuple[np.ndarray, list[np.ndarray], np.ndarray, np.ndarray]:
        """(TCP matrix, the 7 joint frames, TCP pose, flange pose) at q; the poses read-only."""
        offset = self.tcp_offset
        cache = self._cache
        for key, cached in cache:
            if key[0] is q and key[1] is offset:
                return cached
        frames = joint_frames(self.dh, q)
        tcp = frames[-1] @ self._tcp_offset_matrix(offset)
        result = (tcp, frames, _read_only(matrix_to_pose(tcp)), _read_only(matrix_to_pose(frames[-1])))
        self._cache = (((q, offset), result), cache[0])
        return result

    def _tcp_offset_matrix(self, offset: np.ndarray) -> np.ndarray:
        """The 4x4 transform of the TCP offset `offset` (computed once per offset object)."""
        cached_offset, matrix = self._offset_matrix
        if cached_offset is not offset:
            matrix = pose_to_matrix(offset)
            self._offset_matrix = (offset, matrix)
        return matrix

    def speeds_between(self, previous_q: np.ndarray, q: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(TCP twist [v; ω] (6,), elbow velocity (3,)) by finite difference from previous_q to q over dt."""
        tcp, frames, _, _ = self.poses_at(q)
        if previous_q is q:
            return np.zeros(6), np.zeros(3)
        old_tcp, old_frames, _, _ = self.poses_at(previous_q)
        twist = np.concatenate([(tcp[:3, 3] - old_tcp[:3, 3]) / dt,
                                matrix_to_rotation_vector(tcp[:3, :3] @ old_tcp[:3, :3].T) / dt])
        return twist, (frames[2][:3, 3] - old_frames[2][:3, 3]) / dt
