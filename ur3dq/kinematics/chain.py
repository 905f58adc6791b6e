"""SerialChain: forward kinematics of a serial chain of revolute and prismatic joints with dual quaternions.

Every chain is stored in one form,

    σ(q) = K_0 · J_1(q_1) · K_1 · J_2(q_2) · … · J_n(q_n) · K_n,

where J_i is the joint's own motion about/along a local z axis (rotation rz(q) or translation tz(q)) and the K_i are
constant dual quaternions (base offset, link geometry, tool offset). Two builders fill it:

* :meth:`SerialChain.from_dh` — standard DH rows, seed 003's per-joint dual quaternion
  rz(θ)·tz(d)·tx(a)·rx(α);
* :meth:`SerialChain.from_axes` — joint axes (direction, point) in the base frame at q = 0 and the flange pose at
  q = 0 (the thesis' §4.2 axis-angle method, product-of-exponentials style): σ(q) = Π exp(ξ_i q_i) · M.

The thesis' FK uses M = pure translation (its end frame is parallel to the base at q = 0), whereas the DH flange
frame at q = 0 is rotated by R0 = the flange orientation at q = 0 (:meth:`SerialChain.home`). So
σ_thesis(q) = σ_DH(q) · R0* for every q — :func:`thesis_to_dh_flange` gives that constant, tests check it.

Joint coefficients are handled as tuples of 8 numbers that may be floats (single FK, no numpy overhead) or arrays
(batch FK, vectorised over N): the same arithmetic serves both.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion, multiply_coefficients, translation_coefficients, z_axis_coefficients
from ur3dq.real_numbers import real_array

REVOLUTE = "revolute"
PRISMATIC = "prismatic"
JOINT_TYPES = (REVOLUTE, PRISMATIC)

#: 8 coefficients (rw rx ry rz dw dx dy dz) as Python floats, or arrays of N values each (batches).
Coefficients = tuple[Any, ...]
_IDENTITY = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
_POSE_FORMS = "expected a DualQuaternion, 8 coefficients or a UR pose vector of 6"


def dh_joint(theta: ArrayLike, d: ArrayLike, a: ArrayLike, alpha: ArrayLike) -> np.ndarray:
    """(..., 8) dual quaternion of one standard DH row rz(θ)·tz(d)·tx(a)·rx(α) (seed 003), arrays broadcast."""
    theta, d, a, alpha = (np.asarray(v, dtype=float) for v in (theta, d, a, alpha))
    ct, st = np.cos(theta / 2), np.sin(theta / 2)
    ca, sa = np.cos(alpha / 2), np.sin(alpha / 2)
    # rz(θ)·rx(α) written out; the translation tz(d)·tx(a) seen from the parent is (a cos θ, a sin θ, d).
    real = np.stack(np.broadcast_arrays(ct * ca, ct * sa, st * sa, st * ca), axis=-1)
    translation = np.stack(np.broadcast_arrays(a * np.cos(theta), a * np.sin(theta), d), axis=-1)
    pure = np.concatenate((np.zeros(translation.shape[:-1] + (1,)), translation), axis=-1)
    return np.concatenate((real, 0.5 * dqarray.quaternion_multiply(pure, real)), axis=-1)


def dh_matrix(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """4×4 homogeneous matrix of one standard DH row Rz(θ)·Tz(d)·Tx(a)·Rx(α) (the textbook form, seed 004)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def frame_with_z_axis(direction: ArrayLike, point: ArrayLike) -> np.ndarray:
    """(8,) pose whose origin is ``point`` and whose z axis is the unit of ``direction`` (shortest-arc rotation)."""
    direction = dqarray.as_array(direction, 3, "direction")
    norm = float(np.linalg.norm(direction))
    if norm < 1e-12:
        raise ValueError("direction: a joint axis must not be the zero vector")
    u = direction / norm
    z = np.array([0.0, 0.0, 1.0])
    # The shortest arc v → u is normalise(1 + v·u, v × u), well conditioned only while v·u ≥ 0: for a u in the
    # lower half space first turn z to −z (π about x), then take the arc −z → u.
    if u[2] >= 0.0:
        rotation = np.concatenate(([1.0 + u[2]], np.cross(z, u)))
    else:
        arc = np.concatenate(([1.0 - u[2]], np.cross(-z, u)))
        rotation = dqarray.quaternion_multiply(arc, np.array([0.0, 1.0, 0.0, 0.0]))
    rotation /= np.linalg.norm(rotation)
    return dqarray.from_rotation_translation(rotation, point)


def thesis_to_dh_flange(home: DualQuaternion) -> DualQuaternion:
    """The constant pure rotation R0* with σ_thesis(q) = σ_DH(q)·R0*, R0 = orientation of ``home`` (flange at q=0)."""
    return DualQuaternion.from_rotation_translation(home.rotation.conjugate, (0.0, 0.0, 0.0))


def _as_coefficients(pose: object, name: str) -> Coefficients:
    """8 floats of a unit DualQuaternion, 8-array or UR pose vector (6 numbers); ValueError naming ``name``."""
    if pose is None:
        return _IDENTITY
    if isinstance(pose, DualQuaternion):
        array = pose.to_array()
    else:
        try:
            array = real_array(pose)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: {_POSE_FORMS}, got {pose!r}") from exc
        if array.shape == (6,):
            array = dqarray.from_ur_pose(array)
    array = dqarray.check_unit(array, name)
    if array.shape != (8,):
        raise ValueError(f"{name}: {_POSE_FORMS}")
    return tuple(float(c) for c in array)


def joint_motion(pose: Coefficients, revolute: bool, value: float) -> Coefficients:
    """pose·rz(value) (``revolute``) or pose·tz(value), an 8-tuple of floats, written out for the joint's sparse
    coefficients (a leaf function: the compiled kernels use it as it is).

    Revolute: both parts times rz = (c, 0, 0, s): (w c − z s, x c + y s, y c − x s, z c + w s).
    Prismatic: (r + εd)(1 + ε(0, 0, 0, h)) = r + ε(d + r·(0, 0, 0, h)), r·(0,0,0,h) = (−z h, y h, −x h, w h).
    """
    w, x, y, z, dw, dx, dy, dz = pose
    half = 0.5 * value
    if revolute:
        c, s = math.cos(half), math.sin(half)
        return (w * c - z * s, x * c + y * s, y * c - x * s, z * c + w * s,
                dw * c - dz * s, dx * c + dy * s, dy * c - dx * s, dz * c + dw * s)
    return (w, x, y, z, dw - z * half, dx + y * half, dy - x * half, dz + w * half)


_K = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0)           # the quaternion k: rz(θ) = cos(θ/2) + k·sin(θ/2)
_EPSILON_K = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)   # ε·k: tz(t) = 1 + ε·k·t/2


#: Rows per block in batch FK: small enough that a block's temporaries stay in the CPU cache (measured: 4096–8192
#: rows run about twice as fast per pose as one pass over 10^5 rows), large enough to amortise Python overhead.
BATCH_BLOCK = 4096


class SerialChain:
    """σ(q) = K_0·J_1(q_1)·K_1·…·J_n(q_n)·K_n; J_i = rz(q_i) (revolute) or tz(q_i) (prismatic)."""

    def __init__(self, constants: ArrayLike, joint_types: Iterable[str], joint_offsets: ArrayLike | None = None,
                 frame_offsets: ArrayLike | None = None) -> None:
        """From n + 1 constant unit dual quaternions (8 each) and n joint types ('revolute' / 'prismatic').

        ``joint_offsets`` (n values, default 0) are added to q before J_i, e.g. DH θ offsets of a calibration.
        ``frame_offsets`` (n + 1 unit dual quaternions, default identity) turn the running products into the
        frames :meth:`frames` reports: frame_i = K_0·J_1·…·J_i·K_i·F_i (the builders undo what they folded into K_i).
        """
        constants = dqarray.check_unit(constants, "constants")
        joint_types = tuple(joint_types)
        if constants.ndim != 2 or len(constants) != len(joint_types) + 1:
            raise ValueError(f"constants: need {len(joint_types) + 1} dual quaternions for {len(joint_types)} joints")
        unknown = [kind for kind in joint_types if kind not in JOINT_TYPES]
        if unknown:
            raise ValueError(f"joint_types: unknown joint type {unknown[0]!r} (use 'revolute' or 'prismatic')")
        n = len(joint_types)
        offsets = np.zeros(n) if joint_offsets is None else dqarray.as_array(joint_offsets, n, "joint_offsets")
        self._constants = tuple(tuple(float(c) for c in row) for row in constants)
        if frame_offsets is None:
            frame_offsets = [_IDENTITY] * len(constants)
        frame_offsets = dqarray.check_unit(frame_offsets, "frame_offsets")
        if frame_offsets.shape != constants.shape:
            raise ValueError(f"frame_offsets: expected {len(constants)} dual quaternions, got {frame_offsets.shape}")
        self._frame_offsets = tuple(tuple(float(c) for c in row) for row in frame_offsets)
        self.joint_types = joint_types
        self.joint_offsets = tuple(float(v) for v in offsets)
        self._maps: tuple[np.ndarray, ...] | None = None   # fk_batch's per-joint matrices, built on first use
        self._form: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None   # product_form's arrays, on first use

    # ---------------------------------------------------------------------------------------------- builders
    @classmethod
    def from_dh(cls, a: ArrayLike, d: ArrayLike, alpha: ArrayLike, theta: ArrayLike | None = None,
                joint_types: Sequence[str] | None = None, base: object = None, tool: object = None) -> SerialChain:
        """From standard DH rows (metres, radians): joint i = rz(θ_i + q_i)·tz(d_i)·tx(a_i)·rx(α_i).

        For a prismatic joint q adds to d instead (θ_i stays fixed). ``base`` and ``tool`` (DualQuaternion, 8
        coefficients or UR pose vector) are prepended / appended.
        """
        a = dqarray.as_array(a, (), "a")
        if a.ndim != 1 or len(a) == 0:
            raise ValueError(f"a: expected one link length per joint (at least one), got shape {a.shape}")
        n = len(a)
        d = dqarray.as_array(d, n, "d")
        alpha = dqarray.as_array(alpha, n, "alpha")
        theta = np.zeros(n) if theta is None else dqarray.as_array(theta, n, "theta")
        joint_types = (REVOLUTE,) * n if joint_types is None else tuple(joint_types)
        if len(joint_types) != n:
            raise ValueError(f"joint_types: expected {n} entries, got {len(joint_types)}")
        # J_i only carries q: the fixed part of the row, rz(θ_i)·tz(d_i), commutes with it and joins the constant
        # before; tx(a_i)·rx(α_i) joins the constant after.
        before = dh_joint(theta, d, 0.0, 0.0)
        after = dh_joint(0.0, 0.0, a, alpha)
        constants = [_as_coefficients(base, "base")]
        for i in range(n):
            constants[i] = multiply_coefficients(constants[i], tuple(before[i]))
            constants.append(tuple(after[i]))
        constants[n] = multiply_coefficients(constants[n], _as_coefficients(tool, "tool"))
        # Frame i (DH frame i) is the running product before joint i + 1's fixed rz(θ)·tz(d) was folded in.
        frame_offsets = [tuple(row) for row in dqarray.conjugate(before)] + [_IDENTITY]
        return cls(constants, joint_types, frame_offsets=frame_offsets)

    @classmethod
    def from_axes(cls, directions: ArrayLike, points: ArrayLike, home: object, joint_types: Sequence[str] | None = None,
                  base: object = None, tool: object = None) -> SerialChain:
        """From joint axes in the base frame at q = 0 (``directions``, ``points``: n×3) and the flange pose at q = 0.

        σ(q) = Π_i exp(ξ_i q_i)·home (thesis §4.2, product of exponentials): exp(ξ_i q_i) = P_i·J_i(q_i)·P_i*, P_i
        a frame on axis i with z along it. A point is ignored for a prismatic joint's translation (any point works).
        """
        directions = dqarray.as_array(directions, 3, "directions")
        points = dqarray.as_array(points, 3, "points")
        if directions.ndim != 2 or points.shape != directions.shape:
            raise ValueError(f"points: expected the shape of directions {directions.shape}, got {points.shape}")
        n = len(directions)
        joint_types = (REVOLUTE,) * n if joint_types is None else tuple(joint_types)
        if len(joint_types) != n:
            raise ValueError(f"joint_types: expected {n} entries, got {len(joint_types)}")
        frames = [tuple(frame_with_z_axis(directions[i], points[i])) for i in range(n)]
        inverse = [tuple(dqarray.conjugate(np.array(frame))) for frame in frames]
        constants = [multiply_coefficients(_as_coefficients(base, "base"), frames[0])]
        for i in range(1, n):
            constants.append(multiply_coefficients(inverse[i - 1], frames[i]))
        flange = multiply_coefficients(_as_coefficients(home, "home"), _as_coefficients(tool, "tool"))
        constants.append(multiply_coefficients(inverse[n - 1], flange))
        # Frame i < n is the partial product Π_{k≤i} exp(ξ_k q_k) (base at i = 0), i.e. the running product · P_{i+1}*;
        # frame n is the end pose.
        return cls(constants, joint_types, frame_offsets=inverse + [_IDENTITY])

    def with_tool(self, tool: object) -> SerialChain:
        """The same chain with ``tool`` (in the current end frame) appended."""
        constants = list(self._constants)
        constants[-1] = multiply_coefficients(constants[-1], _as_coefficients(tool, "tool"))
        return SerialChain(constants, self.joint_types, self.joint_offsets, self._frame_offsets)

    def with_base(self, base: object) -> SerialChain:
        """The same chain seen from a new frame: ``base`` (pose of the old base in the new frame) prepended."""
        constants = list(self._constants)
        constants[0] = multiply_coefficients(_as_coefficients(base, "base"), constants[0])
        return SerialChain(constants, self.joint_types, self.joint_offsets, self._frame_offsets)

    # ----------------------------------------------------------------------------------------------------- FK
    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return len(self.joint_types)

    def check_q(self, q: ArrayLike, name: str = "q") -> np.ndarray:
        """``q`` as a finite float vector of n joint values; ValueError naming ``name`` otherwise."""
        q = dqarray.as_array(q, self.n_joints, name)
        if q.ndim != 1:
            raise ValueError(f"{name}: expected {self.n_joints} joint values, got shape {q.shape}")
        return q

    def _after_joint(self, i: int, pose: Coefficients, value: float) -> Coefficients:
        """pose·J_i(value + offset_i) (floats)."""
        return joint_motion(pose, self.joint_types[i] == REVOLUTE, value + self.joint_offsets[i])

    def _accumulate(self, joint_values: Iterable[float]) -> Iterator[Coefficients]:
        """Yield the running products K_0·J_1·K_1·…·J_i·K_i for i = 0..n (coefficient tuples)."""
        pose = self._constants[0]
        yield pose
        for i, value in enumerate(joint_values):
            pose = multiply_coefficients(self._after_joint(i, pose, value), self._constants[i + 1])
            yield pose

    def fk(self, q: ArrayLike) -> DualQuaternion:
        """End pose σ(q) (the last constant includes the tool) in the base frame."""
        return self.fk_of_floats(tuple(float(v) for v in self.check_q(q)))

    def fk_of_floats(self, q: tuple[float, ...]) -> DualQuaternion:
        """End pose for n finite Python floats already validated by the caller (the single-FK hot path)."""
        return DualQuaternion._from_tuple(self.end_coefficients(q))

    def end_coefficients(self, q: tuple[float, ...]) -> Coefficients:
        """End pose as an 8-tuple of floats (rw rx ry rz dw dx dy dz) for n finite floats validated by the caller."""
        *_, end = self._accumulate(q)
        return end

    def fk_batch(self, joint_matrix: ArrayLike) -> np.ndarray:
        """End poses (N, 8) of N configurations (N, n), vectorised over N."""
        joint_matrix = dqarray.as_array(joint_matrix, self.n_joints, "joint_matrix")
        if joint_matrix.ndim != 2:
            raise ValueError(f"joint_matrix: expected shape (N, {self.n_joints}), got {joint_matrix.shape}")

        maps = self._batch_maps()
        out = np.empty((len(joint_matrix), 8))
        for start in range(0, len(joint_matrix), BATCH_BLOCK):
            block = joint_matrix[start:start + BATCH_BLOCK]
            pose = np.broadcast_to(self._constants[0], (len(block), 8))
            for column, kind, offset, matrix in zip(block.T, self.joint_types, self.joint_offsets, maps, strict=True):
                both = pose @ matrix   # (B, 16): pose·K_i and pose·u·K_i
                half = 0.5 * (column + offset)
                if kind == REVOLUTE:
                    pose = np.cos(half)[:, None] * both[:, :8] + np.sin(half)[:, None] * both[:, 8:]
                else:
                    pose = both[:, :8] + half[:, None] * both[:, 8:]
            out[start:start + BATCH_BLOCK] = pose
        return out

    def _batch_maps(self) -> tuple[np.ndarray, ...]:
        """Per joint i the (8, 16) matrix of X ↦ (X·K_i, X·u·K_i) on coefficient rows (cached): right-multiplication
        by a constant is linear, so a joint of fk_batch is one matmul of its (B, 8) running products, then
        X·J_i·K_i = cos(h)·X·K_i + sin(h)·X·k·K_i (revolute: rz(2h) = cos h + k sin h) or X·K_i + h·X·εk·K_i
        (prismatic: tz(2h) = 1 + εk·h), h half the joint value. ~40 numpy calls per block instead of ~900 for the
        coefficient products written out on arrays."""
        if self._maps is None:
            identity = [tuple(row) for row in np.eye(8)]
            maps = []
            for kind, constant in zip(self.joint_types, self._constants[1:], strict=True):
                unit = _K if kind == REVOLUTE else _EPSILON_K
                maps.append(np.array([multiply_coefficients(e, constant)
                                      + multiply_coefficients(multiply_coefficients(e, unit), constant)
                                      for e in identity]))
            self._maps = tuple(maps)
        return self._maps

    def frames(self, q: ArrayLike) -> np.ndarray:
        """(n + 1, 8) frames 0..n in the base frame: DH frames for DH chains, the partial products of exponentials
        for axis chains (frame 0 = base); frame n is always the end pose, tool included."""
        q = self.check_q(q)
        running = self._accumulate([float(v) for v in q])
        return np.array([multiply_coefficients(pose, offset)
                         for pose, offset in zip(running, self._frame_offsets, strict=True)])

    def joint_axes(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(directions, points), each (n, 3): every joint's unit axis and a point on it, base frame, at q."""
        q = self.check_q(q)
        pose = self._constants[0]
        directions, points = [], []
        for i, value in enumerate(q):
            # The axis of J_i is the local z axis of the running product just before J_i, through its origin.
            directions.append(z_axis_coefficients(pose))
            points.append(translation_coefficients(pose))
            pose = multiply_coefficients(self._after_joint(i, pose, float(value)), self._constants[i + 1])
        return np.array(directions), np.array(points)

    def product_form(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(constants (n + 1, 8), revolute (n,) bool, offsets (n,)): the chain as arrays, for compiled kernels.

        σ(q) = K_0·J_1(q_1 + offset_1)·K_1·…·J_n(q_n + offset_n)·K_n, J_i = rz (revolute) or tz. Read-only, built once.
        """
        if self._form is None:
            arrays = (np.array(self._constants), np.array([kind == REVOLUTE for kind in self.joint_types]),
                      np.array(self.joint_offsets))
            for array in arrays:
                array.flags.writeable = False
            self._form = arrays
        return self._form

    def home(self) -> DualQuaternion:
        """End pose at q = 0."""
        return self.fk(np.zeros(self.n_joints))
