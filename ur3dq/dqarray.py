"""Vectorised dual-quaternion kernels over ``(..., 8)`` numpy arrays.

Layout of the last axis: ``[rw, rx, ry, rz, dw, dx, dy, dz]`` — the real part (the rotation r) then the dual part,
Hamilton quaternions in (w, x, y, z) order. A rigid transform is σ = r + ε·½·t·r (rotate, then translate in the
parent frame); composition is σ_0→2 = σ_0→1 · σ_1→2; σ and −σ are the same transform.

Every public function validates its input (shape, finite values) and raises ``ValueError`` naming the argument;
the leading ``...`` axes broadcast like numpy.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ur3dq.real_numbers import real_array

#: How far from 1 a rotation quaternion's norm may be before it is refused as "not a unit rotation".
UNIT_TOLERANCE = 1e-6

# Below this |vector part| (= sin of the half angle) the closed forms switch to Taylor series, whose truncation
# error there is far below double precision.
_SMALL = 1e-4


def as_array(value: npt.ArrayLike, last: int | tuple[int, ...], name: str) -> np.ndarray:
    """Convert ``value`` to a finite float array whose trailing shape is ``last``; ValueError naming ``name``."""
    try:
        array = real_array(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected numbers, got {value!r}") from exc
    trailing = (last,) if isinstance(last, int) else tuple(last)
    if array.ndim < len(trailing) or array.shape[array.ndim - len(trailing):] != trailing:
        raise ValueError(f"{name}: expected shape (..., {', '.join(map(str, trailing))}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return array


def sincos_of_half(half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sin 2h, cos 2h) of an array of half angles h, IN PLACE, from t = tan h: sin = t·u, cos = u − 1, u = 2/(1+t²).

    Why tan: on CPUs with AVX-512 numpy's float64 tan has a SIMD loop and sin/cos do not, so one tan plus a few
    multiplications costs far less than sin + cos (docs/performance.md); where tan has no SIMD loop this costs
    about one sin instead of two. The identities stay accurate to a few ulp, also where t is huge (2h ≈ π).
    ``half`` is overwritten (callers pass a temporary they could scale for free).
    """
    tangent = np.tan(half, out=half)
    scale = np.multiply(tangent, tangent)
    scale += 1.0
    np.divide(2.0, scale, out=scale)
    sine = np.multiply(tangent, scale, out=tangent)
    scale -= 1.0
    return sine, scale


def sincos(angle: npt.ArrayLike) -> tuple[Any, Any]:
    """(sin, cos) of an angle array (see :func:`sincos_of_half`; ``angle`` is left unchanged)."""
    shape = np.shape(angle)
    sine, cosine = sincos_of_half(np.multiply(np.atleast_1d(angle), 0.5))
    return sine.reshape(shape), cosine.reshape(shape)


# ----------------------------------------------------------------------------------------------- quaternions
def quaternion_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a·b of (..., 4) quaternions in (w, x, y, z) order (no validation: an inner kernel)."""
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        (
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ),
        axis=-1,
    )


def quaternion_conjugate(q: np.ndarray) -> np.ndarray:
    """Quaternion conjugate (w, −x, −y, −z) of (..., 4) quaternions (no validation: an inner kernel)."""
    return np.asarray(q * np.array([1.0, -1.0, -1.0, -1.0]))


def rotation_vector_to_quaternion(rotation_vector: npt.ArrayLike) -> np.ndarray:
    """Unit quaternion (..., 4) of a rotation vector (..., 3) = axis·angle in radians (any angle, incl. 0)."""
    v = as_array(rotation_vector, 3, "rotation_vector")
    angle = np.linalg.norm(v, axis=-1)
    half = 0.5 * angle
    small = angle < _SMALL
    # sin(angle/2)/angle, with its Taylor series near 0 where the quotient loses precision.
    factor = np.where(small, 0.5 - angle * angle / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate((np.cos(half)[..., None], factor[..., None] * v), axis=-1)


def quaternion_to_rotation_vector(q: npt.ArrayLike) -> np.ndarray:
    """Rotation vector (..., 3), angle in [0, π], of (..., 4) unit quaternions (q ≡ −q, handles 0 and π)."""
    q = as_array(q, 4, "quaternion")
    sign = np.where(q[..., 0] < 0.0, -1.0, 1.0)
    w = sign * q[..., 0]
    v = sign[..., None] * q[..., 1:]
    n = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(n, w)
    small = n < _SMALL
    # angle / n, its limit near n = 0 being 2/w·(1 − n²/(3w²)) (w ≈ 1 there).
    factor = np.where(small, 2.0 / np.where(small, w, 1.0) * (1.0 - n * n / 3.0), angle / np.where(small, 1.0, n))
    return np.asarray(factor[..., None] * v)


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """3×3 rotation matrices (..., 3, 3) of (..., 4) unit quaternions (no validation: an inner kernel)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def matrix_to_quaternion(rotation: npt.ArrayLike) -> np.ndarray:
    """Unit quaternion (..., 4) with w ≥ 0 of (..., 3, 3) rotation matrices (Shepperd's stable branch choice)."""
    m = as_array(rotation, (3, 3), "rotation")
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    trace = m00 + m11 + m22
    # Each candidate is 4·(largest component)·q; dividing by the largest keeps the division well conditioned.
    candidates = np.stack(
        (
            np.stack((1 + trace, m21 - m12, m02 - m20, m10 - m01), axis=-1),
            np.stack((m21 - m12, 1 + m00 - m11 - m22, m01 + m10, m02 + m20), axis=-1),
            np.stack((m02 - m20, m01 + m10, 1 - m00 + m11 - m22, m12 + m21), axis=-1),
            np.stack((m10 - m01, m02 + m20, m12 + m21, 1 - m00 - m11 + m22), axis=-1),
        ),
        axis=-2,
    )
    branch = np.argmax(np.stack((trace, m00, m11, m22), axis=-1), axis=-1)
    chosen = np.take_along_axis(candidates, branch[..., None, None], axis=-2)[..., 0, :]
    q = chosen / np.linalg.norm(chosen, axis=-1, keepdims=True)
    return np.asarray(np.where(q[..., :1] < 0.0, -q, q))


# ------------------------------------------------------------------------------------------ dual quaternions
def multiply(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Dual-quaternion product a·b of (..., 8) arrays: (ra + ε da)(rb + ε db) = ra rb + ε(ra db + da rb)."""
    a = as_array(a, 8, "a")
    b = as_array(b, 8, "b")
    return multiply_unchecked(a, b)


def multiply_unchecked(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dual-quaternion product a·b of (..., 8) float arrays, without validation (for hot inner loops)."""
    ra, da = a[..., :4], a[..., 4:]
    rb, db = b[..., :4], b[..., 4:]
    real = quaternion_multiply(ra, rb)
    dual = quaternion_multiply(ra, db) + quaternion_multiply(da, rb)
    return np.concatenate((real, dual), axis=-1)


def conjugate(a: npt.ArrayLike) -> np.ndarray:
    """Quaternion conjugate r* + ε d* of (..., 8) arrays (the inverse of a unit dual quaternion)."""
    return np.asarray(as_array(a, 8, "a") * np.array([1.0, -1.0, -1.0, -1.0, 1.0, -1.0, -1.0, -1.0]))


def dual_conjugate(a: npt.ArrayLike) -> np.ndarray:
    """Dual conjugate r − ε d of (..., 8) arrays."""
    return np.asarray(as_array(a, 8, "a") * np.array([1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0]))


def combined_conjugate(a: npt.ArrayLike) -> np.ndarray:
    """Combined (quaternion and dual) conjugate r* − ε d* of (..., 8) arrays."""
    return np.asarray(as_array(a, 8, "a") * np.array([1.0, -1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0]))


def from_rotation_translation(rotation: npt.ArrayLike, translation: npt.ArrayLike) -> np.ndarray:
    """(..., 8) σ = r + ε·½·t·r from unit quaternions r (..., 4) and translations t (..., 3) in the parent frame."""
    r = as_array(rotation, 4, "rotation")
    t = as_array(translation, 3, "translation")
    norm = np.linalg.norm(r, axis=-1)
    if np.any(np.abs(norm - 1.0) > UNIT_TOLERANCE):
        raise ValueError(f"rotation: not a unit quaternion (norm {norm.flat[np.argmax(np.abs(norm - 1.0))]!r})")
    r = r / norm[..., None]
    shape = np.broadcast_shapes(r.shape[:-1], t.shape[:-1])
    r = np.broadcast_to(r, shape + (4,))
    t = np.broadcast_to(t, shape + (3,))
    pure_t = np.concatenate((np.zeros(t.shape[:-1] + (1,)), t), axis=-1)
    return np.concatenate((r, 0.5 * quaternion_multiply(pure_t, r)), axis=-1)


def rotation(a: npt.ArrayLike) -> np.ndarray:
    """Rotation quaternions (..., 4): the real parts of (..., 8) dual quaternions."""
    return np.asarray(as_array(a, 8, "a")[..., :4].copy())


def translation(a: npt.ArrayLike) -> np.ndarray:
    """Translations (..., 3) t = 2·d·r* of unit dual quaternions (..., 8), in the parent frame."""
    a = as_array(a, 8, "a")
    return translation_unchecked(a)


def translation_unchecked(a: np.ndarray) -> np.ndarray:
    """t = 2·d·r* (vector part) of (..., 8) unit dual quaternions, without validation."""
    rw, rx, ry, rz = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    dw, dx, dy, dz = a[..., 4], a[..., 5], a[..., 6], a[..., 7]
    # Vector part of 2·(d·r*), written out so no 4-vector is built for the discarded scalar part.
    return 2.0 * np.stack(
        (
            -dw * rx + dx * rw - dy * rz + dz * ry,
            -dw * ry + dx * rz + dy * rw - dz * rx,
            -dw * rz - dx * ry + dy * rx + dz * rw,
        ),
        axis=-1,
    )


def check_unit(a: npt.ArrayLike, name: str = "a", tolerance: float = UNIT_TOLERANCE) -> np.ndarray:
    """Return ``a`` as a (..., 8) array after checking |r| = 1 and r·d = 0 within ``tolerance``; else ValueError."""
    a = as_array(a, 8, name)
    real = a[..., :4]
    # einsum: one pass per row for these length-4 dot products (norm and sum reduce far slower over short rows).
    norm_error = np.abs(np.sqrt(np.einsum("...i,...i->...", real, real)) - 1.0)
    if np.any(norm_error > tolerance):
        raise ValueError(f"{name}: not a unit dual quaternion (|real| differs from 1 by {norm_error.max():.3g})")
    orthogonality = np.abs(np.einsum("...i,...i->...", real, a[..., 4:]))
    if np.any(orthogonality > tolerance):
        raise ValueError(f"{name}: not a unit dual quaternion (real·dual = {orthogonality.max():.3g}, must be 0)")
    return a


def normalise(a: npt.ArrayLike) -> np.ndarray:
    """Nearest unit dual quaternions (..., 8): r/|r|, and the dual part made orthogonal to r (keeps t)."""
    a = as_array(a, 8, "a")
    norm = np.linalg.norm(a[..., :4], axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise ValueError("a: real part is zero; a dual quaternion with no rotation part cannot be normalised")
    r = a[..., :4] / norm
    d = a[..., 4:] / norm
    d = d - np.sum(r * d, axis=-1, keepdims=True) * r
    return np.concatenate((r, d), axis=-1)


def canonical(a: npt.ArrayLike) -> np.ndarray:
    """The representative of σ ≡ −σ (..., 8) whose real w is ≥ 0 (for hashing, display and logs)."""
    a = as_array(a, 8, "a")
    return np.where(a[..., :1] < 0.0, -a, a)


def transform_points(a: npt.ArrayLike, points: npt.ArrayLike) -> np.ndarray:
    """Points (..., 3) mapped by unit dual quaternions (..., 8): r·p·r* + t."""
    a = as_array(a, 8, "a")
    p = as_array(points, 3, "points")
    rotated = np.einsum("...ij,...j->...i", quaternion_to_matrix(a[..., :4]), p)
    return np.asarray(rotated + translation_unchecked(a))


def to_matrix(a: npt.ArrayLike) -> np.ndarray:
    """4×4 homogeneous matrices (..., 4, 4) of (..., 8) unit dual quaternions."""
    a = as_array(a, 8, "a")
    shape = a.shape[:-1]
    matrix = np.zeros(shape + (4, 4))
    matrix[..., :3, :3] = quaternion_to_matrix(a[..., :4])
    matrix[..., :3, 3] = translation_unchecked(a)
    matrix[..., 3, 3] = 1.0
    return matrix


def from_matrix(matrix: npt.ArrayLike, tolerance: float = UNIT_TOLERANCE) -> np.ndarray:
    """(..., 8) unit dual quaternions of 4×4 homogeneous matrices; ValueError if the 3×3 block is no rotation."""
    m = as_array(matrix, (4, 4), "matrix")
    if np.any(np.abs(m[..., 3, :] - np.array([0.0, 0.0, 0.0, 1.0])) > tolerance):
        raise ValueError("matrix: bottom row must be [0, 0, 0, 1]")
    rot = m[..., :3, :3]
    gram_error = np.abs(np.einsum("...ji,...jk->...ik", rot, rot) - np.eye(3)).max(initial=0.0)
    if gram_error > tolerance:
        raise ValueError(f"matrix: the 3×3 block is not orthonormal (RᵀR differs from I by {gram_error:.3g})")
    if np.any(np.linalg.det(rot) < 0.0):
        raise ValueError("matrix: the 3×3 block is a reflection (determinant −1), not a rotation")
    return from_rotation_translation(matrix_to_quaternion(rot), m[..., :3, 3])


def to_ur_pose(a: npt.ArrayLike) -> np.ndarray:
    """UR pose vectors (..., 6) [x, y, z, rx, ry, rz] (rotation vector, angle in [0, π]) of unit (..., 8)."""
    a = as_array(a, 8, "a")
    return np.concatenate((translation_unchecked(a), quaternion_to_rotation_vector(a[..., :4])), axis=-1)


def from_ur_pose(pose: npt.ArrayLike) -> np.ndarray:
    """(..., 8) unit dual quaternions of UR pose vectors (..., 6) [x, y, z, rx, ry, rz] (metres, rotation vector)."""
    p = as_array(pose, 6, "pose")
    return from_rotation_translation(rotation_vector_to_quaternion(p[..., 3:]), p[..., :3])


def pose_distance(a: npt.ArrayLike, b: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(metres, radians) between unit (..., 8) poses: |ta − tb| and the angle of ra*·rb in [0, π] (σ ≡ −σ)."""
    a = as_array(a, 8, "a")
    b = as_array(b, 8, "b")
    metres = np.linalg.norm(translation_unchecked(a) - translation_unchecked(b), axis=-1)
    relative = quaternion_multiply(quaternion_conjugate(a[..., :4]), b[..., :4])
    radians = 2.0 * np.arctan2(np.linalg.norm(relative[..., 1:], axis=-1), np.abs(relative[..., 0]))
    return metres, radians


def log(a: npt.ArrayLike) -> np.ndarray:
    """Screw logarithm (..., 6) [ω, v] of unit (..., 8): σ = exp(ω + ε v), ω = ½·angle·axis, on the w ≥ 0 sheet.

    For a pure translation t the result is [0, ½t]; for a pure rotation it is [½θn, 0] only when the axis passes
    through the origin. ``exp(log(σ))`` is σ or −σ (the same pose).
    """
    a = canonical(a)
    r_w, r_v = a[..., 0], a[..., 1:4]
    s_w, s_v = a[..., 4], a[..., 5:8]
    n = np.linalg.norm(r_v, axis=-1)
    half_angle = np.arctan2(n, r_w)
    small = n < _SMALL
    safe_n = np.where(small, 1.0, n)
    h2 = half_angle * half_angle
    # k = h / sin h and c = (cos h − k) / sin² h, with their Taylor series near h = 0.
    k = np.where(small, 1.0 + h2 / 6.0, half_angle / safe_n)
    c = np.where(small, -2.0 / 3.0 - h2 / 5.0, (r_w - k) / (safe_n * safe_n))
    omega = k[..., None] * r_v
    s_dot_r = np.sum(s_v * r_v, axis=-1)
    v = k[..., None] * s_v + (c * s_dot_r - s_w)[..., None] * r_v
    return np.concatenate((omega, v), axis=-1)


def exp(screw: npt.ArrayLike) -> np.ndarray:
    """Unit dual quaternions (..., 8) exp(ω + ε v) of (..., 6) [ω, v]: the inverse of :func:`log`."""
    x = as_array(screw, 6, "screw")
    omega, v = x[..., :3], x[..., 3:]
    h = np.linalg.norm(omega, axis=-1)
    small = h < _SMALL
    safe_h = np.where(small, 1.0, h)
    h2 = h * h
    # sinc(h) = sin h / h and e = (cos h − sinc h) / h², with their Taylor series near 0.
    sinc = np.where(small, 1.0 - h2 / 6.0 + h2 * h2 / 120.0, np.sin(h) / safe_h)
    e = np.where(small, -1.0 / 3.0 + h2 / 30.0, (np.cos(h) - sinc) / (safe_h * safe_h))
    omega_dot_v = np.sum(omega * v, axis=-1)
    real = np.concatenate((np.cos(h)[..., None], sinc[..., None] * omega), axis=-1)
    dual = np.concatenate(
        ((-sinc * omega_dot_v)[..., None], sinc[..., None] * v + (e * omega_dot_v)[..., None] * omega), axis=-1
    )
    return np.concatenate((real, dual), axis=-1)


def sclerp(a: npt.ArrayLike, b: npt.ArrayLike, tau: npt.ArrayLike) -> np.ndarray:
    """Screw linear interpolation a·(a*·b)^τ of unit (..., 8) poses along the shorter screw; τ broadcasts."""
    a = check_unit(a, "a")
    b = check_unit(b, "b")
    tau = as_array(tau, (), "tau")
    try:
        shape = np.broadcast_shapes(a.shape[:-1], b.shape[:-1], np.shape(tau))
    except ValueError:
        raise ValueError(f"a, b, tau: shapes {a.shape}, {b.shape} and {np.shape(tau)} do not broadcast "
                         "(a and b are (..., 8) poses, tau their leading shape or a scalar)") from None
    a, b = np.broadcast_to(a, shape + (8,)), np.broadcast_to(b, shape + (8,))
    relative = log(multiply_unchecked(conjugate(a), b))
    return multiply_unchecked(a, exp(np.asarray(tau)[..., None] * relative))
