"""Analytic inverse kinematics of the UR family, after the thesis' dual-quaternion derivation (seed 000, §4.3).

Frames: base = DH frame 0, flange = DH frame 6, standard DH (docs/conventions.md); the pose asked for is the TCP
(flange · model.tcp). Angles in radians; every solution is returned canonical in (−π, π].

The thesis' equations, restated in the DH frames (its own frames differ by constant rotations):
  (4.9–4.11) wrist centre p5 = p − d6·z6 lies at distance d4 from the base axis along z1 = (sin θ1, −cos θ1, 0):
             x5·sin θ1 − y5·cos θ1 = d4, solved as θ1 = atan2(x5, −y5) ± atan2(√(x5² + y5² − d4²), d4).
  (4.13)     cos θ5 = z1·z6 (equal to (x6·sin θ1 − y6·cos θ1 − d4)/d6), two signs of θ5.
  (4.14–4.28) with r' = Rx(−π/2)·Rz(−θ1)·r (the thesis' N2 = Q1⁻¹·N1, rotation part) one gets the half-angle
             identities  w' = cos(θ5/2)·cos(Σ/2),  z' = cos(θ5/2)·sin(Σ/2),
                         x' = sin(θ5/2)·sin(Δ/2),  y' = −sin(θ5/2)·cos(Δ/2),
             Σ = θ234 + θ6, Δ = θ234 − θ6, θ234 = θ2 + θ3 + θ4, hence θ6 = (Σ − Δ)/2 and θ234 = (Σ + Δ)/2.
  (4.35–4.38) the planar 3R arm of joints 2–4: (x4, z4) = a2·(c2, s2) + a3·(c23, s23),
             cos θ3 = (x4² + z4² − a2² − a3²)/(2·a2·a3), two signs of θ3.
  (4.41)     θ2 = atan2(z4·(a2 + a3·c3) − x4·a3·s3, x4·(a2 + a3·c3) + z4·a3·s3).
  (4.44)     θ4 = θ234 − θ2 − θ3 (the thesis' half-angle form reduces to this: joints 2–4 are parallel).
  (4.45)     the FK filter: a branch is kept only if its forward kinematics reproduces the pose.

Up to 2 × 2 × 2 = 8 branches, ordered (θ1 sign, θ5 sign, θ3 sign) with the + sign first.

Singularities (defined behaviour, tested):
  wrist (θ5 ≈ 0 or π, |sin(θ5/2)| or |cos(θ5/2)| < WRIST_SINGULAR_TOLERANCE): axes 2, 3, 4 and 6 are parallel
      and the orientation fixes only Σ = θ234 + θ6 (or Δ = θ234 − θ6 at θ5 ≈ π): a one-parameter family. θ6 is
      set to the reference configuration's θ6 (0 without one: ik_all's documented choice) so wrist 3 does not
      jump; θ234 takes the rest and θ2, θ3 follow from the position. When the arm cannot reach with that split
      (the d5 offset turns with θ234), the nearest reachable split is used instead. The two θ5 signs merge.
      Near the singularity (< WRIST_NEAR_TOLERANCE) the computed split carries rounding of ~ε/θ5; a branch it
      pushes out of reach is moved back along the family the same way.
  shoulder (x5² + y5² = d4², the wrist centre's projection in the arm plane on the base axis): the two θ1 branches
      merge. UR arms have d4 > 0, so a wrist centre *on* the base axis is unreachable ("too close").
  stretched or folded elbow (cos θ3 = ±1): the two θ3 branches merge.
Values a rounding error outside their domain (|cos θ3| ≤ 1 + DOMAIN_TOLERANCE …) are clamped; the FK filter then
decides whether the pose is met. Unreachable poses raise UnreachablePoseError saying why.

Calibrated models (DH deltas): the nominal geometry (d1, a2, a3, d4, d5, d6 of the calibrated table) gives the
starting branches (a branch beyond CALIBRATED_DOMAIN_SLACK of the nominal reach is absent), then Newton steps on
the calibrated FK converge each to CALIBRATED_TOLERANCE; the FK filter still decides. A seed still above
newton_floats.HOPELESS_ERROR after HOPELESS_STEP steps gives up, unless a seed of its pose lies beside a singular
wrist (|sin θ5| < wrist_turns.PATIENT_SINE), where seeds wander before they converge. Newton runs all rows of a call
at once: as batched 4×4 matrices for a few rows (single poses), written out per joint-major column for many.
Beside a wrist singularity (|sin θ5| < 0.05 for a nominal seed) a seed's θ6 can be off by up to π: where a
(θ1, elbow) pair's two seeds do not reach two new solutions, Newton runs again from their turns along the wrist's
family (wrist_turns) and fills the pair's slots. Known limit: there a calibrated arm can have more than two
solutions per pair (more than 8 in all), and beside the folded elbow two nominal branches can converge to the same
calibrated solution, so ik_all may miss one (~4 % of configurations beside a singularity, measured on the 14
factory tables; whatever it returns is FK-verified; ik then picks the nearest of those).
``ik`` first runs Newton from q_ref alone and returns that
solution when it provably is the one the full ranking picks (no other solution can lie nearer: its isolation radius,
from the Jacobian's least singular value and a bound on the chain's curvature, calibrated._isolation_radius, covers
every configuration nearer q_ref); otherwise, beside a singularity or far from q_ref, all candidates are ranked. A
q_ref whose first Newton step already says that proof will fail (nearest._proof_expected: the step against the
isolation radius of q_ref's own least singular value) is not refined alone: it joins the nominal branches' Newton
batch.
``ik_batch`` likewise refines one row per pose from q_ref and keeps the proven ones (``ik``'s answers); the other
poses rank their refined nominal branches (which, beside a singularity, can miss the solution the q_ref row finds).
Both batches take a calibrated pose beside a singular wrist (|sin θ5| < wrist_turns.TURN_SINE for a nominal seed)
from ``ik_all``'s and ``ik``'s own code, one by one (batch._singular_wrist_poses): which solution a wandering seed
reaches there depends on the rounding of every step, and one implementation gives one answer.

Single poses run in plain floats (no pyquaternion or numpy objects on the hot path); on a nominal model `ik_all`
solves the 8 branches with the equations written out for a regular wrist (single._nominal_branches) and FK-checks
each from the closed-form flange rotation and position, what the branches share computed once (the rotation per
θ1: the elbow pair shares θ1, θ2 + θ3 + θ4, θ5, θ6 and the wrist flip keeps the rotation; each branch adds its
planar 2-link term): fk_filter._nominal_meets, cross-checked against the per-branch fk_filter._nominal_check;
`ik` walks the branches θ1 → wrist → elbow cheapest first, with the equations written out for a regular wrist, and stops
solving a branch that can no longer be the nearest; the ±2π variant nearest q_ref inside the limits is chosen per joint
(the cost is separable), and the FK filter checks the joints it returns. Batches of a nominal model run a closed-form
kernel (batch_kernels._regular_branches) in numpy over blocks of IK_BLOCK poses, all branches at once
(joint-major (6, 8, B) arrays): what the branches share is computed once (θ1 per pose, the wrist per θ1, both θ5
signs from the same terms), and the FK filter evaluates the closed-form FK kernel (ur_fk) on every branch's final
joints. ``ik_batch`` ranks the existing branches by their nearest in-limit variants first (each joint's
variants once per distinct value) and runs the FK filter on each pose's winner only, in blocks of NEAREST_BLOCK
(a winner that fails is ranked again among the verified branches: the same answer as filtering first). Poses
near a wrist or elbow singularity are redone one by one by ik_all's own scalar code (single._branch_table): there
rounding noise decides whether a branch pair merges, and only the same float operations give the same answer in
every path.

Chaining ``ik`` with q_ref = the previous answer (issue 11, item 7, documented behaviour): ``ik`` minimises the
weighted joint distance to q_ref only, so at an elbow or shoulder crossing (where two branches meet: θ3 = 0, or the
wrist centre on the shoulder circle) the nearest solution past the crossing can be the mirrored branch, and a chain
that follows it later meets a ±2π limit where the nearest in-limit variant is a turn away. Paths are checked for
exactly this before anything moves (ur3dq.pathcheck reports branch flips and limit jumps); scripts that chain ``ik``
themselves should compare the (θ1, θ5, θ3) signs of consecutive answers.

The package, one concern a module: ``geometry`` (the model as floats, tolerances), ``equations`` (the thesis'
equations for floats and arrays), ``fk_filter`` (pose checks, the FK filter, the duplicate rule), ``calibrated``
(Newton on the full DH chain), ``wrist_turns`` (its seeds beside a singular wrist), ``single`` (``ik_all``), ``nearest``
(``ik``), ``batch`` and ``batch_kernels`` (``ik_all_batch``, ``ik_batch``). Each performance copy of the equations
(``single._nominal_branches``, ``nearest._nearest_branch``, ``batch_kernels._regular_branches``) is cross-checked
against ``equations._branches`` by the tests.
"""
from __future__ import annotations

from ur3dq.kinematics.ur_ik.batch import ik_all_batch, ik_batch
from ur3dq.kinematics.ur_ik.equations import wrap_angle
from ur3dq.kinematics.ur_ik.geometry import (
    CALIBRATED_TOLERANCE,
    DUPLICATE_TOLERANCE,
    FK_TOLERANCE_M,
    FK_TOLERANCE_RAD,
    IK_BLOCK,
    NEAREST_BLOCK,
    WRIST_SINGULAR_TOLERANCE,
)
from ur3dq.kinematics.ur_ik.nearest import ik, joint_variants
from ur3dq.kinematics.ur_ik.single import ik_all

__all__ = [
    "CALIBRATED_TOLERANCE", "DUPLICATE_TOLERANCE", "FK_TOLERANCE_M", "FK_TOLERANCE_RAD", "IK_BLOCK", "NEAREST_BLOCK",
    "WRIST_SINGULAR_TOLERANCE", "ik", "ik_all", "ik_all_batch", "ik_batch", "joint_variants", "wrap_angle",
]
