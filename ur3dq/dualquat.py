"""DualQuaternion: a rigid transform σ = r + ε·½·t·r whose real and dual parts are ``pyquaternion.Quaternion``s.

Conventions (docs/conventions.md): Hamilton quaternions in (w, x, y, z) order; rotate,
then translate in the parent frame; σ_0→2 = σ_0→1 · σ_1→2; σ and −σ are the same pose; metres and radians.

The eight coefficients are kept as plain floats so single operations (composition in forward kinematics) stay
cheap; the ``pyquaternion`` objects are built only when ``.real`` / ``.dual`` / ``.rotation`` are asked for.
Conversions and the screw log/exp go through the array kernels of :mod:`ur3dq.dqarray`, so each formula exists once.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from pyquaternion import Quaternion

from ur3dq import dqarray
from ur3dq.dqarray import UNIT_TOLERANCE


def _quaternion_coefficients(value: Quaternion | npt.ArrayLike, name: str) -> tuple[float, ...]:
    """Four finite floats (w, x, y, z) from a Quaternion or a sequence of 4 numbers; ValueError naming ``name``."""
    if isinstance(value, Quaternion):
        value = value.q
    coefficients = dqarray.as_array(value, 4, name)
    if coefficients.shape != (4,):
        raise ValueError(f"{name}: expected 4 coefficients (w, x, y, z), got shape {coefficients.shape}")
    return tuple(float(c) for c in coefficients)


def _vector(value: npt.ArrayLike, size: int, name: str) -> np.ndarray:
    """A finite float vector of exactly ``size`` values; ValueError naming ``name`` otherwise."""
    vector = dqarray.as_array(value, size, name)
    if vector.shape != (size,):
        raise ValueError(f"{name}: expected {size} values, got shape {vector.shape}")
    return vector


def multiply_quaternion_coefficients(a: tuple[Any, ...], b: tuple[Any, ...]) -> tuple[Any, ...]:
    """Hamilton product a·b of two (w, x, y, z) 4-tuples; floats or broadcastable arrays."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def conjugate_coefficients(c: tuple[Any, ...]) -> tuple[Any, ...]:
    """r* + ε d* of an 8-tuple (quaternion conjugate of both parts): the inverse of a unit dual quaternion."""
    return (c[0], -c[1], -c[2], -c[3], c[4], -c[5], -c[6], -c[7])


def multiply_coefficients(a: tuple[Any, ...], b: tuple[Any, ...]) -> tuple[Any, ...]:
    """Product of two 8-tuples (ra + ε da)(rb + ε db) = ra rb + ε(ra db + da rb); floats or broadcastable arrays."""
    aw, ax, ay, az, adw, adx, ady, adz = a
    bw, bx, by, bz, bdw, bdx, bdy, bdz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bdw - ax * bdx - ay * bdy - az * bdz + adw * bw - adx * bx - ady * by - adz * bz,
        aw * bdx + ax * bdw + ay * bdz - az * bdy + adw * bx + adx * bw + ady * bz - adz * by,
        aw * bdy - ax * bdz + ay * bdw + az * bdx + adw * by - adx * bz + ady * bw + adz * bx,
        aw * bdz + ax * bdy - ay * bdx + az * bdw + adw * bz + adx * by - ady * bx + adz * bw,
    )


def translation_coefficients(c: tuple[Any, ...]) -> tuple[Any, ...]:
    """t = vec(2·d·r*) of a unit 8-tuple (the vector part: no 4-vector is built for the discarded scalar), a 3-tuple;
    floats or broadcastable arrays."""
    rw, rx, ry, rz, dw, dx, dy, dz = c
    return (2.0 * (-dw * rx + dx * rw - dy * rz + dz * ry), 2.0 * (-dw * ry + dx * rz + dy * rw - dz * rx),
            2.0 * (-dw * rz - dx * ry + dy * rx + dz * rw))


def z_axis_coefficients(c: tuple[Any, ...]) -> tuple[Any, ...]:
    """The frame's z axis r·k·r* (the rotation matrix's third column) of a unit 8-tuple (or 4-tuple), a 3-tuple."""
    w, x, y, z = c[0], c[1], c[2], c[3]
    return 2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)


class DualQuaternion:
    """A dual quaternion real + ε·dual; as a pose, σ = r + ε·½·t·r (rotate, then translate, parent frame).

    Examples
    --------
    >>> from pyquaternion import Quaternion
    >>> turn = DualQuaternion.from_rotation_translation(Quaternion(axis=[0, 0, 1], angle=1.5707963267948966))
    >>> shift = DualQuaternion.from_translation([0.1, 0.0, 0.0])
    >>> (turn * shift).translation.round(6).tolist()         # shift in the turned frame
    [0.0, 0.1, 0.0]
    >>> (shift * turn).transform_point([0.1, 0.0, 0.0]).round(6).tolist()
    [0.1, 0.1, 0.0]
    >>> (turn * shift).is_close(-(turn * shift))              # σ and −σ are the same pose
    True
    """

    __slots__ = ("_c",)

    def __init__(self, real: Quaternion | npt.ArrayLike, dual: Quaternion | npt.ArrayLike | None = None) -> None:
        """Build from the real and dual parts (``Quaternion`` or 4 numbers each); ``dual`` defaults to zero."""
        real_c = _quaternion_coefficients(real, "real")
        dual_c = (0.0, 0.0, 0.0, 0.0) if dual is None else _quaternion_coefficients(dual, "dual")
        self._c = real_c + dual_c

    @classmethod
    def _from_tuple(cls, coefficients: tuple[float, ...]) -> DualQuaternion:
        """Wrap 8 floats already known to be finite (internal fast path, no validation)."""
        instance = object.__new__(cls)
        instance._c = coefficients
        return instance

    # ------------------------------------------------------------------------------------------- constructors
    @classmethod
    def identity(cls) -> DualQuaternion:
        """The identity transform 1 + ε·0."""
        return cls._from_tuple((1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))

    @classmethod
    def from_rotation_translation(cls, rotation: Quaternion | npt.ArrayLike,
                                  translation: npt.ArrayLike = (0.0, 0.0, 0.0)) -> DualQuaternion:
        """σ = r + ε·½·t·r: rotate by unit quaternion ``rotation``, then translate by ``translation`` (parent)."""
        r = _quaternion_coefficients(rotation, "rotation")
        t = _vector(translation, 3, "translation")
        return cls.from_array(dqarray.from_rotation_translation(np.array(r), t))

    @classmethod
    def from_translation(cls, translation: npt.ArrayLike) -> DualQuaternion:
        """The pure translation 1 + ε·½·t."""
        return cls.from_rotation_translation((1.0, 0.0, 0.0, 0.0), translation)

    @classmethod
    def from_axis_angle(cls, axis: npt.ArrayLike, angle: float) -> DualQuaternion:
        """A pure rotation by ``angle`` radians about ``axis`` (any non-zero length) through the origin."""
        axis = _vector(axis, 3, "axis")
        norm = float(np.linalg.norm(axis))
        if norm < 1e-12:
            raise ValueError("axis: must not be the zero vector")
        angle = float(_vector([angle], 1, "angle")[0])
        return cls.from_rotation_translation(dqarray.rotation_vector_to_quaternion(axis / norm * angle))

    @classmethod
    def from_array(cls, coefficients: npt.ArrayLike) -> DualQuaternion:
        """From the 8 coefficients [rw rx ry rz dw dx dy dz] (real part, then dual part)."""
        array = _vector(coefficients, 8, "coefficients")
        return cls._from_tuple(tuple(float(c) for c in array))

    @classmethod
    def from_matrix(cls, matrix: npt.ArrayLike, tolerance: float = UNIT_TOLERANCE) -> DualQuaternion:
        """From a 4×4 homogeneous transform.

        From a 4×4 homogeneous transform (rotation block orthonormal within ``tolerance``, det +1, last row
        0 0 0 1); the quaternion is extracted (Shepperd) and normalised, so a looser tolerance admits rounded
        printouts at about their print precision."""
        matrix = dqarray.as_array(matrix, (4, 4), "matrix")
        if matrix.shape != (4, 4):
            raise ValueError(f"matrix: expected a 4×4 matrix, got shape {matrix.shape}")
        return cls.from_array(dqarray.from_matrix(matrix, tolerance))

    @classmethod
    def from_ur_pose(cls, pose: npt.ArrayLike) -> DualQuaternion:
        """From a UR pose vector [x, y, z, rx, ry, rz] (metres, rotation vector in radians)."""
        return cls.from_array(dqarray.from_ur_pose(_vector(pose, 6, "pose")))

    @classmethod
    def from_pair(cls, q: Quaternion | npt.ArrayLike, p: Quaternion | npt.ArrayLike,
                  tolerance: float = UNIT_TOLERANCE) -> DualQuaternion:
        """From the thesis pair (q, p): unit rotation q, position p (3 numbers or a pure ``Quaternion``)."""
        if isinstance(p, Quaternion):
            if abs(p.w) > tolerance:
                raise ValueError(f"p: a position quaternion must be pure (w = 0), got w = {p.w!r}")
            p = p.vector
        r = np.array(_quaternion_coefficients(q, "q"))
        norm = float(np.linalg.norm(r))
        if abs(norm - 1.0) > tolerance:
            raise ValueError(f"q: not a unit quaternion (norm {norm!r})")
        return cls.from_rotation_translation(r / norm, _vector(p, 3, "p"))

    @classmethod
    def from_thesis_line(cls, line: str, tolerance: float = UNIT_TOLERANCE) -> DualQuaternion:
        """Parse the thesis' 8-coefficient line ``q.w q.x q.y q.z 0 p.x p.y p.z`` (spaces or commas).

        ``tolerance`` bounds |q| − 1 and the 5th coefficient; lines printed with few decimals need a larger one
        (q is then renormalised).
        """
        if not isinstance(line, str):
            raise ValueError(f"line: expected a string, got {type(line).__name__}")
        fields = line.replace(",", " ").split()
        if len(fields) != 8:
            raise ValueError(f"line: expected 8 coefficients 'q.w q.x q.y q.z 0 p.x p.y p.z', got {len(fields)}")
        try:
            values = [float(field) for field in fields]
        except ValueError as exc:
            raise ValueError(f"line: not a number in {line.strip()!r}") from exc
        if abs(values[4]) > tolerance:
            raise ValueError(f"line: 5th coefficient (p.w) must be 0 in the pair form, got {values[4]!r}")
        return cls.from_pair(values[:4], values[5:], tolerance=tolerance)

    # --------------------------------------------------------------------------------------------- accessors
    @property
    def real(self) -> Quaternion:
        """The real part (the rotation r of a pose) as a ``pyquaternion.Quaternion``."""
        return Quaternion(*self._c[:4])

    @property
    def dual(self) -> Quaternion:
        """The dual part (½·t·r for a pose) as a ``pyquaternion.Quaternion``."""
        return Quaternion(*self._c[4:])

    @property
    def rotation(self) -> Quaternion:
        """The rotation quaternion r (the real part)."""
        return self.real

    @property
    def translation(self) -> np.ndarray:
        """Translation t = 2·dual·real* in the parent frame, metres."""
        return np.array(translation_coefficients(self._c))

    def to_array(self) -> np.ndarray:
        """The 8 coefficients [rw rx ry rz dw dx dy dz]."""
        return np.array(self._c)

    def to_matrix(self) -> np.ndarray:
        """The 4×4 homogeneous transform (requires a unit dual quaternion)."""
        return dqarray.to_matrix(self._unit_array("self"))

    def to_ur_pose(self) -> np.ndarray:
        """UR pose vector [x, y, z, rx, ry, rz], rotation-vector angle in [0, π] (requires a unit σ)."""
        return dqarray.to_ur_pose(self._unit_array("self"))

    def to_pair(self) -> tuple[Quaternion, np.ndarray]:
        """The thesis pair (q, p): rotation quaternion q and position p (3 numbers)."""
        self._unit_array("self")
        return self.real, self.translation

    def to_thesis_line(self) -> str:
        """The thesis' text line ``q.w q.x q.y q.z 0 p.x p.y p.z`` with round-trip precision."""
        q, p = self.to_pair()
        return " ".join(repr(float(v)) for v in (*q.q, 0.0, *p))

    def _unit_array(self, name: str) -> np.ndarray:
        """The coefficients as an array, after checking this is a unit dual quaternion (a rigid transform)."""
        return dqarray.check_unit(np.array(self._c), name)

    # -------------------------------------------------------------------------------------------------- algebra
    def __mul__(self, other: DualQuaternion) -> DualQuaternion:
        """Composition self·other (σ_0→2 = σ_0→1 · σ_1→2); a number scales both parts."""
        if isinstance(other, DualQuaternion):
            return DualQuaternion._from_tuple(multiply_coefficients(self._c, other._c))
        if isinstance(other, (int, float)) and math.isfinite(other):
            return DualQuaternion._from_tuple(tuple(c * other for c in self._c))
        return NotImplemented

    def __rmul__(self, other: object) -> DualQuaternion:
        """Scalar times dual quaternion."""
        if isinstance(other, (int, float)) and math.isfinite(other):
            return DualQuaternion._from_tuple(tuple(c * other for c in self._c))
        return NotImplemented

    def __add__(self, other: DualQuaternion) -> DualQuaternion:
        """Coefficient-wise sum (the algebra's addition, not a pose operation)."""
        if not isinstance(other, DualQuaternion):
            return NotImplemented
        return DualQuaternion._from_tuple(tuple(a + b for a, b in zip(self._c, other._c)))

    def __neg__(self) -> DualQuaternion:
        """−σ: the same pose, the other sign."""
        return DualQuaternion._from_tuple(tuple(-c for c in self._c))

    def __eq__(self, other: object) -> bool:
        """Exact coefficient equality (use :meth:`is_close` to compare poses, which accepts σ ≡ −σ)."""
        if not isinstance(other, DualQuaternion):
            return NotImplemented
        return self._c == other._c

    def __hash__(self) -> int:
        """Hash of the coefficients, consistent with ``==`` (immutable value)."""
        return hash(self._c)

    def __repr__(self) -> str:
        r = " ".join(f"{c:+.6f}" for c in self._c[:4])
        d = " ".join(f"{c:+.6f}" for c in self._c[4:])
        return f"DualQuaternion([{r}] + ε[{d}])"

    def conjugate(self) -> DualQuaternion:
        """Quaternion conjugate r* + ε·d* (the inverse of a unit dual quaternion)."""
        w, x, y, z, dw, dx, dy, dz = self._c
        return DualQuaternion._from_tuple((w, -x, -y, -z, dw, -dx, -dy, -dz))

    def dual_conjugate(self) -> DualQuaternion:
        """Dual conjugate r − ε·d."""
        w, x, y, z, dw, dx, dy, dz = self._c
        return DualQuaternion._from_tuple((w, x, y, z, -dw, -dx, -dy, -dz))

    def combined_conjugate(self) -> DualQuaternion:
        """Combined conjugate r* − ε·d*."""
        w, x, y, z, dw, dx, dy, dz = self._c
        return DualQuaternion._from_tuple((w, -x, -y, -z, -dw, dx, dy, dz))

    def inverse(self) -> DualQuaternion:
        """σ⁻¹ = r⁻¹ − ε·r⁻¹·d·r⁻¹ (any invertible dual quaternion, i.e. real part ≠ 0)."""
        norm2 = sum(c * c for c in self._c[:4])
        if norm2 < 1e-24:
            raise ValueError("self: real part is zero, the dual quaternion has no inverse")
        w, x, y, z = self._c[:4]
        r_inv = (w / norm2, -x / norm2, -y / norm2, -z / norm2, 0.0, 0.0, 0.0, 0.0)
        dual_only = (0.0, 0.0, 0.0, 0.0) + self._c[4:]
        # With ε² = 0: (r + εd)⁻¹ = r⁻¹ − ε r⁻¹ d r⁻¹; the product below carries −r⁻¹ d r⁻¹ in its dual half.
        correction = multiply_coefficients(multiply_coefficients(r_inv, dual_only), r_inv)
        return DualQuaternion._from_tuple(r_inv[:4] + tuple(-c for c in correction[4:]))

    def normalised(self) -> DualQuaternion:
        """The nearest unit dual quaternion: real part scaled to norm 1, dual part made orthogonal (keeps t)."""
        return DualQuaternion.from_array(dqarray.normalise(np.array(self._c)))

    def is_unit(self, tolerance: float = UNIT_TOLERANCE) -> bool:
        """True when |r| = 1 and r·d = 0 within ``tolerance`` (i.e. this is a rigid transform)."""
        try:
            dqarray.check_unit(np.array(self._c), "self", tolerance)
        except ValueError:
            return False
        return True

    def transform_point(self, point: npt.ArrayLike) -> np.ndarray:
        """The point (3 numbers, child frame) expressed in the parent frame: r·p·r* + t."""
        return dqarray.transform_points(self._unit_array("self"), _vector(point, 3, "point"))

    def log(self) -> np.ndarray:
        """Screw logarithm [ω, v] (6 numbers): σ = exp(ω + ε·v), ω = ½·angle·axis (see dqarray.log)."""
        return dqarray.log(self._unit_array("self"))

    @classmethod
    def exp(cls, screw: npt.ArrayLike) -> DualQuaternion:
        """The unit dual quaternion exp(ω + ε·v) of 6 numbers [ω, v] (the inverse of :meth:`log`)."""
        return cls.from_array(dqarray.exp(_vector(screw, 6, "screw")))

    def power(self, exponent: float) -> DualQuaternion:
        """σ^τ = exp(τ·log σ): the screw motion's fraction τ (shorter screw, σ ≡ −σ)."""
        exponent = float(_vector([exponent], 1, "exponent")[0])
        return DualQuaternion.exp(exponent * self.log())

    def sclerp(self, other: DualQuaternion, tau: float) -> DualQuaternion:
        """Screw linear interpolation self·(self*·other)^τ: τ = 0 gives self, τ = 1 gives other (as a pose)."""
        if not isinstance(other, DualQuaternion):
            raise ValueError(f"other: expected a DualQuaternion, got {type(other).__name__}")
        tau = float(_vector([tau], 1, "tau")[0])
        return DualQuaternion.from_array(
            dqarray.sclerp(self._unit_array("self"), other._unit_array("other"), tau)
        )

    def distance(self, other: DualQuaternion) -> tuple[float, float]:
        """(metres, radians): translation distance and rotation angle between two poses (σ ≡ −σ)."""
        if not isinstance(other, DualQuaternion):
            raise ValueError(f"other: expected a DualQuaternion, got {type(other).__name__}")
        metres, radians = dqarray.pose_distance(self._unit_array("self"), other._unit_array("other"))
        return float(metres), float(radians)

    def is_close(self, other: DualQuaternion, tol_m: float = 1e-9, tol_rad: float = 1e-9) -> bool:
        """True when the poses differ by at most ``tol_m`` metres and ``tol_rad`` radians (σ ≡ −σ)."""
        metres, radians = self.distance(other)
        return metres <= tol_m and radians <= tol_rad
