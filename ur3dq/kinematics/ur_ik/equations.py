"""The thesis' analytic IK of the UR family (seed 000, §4.3), restated in the DH frames, as compiled scalar code.

Frames: base = DH frame 0, flange = DH frame 6, standard DH (docs/conventions.md). A target is the flange pair
(qw, qx, qy, qz, px, py, pz) (the thesis' (q, p)); the lengths (d1, a2, a3, d4, d5, d6) are arm.LENGTHS.

  (4.9–4.11) wrist centre p5 = p − d6·z6 lies at distance d4 from the base axis along z1 = (sin θ1, −cos θ1, 0):
             x5·sin θ1 − y5·cos θ1 = d4, solved as θ1 = atan2(x5, −y5) ± atan2(√(x5² + y5² − d4²), d4).
  (4.14–4.28) with r' = Rx(−π/2)·Rz(−θ1)·r (the thesis' N2 = Q1⁻¹·N1, rotation part) the half-angle identities
             w' = cos(θ5/2)·cos(Σ/2),  z' = cos(θ5/2)·sin(Σ/2),  x' = sin(θ5/2)·sin(Δ/2),  y' = −sin(θ5/2)·cos(Δ/2),
             Σ = θ234 + θ6, Δ = θ234 − θ6, θ234 = θ2 + θ3 + θ4: θ6 = (Σ − Δ)/2, θ234 = (Σ + Δ)/2; −θ5 is the
             wrist flip (θ6 − π, θ234 + π).
  (4.33–4.34) the frame-4 origin in the shoulder plane: (x4, z4) = (c1·px + s1·py − d5·s234 + d6·s5·c234,
             pz − d1 + d5·c234 + d6·s5·s234).
  (4.35–4.38) the planar 3R arm of joints 2–4: cos θ3 = (x4² + z4² − a2² − a3²)/(2·a2·a3), two signs of θ3.
  (4.41)     θ2 = atan2(z4·(a2 + a3·c3) − x4·a3·s3, x4·(a2 + a3·c3) + z4·a3·s3).
  (4.44)     θ4 = θ234 − θ2 − θ3 (joints 2–4 are parallel).
  (4.45)     the FK filter (frames.meets): a branch is kept only if its forward kinematics reproduces the pose.

Up to 2 × 2 × 2 = 8 branches, slot 4·i1 + 2·i5 + i3 for the (θ1, θ5, θ3) signs, + first (i = 0).

Singular cases (defined behaviour, tested):
  wrist (|sin(θ5/2)| or |cos(θ5/2)| < WRIST_SINGULAR_TOLERANCE): axes 2, 3, 4 and 6 are parallel and only Σ (θ5 = 0)
      or Δ (θ5 = π) is fixed: a one-parameter family. θ6 is set to the reference's θ6 (0 without one); θ234 takes
      the rest, and where the arm cannot reach with that split the nearest reachable split is taken (the d5 offset
      turns with θ234). The two θ5 signs merge. Near it (arm.WRIST_NEAR: the split's rounding on a nominal arm, the
      calibration's effect on a calibrated arm's seeds) a branch pushed out of reach moves along the family alike.
  shoulder (x5² + y5² = d4²): the two θ1 merge; closer to the base axis is unreachable.
  stretched or folded elbow (|cos θ3| = 1): the two θ3 merge (within ELBOW_ROUNDING on a nominal arm).
Values a rounding outside their domain are clamped; the FK filter decides whether the pose is met.
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.arm import CALIBRATED, EDGE, ELBOW_ROUNDING, LENGTHS, SLACK, WRIST_NEAR, WRIST_SINGULAR_TOLERANCE
from ur3dq.kinematics.jit import kernel

HALF_SQRT2 = math.sqrt(0.5)
TWO_PI = 2.0 * math.pi


@kernel
def remainder(x: float, y: float) -> float:
    """x − n·y for y > 0, n the integer nearest x/y (ties to even): in [−y/2, y/2] up to the rounding of n·y (a few
    ulp of x for the angles here)."""
    return x - y * float(np.rint(x / y))


@kernel
def clamp_or_nan(value: float, low: float, high: float, slack: float) -> float:
    """``value`` clipped into [low, high] if within ``slack`` of it, else NaN."""
    if value < low - slack or value > high + slack:
        return math.nan
    return min(max(value, low), high)


@kernel
def theta1_pair(arm: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """The two θ1 of eqs. 4.9–4.11 for flange pair ``target``; NaN when the wrist centre is too close to the base
    axis (beyond the domain slack)."""
    qw, qx, qy, qz, px, py = target[0], target[1], target[2], target[3], target[4], target[5]
    d4, d6 = arm[LENGTHS + 3], arm[LENGTHS + 5]
    x5 = px - d6 * 2.0 * (qx * qz + qw * qy)   # p5 = p − d6·z6, z6 the flange rotation's third column
    y5 = py - d6 * 2.0 * (qy * qz - qw * qx)
    reach = clamp_or_nan(x5 * x5 + y5 * y5 - d4 * d4, arm[EDGE] * d4 * d4, math.inf, arm[SLACK] * d4 * d4)
    base = math.atan2(x5, -y5)
    offset = math.atan2(math.sqrt(reach), d4)
    return base + offset, base - offset


@kernel
def reduced_rotation(theta1: float, target: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """(cos θ1, sin θ1, w', x', y', z'), (w', x', y', z') = Rx(−π/2)·Rz(−θ1)·r: what wrist joints 2…6 must produce
    (eq. 4.14)."""
    ch, sh = math.cos(0.5 * theta1), -math.sin(0.5 * theta1)
    qw, qx, qy, qz = target[0], target[1], target[2], target[3]
    w1, x1, y1, z1 = ch * qw - sh * qz, ch * qx - sh * qy, ch * qy + sh * qx, ch * qz + sh * qw
    h = HALF_SQRT2
    return ch * ch - sh * sh, -2.0 * ch * sh, h * (w1 + x1), h * (x1 - w1), h * (y1 + z1), h * (z1 - y1)


@kernel
def wrist(w: float, x: float, y: float, z: float, theta6_ref: float, near_tolerance: float
          ) -> tuple[float, float, float, int]:
    """(θ5 ≥ 0, θ6, θ234, singularity) of eqs. 4.14–4.28 in half-angle form; singularity 0 regular, 1 near θ5 = 0,
    2 near π (|sin(θ5/2)| or |cos(θ5/2)| below ``near_tolerance``), 3 at 0, 4 at π (3 and 4: θ5 exactly 0 or π and
    θ6 = ``theta6_ref``)."""
    sin_half5, cos_half5 = math.sqrt(x * x + y * y), math.sqrt(w * w + z * z)
    half_sum = math.atan2(z, w)          # Σ/2, eqs. 4.14 and 4.16
    half_diff = math.atan2(x, -y)        # Δ/2, eqs. 4.15 and 4.17
    if sin_half5 < WRIST_SINGULAR_TOLERANCE:
        return 0.0, theta6_ref, 2.0 * half_sum - theta6_ref, 3
    if cos_half5 < WRIST_SINGULAR_TOLERANCE:
        return math.pi, theta6_ref, 2.0 * half_diff + theta6_ref, 4
    near = 0
    if sin_half5 < near_tolerance or cos_half5 < near_tolerance:
        near = 1 if sin_half5 < cos_half5 else 2
    return 2.0 * math.atan2(sin_half5, cos_half5), half_sum - half_diff, half_sum + half_diff, near


@kernel
def planar_arm(arm: np.ndarray, cos1: float, sin1: float, theta5: float, theta234: float,
               target: np.ndarray) -> tuple[float, float]:
    """(x4, z4): where joints 2–3 must put the frame-4 origin, in the shoulder plane (eqs. 4.33–4.34)."""
    d1, d5, d6 = arm[LENGTHS], arm[LENGTHS + 4], arm[LENGTHS + 5]
    c234, s234, s5 = math.cos(theta234), math.sin(theta234), math.sin(theta5)
    x4 = cos1 * target[4] + sin1 * target[5] - s234 * d5 + c234 * s5 * d6
    z4 = target[6] - d1 + c234 * d5 + s234 * s5 * d6
    return x4, z4


@kernel
def elbow_cosine(arm: np.ndarray, x4: float, z4: float) -> float:
    """cos θ3 of eq. 4.38: clamped within the domain slack of ±1 (stretched or folded elbow), NaN beyond; on a
    nominal arm ±1 within ELBOW_ROUNDING of it."""
    a2, a3, edge = arm[LENGTHS + 1], arm[LENGTHS + 2], arm[EDGE]
    cos3 = (x4 * x4 + z4 * z4 - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
    if arm[CALIBRATED] == 0.0 and 1.0 - ELBOW_ROUNDING < abs(cos3) < 1.0:
        cos3 = math.copysign(1.0, cos3)
    return clamp_or_nan(cos3, edge - 1.0, 1.0 - edge, arm[SLACK])


@kernel
def reachable_split(arm: np.ndarray, cos1: float, sin1: float, theta5: float, theta234: float,
                    target: np.ndarray) -> float:
    """The θ234 nearest ``theta234`` at which the planar arm reaches, θ1 and θ5 fixed (NaN if none does).

    Eq. 4.34 gives (x4, z4) = P − ρ·(sin ψ, −cos ψ), P = (c1·px + s1·py, pz − d1), ρ = |(d5, d6·s5)|,
    ψ = θ234 − atan2(d6·s5, d5): a circle. The elbow must span R² + ρ² − 2ρR·sin(ψ − φ) (R, φ: the polar form of P)
    between the folded and the stretched arm; the allowed ψ form arcs whose ends have sin(ψ − φ) = low or high.
    """
    d1, a2, a3, d5, d6 = arm[LENGTHS], arm[LENGTHS + 1], arm[LENGTHS + 2], arm[LENGTHS + 4], arm[LENGTHS + 5]
    near_x = cos1 * target[4] + sin1 * target[5]
    near_z = target[6] - d1
    radius, phase = math.hypot(near_x, near_z), math.atan2(near_z, near_x)
    offset = d6 * math.sin(theta5)
    rho, beta = math.hypot(d5, offset), math.atan2(offset, d5)
    longest, shortest = abs(a2) + abs(a3), abs(abs(a2) - abs(a3))
    base2 = radius * radius + rho * rho
    low = (base2 - longest * longest) / (2.0 * rho * radius)
    high = (base2 - shortest * shortest) / (2.0 * rho * radius)
    psi = theta234 - beta
    sine = math.sin(psi - phase)
    if low <= sine <= high:
        return theta234
    best, best_distance = math.nan, math.inf
    for bound in (low, high):
        arc_end = math.asin(clamp_or_nan(bound, -1.0, 1.0, 0.0))
        for candidate in (phase + arc_end, phase + math.pi - arc_end):
            distance = abs(remainder(candidate - psi, TWO_PI))
            if distance < best_distance:   # False for NaN: an arc end that does not exist
                best, best_distance = candidate, distance
    return best + beta


@kernel
def split_for_reach(arm: np.ndarray, cos1: float, sin1: float, theta5: float, theta6: float, theta234: float,
                    singular: int, target: np.ndarray) -> tuple[float, float, float, float, float]:
    """(θ6, θ234, x4, z4, cos θ3) of one wrist branch (eqs. 4.33–4.38), its split moved along a singular wrist's
    family to the nearest reachable one where the arm cannot reach with it (θ6 compensating)."""
    x4, z4 = planar_arm(arm, cos1, sin1, theta5, theta234, target)
    cos3 = elbow_cosine(arm, x4, z4)
    if singular >= 3 or (singular > 0 and cos3 != cos3):
        shift = reachable_split(arm, cos1, sin1, theta5, theta234, target) - theta234
        theta234 += shift
        theta6 += -shift if singular % 2 == 1 else shift   # Σ fixed near θ5 = 0, Δ near π
        x4, z4 = planar_arm(arm, cos1, sin1, theta5, theta234, target)
        cos3 = elbow_cosine(arm, x4, z4)
    return theta6, theta234, x4, z4, cos3


@kernel
def shoulder_elbow(arm: np.ndarray, x4: float, z4: float, cos3: float, sign: float) -> tuple[float, float]:
    """(θ2, θ3) of the elbow with θ3's ``sign`` (±1): θ3 from eq. 4.38, θ2 from eq. 4.41."""
    a2, a3 = arm[LENGTHS + 1], arm[LENGTHS + 2]
    sin3 = math.sqrt(1.0 - cos3 * cos3)
    along, across = a2 + a3 * cos3, sign * a3 * sin3
    theta2 = math.atan2(z4 * along - x4 * across, x4 * along + z4 * across)
    return theta2, sign * math.atan2(sin3, cos3)


@kernel
def wrist_of(arm: np.ndarray, target: np.ndarray, theta1: float, theta6_ref: float
             ) -> tuple[float, float, float, float, float, int]:
    """(cos θ1, sin θ1, θ5 ≥ 0, θ6, θ234, singularity) of the wrist of the branches with this θ1 (eqs. 4.14–4.28;
    ``wrist`` says what the singularity codes mean; at a singular wrist θ6 = ``theta6_ref``)."""
    cos1, sin1, w, x, y, z = reduced_rotation(theta1, target)
    theta5, theta6, theta234, singular = wrist(w, x, y, z, theta6_ref, arm[WRIST_NEAR])
    return cos1, sin1, theta5, theta6, theta234, singular


@kernel
def flipped(theta5: float, theta6: float, theta234: float, singular: int, flip: int) -> tuple[float, float, float]:
    """(θ5, θ6, θ234) of the wrist, flipped (−θ5, θ6 − π, θ234 + π) when ``flip`` is 1; a singular wrist's two signs
    are one family, so there only θ5's sign changes."""
    if flip == 0:
        return theta5, theta6, theta234
    if singular >= 3:
        return -theta5, theta6, theta234
    return -theta5, theta6 - math.pi, theta234 + math.pi


@kernel
def elbow_branches(arm: np.ndarray, target: np.ndarray, theta1: float, cos1: float, sin1: float, theta5: float,
                   theta6: float, theta234: float, singular: int, out: np.ndarray) -> None:
    """The two elbow branches (θ3 ≥ 0, then θ3 ≤ 0) of one wrist branch into ``out`` (2, 6): the split moved where
    the arm cannot reach with it (split_for_reach), θ2 and θ3 of eqs. 4.38–4.41, θ4 of eq. 4.44."""
    split6, split234, x4, z4, cos3 = split_for_reach(arm, cos1, sin1, theta5, theta6, theta234, singular, target)
    for i3 in range(2):
        theta2, theta3 = shoulder_elbow(arm, x4, z4, cos3, 1.0 - 2.0 * i3)
        row = out[i3]
        row[0], row[1], row[2], row[3] = theta1, theta2, theta3, split234 - theta2 - theta3   # eq. 4.44
        row[4], row[5] = theta5, split6


@kernel
def branches(arm: np.ndarray, target: np.ndarray, theta6_ref: float, out: np.ndarray) -> None:
    """The 8 branches (θ1…θ6) of flange pair ``target`` into ``out`` (8, 6), slot 4·i1 + 2·i5 + i3, NaN where a
    branch does not exist; at a singular wrist θ6 = ``theta6_ref``."""
    pair = theta1_pair(arm, target)
    for i1 in range(2):
        cos1, sin1, theta5, theta6, theta234, singular = wrist_of(arm, target, pair[i1], theta6_ref)
        for i5 in range(2):
            slot = 4 * i1 + 2 * i5
            flip5, flip6, flip234 = flipped(theta5, theta6, theta234, singular, i5)
            elbow_branches(arm, target, pair[i1], cos1, sin1, flip5, flip6, flip234, singular, out[slot:slot + 2])
