"""Forward kinematics compiled, once per form: the closed form of a nominal UR arm (one pose with libm's sines, a
batch with numpy's vectorised tangents) and the standard DH chain of any (calibrated) table, as frames.

An arm is the float vector of ur3dq.kinematics.arm. Small values travel as tuples (quaternions (w, x, y, z), pairs
(qw, qx, qy, qz, px, py, pz), row-major matrices): no allocation per call.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.arm import DH, LENGTHS
from ur3dq.kinematics.chain_kernels import translation_of
from ur3dq.kinematics.jit import kernel

Quaternion = tuple[float, float, float, float]
Pair = tuple[float, float, float, float, float, float, float]
Matrix = tuple[float, float, float, float, float, float, float, float, float]
SinCos = tuple[float, float]
Coefficients = tuple[float, float, float, float, float, float, float, float]
Vector = tuple[float, float, float]
Lengths = tuple[float, float, float, float, float, float]


@kernel
def product(a: Quaternion, b: Quaternion) -> Quaternion:
    """The Hamilton product a·b of (w, x, y, z) quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


@kernel
def cross(a: Vector, b: Vector) -> Vector:
    """a × b of 3-vectors."""
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@kernel
def rotation_matrix(q: Quaternion) -> Matrix:
    """The row-major rotation matrix of unit quaternion q."""
    w, x, y, z = q
    return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y),
            2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x),
            2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y))


@kernel
def pair_of(c: np.ndarray) -> Pair:
    """(qw, qx, qy, qz, px, py, pz) of a unit dual quaternion's 8 coefficients: p = 2·d·r*."""
    p = translation_of((c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]))
    return (c[0], c[1], c[2], c[3], p[0], p[1], p[2])


@kernel
def compose(first: Pair, second: Pair) -> Pair:
    """The pair of first · second (``second`` given in ``first``'s frame, e.g. a tool on a flange): r₁·r₂ and
    p₁ + R₁·p₂."""
    w, x, y, z = product((first[0], first[1], first[2], first[3]), (second[0], second[1], second[2], second[3]))
    m = rotation_matrix((first[0], first[1], first[2], first[3]))
    return (w, x, y, z, first[4] + m[0] * second[4] + m[1] * second[5] + m[2] * second[6],
            first[5] + m[3] * second[4] + m[4] * second[5] + m[5] * second[6],
            first[6] + m[6] * second[4] + m[7] * second[5] + m[8] * second[6])


@kernel
def dual_quaternion(pair: Pair) -> Coefficients:
    """The 8 coefficients (r, ½p·r) of a pair."""
    w, x, y, z, hx, hy, hz = pair[0], pair[1], pair[2], pair[3], 0.5 * pair[4], 0.5 * pair[5], 0.5 * pair[6]
    return (w, x, y, z, -hx * x - hy * y - hz * z, hx * w + hy * z - hz * y, -hx * z + hy * w + hz * x,
            hx * y - hy * x + hz * w)


@kernel
def nominal_lengths(arm: np.ndarray) -> Lengths:
    """The closed form's lengths (d1, a2, a3, d4, d5, d6) of ``arm``."""
    return (arm[LENGTHS], arm[LENGTHS + 1], arm[LENGTHS + 2], arm[LENGTHS + 3], arm[LENGTHS + 4], arm[LENGTHS + 5])


@kernel
def closed_form(lengths: Lengths, half1: SinCos, half234: SinCos, half_sum: SinCos, half_difference: SinCos,
                full2: SinCos, full23: SinCos) -> Pair:
    """Flange pair of a nominal UR arm (``lengths``: nominal_lengths) from (sin, cos) of q1/2, q234/2, (q5 + q6)/2,
    (q5 − q6)/2, q2 and q2 + q3.

    Rotation r = [rz(q1)·rx(π/2)]·[rz(q234)·rx(π/2)]·[rz(q5)·rx(−π/2)·rz(q6)]: the first two factors multiply out
    to (−s1 sb, c1 cb, s1 cb, c1 sb), the third to k(cP, −cM, −sM, sP), k = 1/√2, halves 1 = q1/2, b = q234/2,
    P = (q5 + q6)/2, M = (q5 − q6)/2; with X = cb cM − sb sP, Y = cb sM − sb cP, Z = cb cP + sb sM,
    W = cb sP + sb cM: r = k(c1 X + s1 Y, c1 Z + s1 W, s1 Z − c1 W, s1 X − c1 Y). The position is that of the
    planar arm (joints 2–4) in frame 1: p = (c1 ρ + s1 δ, s1 ρ − c1 δ, d1 + a2 s2 + a3 s23 − d5 c234 − d6 s5 s234),
    ρ = a2 c2 + a3 c23 + d5 s234 − d6 s5 c234, δ = d4 + d6 c5 (full angles here).
    """
    d1, a2, a3, d4, d5, d6 = lengths
    (s1, c1), (sb, cb), (sp, cp), (sm, cm) = half1, half234, half_sum, half_difference
    x, y = cb * cm - sb * sp, cb * sm - sb * cp
    z, w = cb * cp + sb * sm, cb * sp + sb * cm
    k = 0.7071067811865476
    cos1, sin1 = c1 * c1 - s1 * s1, 2.0 * s1 * c1   # full angles from the half angles at hand
    cos234, sin234 = cb * cb - sb * sb, 2.0 * sb * cb
    cos5, d6_sin5 = cp * cm - sp * sm, d6 * (sp * cm + cp * sm)
    reach = a2 * full2[1] + a3 * full23[1] + d5 * sin234 - d6_sin5 * cos234
    offset = d4 + d6 * cos5
    return (k * (c1 * x + s1 * y), k * (c1 * z + s1 * w), k * (s1 * z - c1 * w), k * (s1 * x - c1 * y),
            cos1 * reach + sin1 * offset, sin1 * reach - cos1 * offset,
            d1 + a2 * full2[0] + a3 * full23[0] - d5 * cos234 - d6_sin5 * sin234)


@kernel
def nominal_flange(arm: np.ndarray, q1: float, q2: float, q3: float, q4: float, q5: float, q6: float) -> Pair:
    """Flange pair of a nominal UR arm at joints q1…q6, by closed_form."""
    h1, h234, hp, hm = 0.5 * q1, 0.5 * (q2 + q3 + q4), 0.5 * (q5 + q6), 0.5 * (q5 - q6)
    return closed_form(nominal_lengths(arm), (math.sin(h1), math.cos(h1)), (math.sin(h234), math.cos(h234)),
                       (math.sin(hp), math.cos(hp)), (math.sin(hm), math.cos(hm)), (math.sin(q2), math.cos(q2)),
                       (math.sin(q2 + q3), math.cos(q2 + q3)))


@kernel
def half_tangent_angles(joints: np.ndarray, out: np.ndarray) -> None:
    """Per row of joints (N, 6) the halves of closed_form's six angles (q1/2, q234/2, (q5 ± q6)/2, q2, q2 + q3), each
    halved again, into out (6, N): numpy's vectorised tan of these gives every sine and cosine of a batch."""
    for index in range(len(joints)):
        q = joints[index]
        out[0, index], out[1, index] = 0.25 * q[0], 0.25 * (q[1] + q[2] + q[3])
        out[2, index], out[3, index] = 0.25 * (q[4] + q[5]), 0.25 * (q[4] - q[5])
        out[4, index], out[5, index] = 0.5 * q[1], 0.5 * (q[1] + q[2])


@kernel
def nominal_poses(arm: np.ndarray, tool: np.ndarray, tangents: np.ndarray, out: np.ndarray) -> None:
    """Poses (N, 8) of ``tool`` (8 coefficients in the flange frame) on a nominal arm into ``out``, from the tangents
    (6, N) of half_tangent_angles' halves: sin 2h = t·u, cos 2h = u − 1 with u = 2/(1 + t²)."""
    # The loop reads no array but the tangents and writes a coefficient-major array of its own: LLVM then
    # vectorises it across poses (a read of arm or tool inside it could alias a write to out, which prevents that).
    lengths, tool_in_flange = nominal_lengths(arm), pair_of(tool)
    poses = np.empty((8, out.shape[0]))
    for index in range(out.shape[0]):
        flange = closed_form(lengths, of_tangent(tangents[0, index]), of_tangent(tangents[1, index]),
                             of_tangent(tangents[2, index]), of_tangent(tangents[3, index]),
                             of_tangent(tangents[4, index]), of_tangent(tangents[5, index]))
        pose = dual_quaternion(compose(flange, tool_in_flange))
        for k in range(8):
            poses[k, index] = pose[k]
    for index in range(out.shape[0]):
        for k in range(8):
            out[index, k] = poses[k, index]


@kernel
def of_tangent(t: float) -> SinCos:
    """(sin 2h, cos 2h) from t = tan h: t·u and u − 1, u = 2/(1 + t²) (a few ulp, also where t is huge)."""
    u = 2.0 / (1.0 + t * t)
    return t * u, u - 1.0


@kernel
def nominal_pose(arm: np.ndarray, tool: np.ndarray, q1: float, q2: float, q3: float, q4: float, q5: float,
                 q6: float) -> Coefficients:
    """The pose (8 coefficients) of ``tool`` (8 coefficients in the flange frame: the TCP, or the identity for the
    flange) on a nominal arm at joints q1…q6."""
    return dual_quaternion(compose(nominal_flange(arm, q1, q2, q3, q4, q5, q6), pair_of(tool)))


@kernel
def chain_frames(arm: np.ndarray, q: np.ndarray, frames: np.ndarray) -> None:
    """DH frames 0…6 of the full table at joints q (6) into ``frames`` (7, 12): per frame its rotation's columns
    x, y, z (9) and its origin (3) in the base frame; frame 6 is the flange.

    Joint i is rz(θ_i + q_i)·tz(d_i)·tx(a_i)·rx(α_i): x' = c·x + s·y, y'' = c·y − s·x, the origin moves along the
    old z by d and the new x by a, then α turns y'' and z about x'."""
    frames[0, :] = 0.0
    frames[0, 0] = frames[0, 4] = frames[0, 8] = 1.0
    for i in range(6):
        a, d, offset, cos_alpha, sin_alpha = arm[DH + 5 * i], arm[DH + 5 * i + 1], arm[DH + 5 * i + 2], \
            arm[DH + 5 * i + 3], arm[DH + 5 * i + 4]
        c, s = math.cos(q[i] + offset), math.sin(q[i] + offset)
        old, new = frames[i], frames[i + 1]
        for k in range(3):
            x, y, z = old[k], old[3 + k], old[6 + k]
            new_x, turned_y = c * x + s * y, c * y - s * x
            new[k] = new_x
            new[3 + k] = cos_alpha * turned_y + sin_alpha * z
            new[6 + k] = cos_alpha * z - sin_alpha * turned_y
            new[9 + k] = old[9 + k] + d * z + a * new_x


@kernel
def chain_matrices(arm: np.ndarray, joints: np.ndarray, out: np.ndarray) -> None:
    """DH frames 0…6 (6 = flange, no TCP) as 4×4 matrices (N, 7, 4, 4) of joints (N, 6) into ``out``."""
    frames = np.empty((7, 12))
    for index in range(len(joints)):
        chain_frames(arm, joints[index], frames)
        for i in range(7):
            matrix = out[index, i]
            for row in range(3):
                for col in range(3):
                    matrix[row, col] = frames[i, 3 * col + row]
                matrix[row, 3] = frames[i, 9 + row]
                matrix[3, row] = 0.0
            matrix[3, 3] = 1.0
