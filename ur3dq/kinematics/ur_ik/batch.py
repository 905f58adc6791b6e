"""Batches of poses: every solution (`ik_all_batch`) and the nearest one (`ik_batch`), block by block."""
from __future__ import annotations

import math

import numpy as np

from ur3dq import dqarray
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics.ur_ik.batch_kernels import _joints_fk_filter, _regular_branches, _regular_fk_filter
from ur3dq.kinematics.ur_ik.calibrated import VARIANT_SHIFT, _fk_implied, _isolated, _proof_span, _refine_batch
from ur3dq.kinematics.ur_ik.equations import _ArrayOps, _branches, wrap_angle
from ur3dq.kinematics.ur_ik.fk_filter import _EXACT_UNIT, _within_fk_tolerance
from ur3dq.kinematics.ur_ik.geometry import (
    _TWO_PI,
    CALIBRATED_TOLERANCE,
    DUPLICATE_TOLERANCE,
    IK_BLOCK,
    LIMIT_ROUNDING,
    NEAREST_BLOCK,
    _flange_of,
    _Geometry,
    _geometry,
    _translation_columns,
)
from ur3dq.kinematics.ur_ik.nearest import _weights, ik
from ur3dq.kinematics.ur_ik.single import _branch_table, _nominal_branches
from ur3dq.kinematics.ur_ik.wrist_turns import PATIENT_SINE, TURN_SINE
from ur3dq.real_numbers import real_array


def _batch_poses(poses) -> np.ndarray:
    """(N, 8) unit dual quaternions; ValueError naming ``poses`` for a wrong shape, NaN/inf or non-unit rows.

    Rows off unit by more than rounding (but within dqarray.UNIT_TOLERANCE) are normalised, as single poses are
    (fk_filter._pose_coefficients): the same pose gives the same answer in both paths."""
    try:
        array = real_array(poses)
    except (TypeError, ValueError) as exc:
        raise ValueError("poses: expected numbers, 8 coefficients per pose") from exc
    if array.ndim != 2 or array.shape[1] != 8:
        raise ValueError(f"poses: expected shape (N, 8), got {array.shape}")
    array = dqarray.check_unit(array, "poses")
    norm2 = np.einsum("ij,ij->i", array[:, :4], array[:, :4])
    orthogonality = np.einsum("ij,ij->i", array[:, :4], array[:, 4:])
    off = (np.abs(norm2 - 1.0) > _EXACT_UNIT) | (np.abs(orthogonality) > _EXACT_UNIT)
    if off.any():
        array = array.copy()
        array[off] = dqarray.normalise(array[off])
    return array


def _batch_flange_targets(g: _Geometry, poses: np.ndarray) -> tuple:
    """Seven (N,) arrays (qw, qx, qy, qz, px, py, pz): flange pairs of (N, 8) TCP poses (pose · tcp⁻¹)."""
    if g.tcp_inverse is not None:
        poses = dqarray.multiply_unchecked(poses, np.array(g.tcp_inverse))
    translation = dqarray.translation_unchecked(poses)
    return tuple(poses[:, i] for i in range(4)) + tuple(translation[:, i] for i in range(3))


def _batch_candidates(g: _Geometry, targets: tuple, theta6_ref, seeds=None) -> np.ndarray:
    """(6, 8, N) canonical analytic branches (joint, branch, pose) of flange targets (seven (N,) arrays).

    Joint-major layout: every joint of every branch is one contiguous run, which is what the elementwise
    kernels (and the model's fk_batch, reading columns) want; refined by Newton first on calibrated models, from
    ``seeds`` (optional: the targets' _nominal_candidates, computed already). The batches take the poses beside a
    singular wrist (_singular_wrist_poses) from ik_all's and ik's own code: the turns of wrist_turns are theirs.
    """
    columns = _nominal_candidates(g, targets, theta6_ref) if seeds is None else seeds
    if g.calibrated:
        flat = columns.reshape(6, -1).T
        repeated = np.tile(np.stack(targets, axis=-1), (8, 1))
        usable = np.all(np.isfinite(flat), axis=1)
        # As ik_all: a wandering seed gives up early unless its pose lies beside a singular wrist.
        patient = np.tile(_least_wrist_sines(columns) < PATIENT_SINE, 8)
        refined, residual = _refine_batch(g, flat[usable], repeated[usable], patient=patient[usable])
        flat = flat.copy()
        flat[usable] = np.where((residual <= CALIBRATED_TOLERANCE)[:, None], refined, np.nan)
        columns = np.ascontiguousarray(flat.T).reshape(6, 8, len(targets[0]))
    # θ2, θ3 come from atan2 already in (−π, π]; θ1, θ4, θ6 are sums and θ5 may be −π.
    for j in (0, 3, 4, 5):
        columns[j] = wrap_angle(columns[j])
    return columns


#: Poses below which the calibrated seeds are solved pose by pose in floats (single._nominal_branches, ~6 µs a pose,
#: as ik_all and ik solve them) rather than once on arrays (~100 µs whatever the poses up to dozens: ~1000 numpy
#: calls).
_SCALAR_SEED_POSES = 16


def _nominal_candidates(g: _Geometry, targets: tuple, theta6_ref) -> np.ndarray:
    """(6, 8, N) the analytic branches of the geometry's closed form (NaN where absent) of flange targets (seven
    (N,) arrays), not yet refined nor wrapped: the seeds of Newton on calibrated models."""
    count = len(targets[0])
    if count < _SCALAR_SEED_POSES:
        pairs, references = np.stack(targets, axis=-1).tolist(), np.broadcast_to(theta6_ref, (count,)).tolist()
        return np.array([_nominal_branches(g, pair, reference) for pair, reference in zip(pairs, references)],
                        dtype=float).reshape(count, 8, 6).transpose(2, 1, 0)
    columns = np.empty((6, 8, count))
    for k, branch in enumerate(_branches(_ArrayOps, g, targets, theta6_ref)):
        for j, value in enumerate(branch):
            columns[j, k] = value
    return columns


def _least_wrist_sines(seeds: np.ndarray) -> np.ndarray:
    """(N,) per pose the least |sin θ5| of its seeds (6, 8, N) (_nominal_candidates), NaN where none exists: what
    wrist_turns.beside_singular_wrist compares with its band, for a batch."""
    return np.fmin.reduce(np.abs(np.sin(seeds[4])), axis=0)


def _singular_wrist_poses(seeds: np.ndarray) -> np.ndarray:
    """(N,) whether some seed of a pose (seeds (6, 8, N), _nominal_candidates) lies beside a singular wrist
    (|sin θ5| < TURN_SINE; False where no seed exists), as wrist_turns.beside_singular_wrist tells for ik_all.

    There a seed's θ6 can be off by up to π, Newton runs again from turned seeds (wrist_turns), and which solution
    a row reaches depends on every rounding of its steps: refined in the batch's kernels, 5 of 3,360 hard poses of
    the 14 factory tables had other solution counts in ik_all_batch than in ik_all, and ik_batch picked a
    configuration 1.57 rad from ik's on one. The batches take these poses (~3 % of random configurations) from
    single._branch_table and nearest.ik, one by one, as the nominal model takes its near-singular poses from
    single._branch_table: one implementation gives one answer. Farther from the singularity (up to PATIENT_SINE,
    where seeds are refined patiently) the batch's rows gave the same solutions (3,360 poses there, measured).
    """
    return _least_wrist_sines(seeds) < TURN_SINE


def _calibrated_split(model, g: _Geometry, poses: np.ndarray, theta6_ref: np.ndarray) -> tuple:
    """(alone (N,) bools, branches (6, 8, R), FK-filter mask (8, R)) of a calibrated model's poses (N, 8): which lie
    beside a singular wrist (_singular_wrist_poses: ik_all's and ik's own code solves them, one by one), and the
    refined nominal branches of the R others with their mask (_refined_filter)."""
    targets = _batch_flange_targets(g, poses)
    seeds = _nominal_candidates(g, targets, theta6_ref)
    alone = _singular_wrist_poses(seeds)
    rows = np.flatnonzero(~alone)
    columns = _batch_candidates(g, tuple(part[rows] for part in targets), None, seeds[:, :, rows])
    return alone, columns, _refined_filter(model, g, columns, poses[rows])


def _calibrated_nearest(model, g: _Geometry, poses: np.ndarray, reference: np.ndarray, weight) -> tuple:
    """(joints (N, 6), proven (N,), rows (N, 6)): per pose of a calibrated model, the solution Newton reaches from
    ``reference`` (N, 6) as its in-limit ±2π variants nearest it, whether it is provably the nearest accepted
    solution, and the Newton row itself (NaN where it did not converge) for the ranking of the others.

    Proven as in nearest._reference_solution: every solution nearer the reference than x (cost c) would lie within
    2·√(c / min w) of x, inside half x's isolation radius (calibrated._isolated), where no other lies, or c = 0 (x's
    variants are the reference: every candidate as near has these joints); and the FK filter passes. That is
    ``ik``'s answer (its ranking holds the same Newton row from the reference), and the ranking of the nominal
    branches' rows gives it too whenever one of them reaches x. Rows not proven are NaN.
    """
    targets = np.stack(_batch_flange_targets(g, poses), axis=-1)
    normals = np.full((6, 6, len(poses)), np.nan)   # JᵀJ of the final joints, for _isolated
    refined, residual = _refine_batch(g, reference, targets, normals)
    rows = np.flatnonzero(residual <= CALIBRATED_TOLERANCE)
    variants, cost = _variant_costs(g, refined[rows].T[:, None, :], reference[rows].T[:, None, :], weight)
    joints, cost = variants[:, 0].T, cost[0]
    fits = cost == cost   # False for NaN: some joint has no in-limit variant
    rows, joints, cost = rows[fits], joints[fits], cost[fits]
    smallest = 1.0 if weight is None else min(weight)
    span = _proof_span(cost, smallest)
    # A reference that is itself the solution (cost 0) is the answer whatever the ranking (as in nearest's).
    isolated = cost == 0.0
    others = np.flatnonzero(~isolated)
    if others.size:
        isolated[others] = _isolated(g, refined[rows[others]], span[others], normals[:, :, rows[others]])
    rows, joints = rows[isolated], joints[isolated]
    passed = _shifted_rows_filter(model, g, joints, refined[rows], poses[rows])
    out = np.full((len(poses), 6), np.nan)
    out[rows[passed]] = joints[passed]
    proven = np.zeros(len(poses), dtype=bool)
    proven[rows[passed]] = True
    return out, proven, np.where((residual <= CALIBRATED_TOLERANCE)[:, None], refined, np.nan)


def _shifted_rows_filter(model, g: _Geometry, joints: np.ndarray, refined: np.ndarray, poses: np.ndarray):
    """(M,) the FK filter of ``joints`` (M, 6), ±2π variants of Newton's accepted rows ``refined`` (M, 6), against
    poses (M, 8): known to pass where each joint lies within VARIANT_SHIFT of a 2π shift of its Newton joint and
    the geometry allows (calibrated._fk_implied; ~0.7 µs a row of fk_batch saved), checked for the others (a joint
    clamped onto a limit)."""
    check = np.arange(len(joints))
    if _fk_implied(g):
        shift = joints - refined
        shift -= _TWO_PI * np.rint(shift / _TWO_PI)
        check = np.flatnonzero((np.abs(shift) > VARIANT_SHIFT).any(axis=1))
    passed = np.ones(len(joints), dtype=bool)
    if check.size:
        fk = model.fk_batch(joints[check])
        passed[check] = _within_fk_tolerance(np.ascontiguousarray(fk.T), np.ascontiguousarray(poses[check].T))
    return passed


def _calibrated_ranking(model, g: _Geometry, poses: np.ndarray, solved: tuple, rows: np.ndarray) -> tuple:
    """(branches (6, 9, R), FK-filter mask (9, R)) to rank for poses (R, 8) of a calibrated model: their refined
    nominal branches and mask ``solved`` (_calibrated_split's) and, last, the Newton rows from the references
    (R, 6), NaN where they did not converge (_calibrated_nearest), the candidates of ik's ranking
    (single._solution_candidates): beside a singularity the nominal branches can miss the solution the reference's
    row reaches."""
    columns, valid = solved
    reference_rows = wrap_angle(rows.T)[:, None, :]
    return (np.concatenate((columns, reference_rows), axis=1),
            np.concatenate((valid, _refined_filter(model, g, reference_rows, poses))))


def _refined_filter(model, g: _Geometry, columns: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """(k, N) _fk_filter's mask of Newton's accepted rows (6, k, N) of a calibrated model, wrapped (wrap_angle: a 2π
    shift, within a few ulps), NaN where absent: known where calibrated._fk_implied (they pass: the mask is where
    they exist), else from their FK."""
    if _fk_implied(g):
        return ~np.isnan(columns).any(axis=0)
    return _fk_filter(model, columns, poses)


def _fk_filter(model, columns: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """(8, N) mask of the branches (6, 8, N) whose FK meets poses (N, 8) (the thesis' filter, eq. 4.45)."""
    exists = ~np.isnan(columns).any(axis=0)
    fk = model.fk_batch(np.where(exists, columns, 0.0).reshape(6, -1).T)
    # One transposing copy makes every coefficient a contiguous run: the comparison then runs twice as fast.
    fk_columns = np.ascontiguousarray(fk.T).reshape((8,) + exists.shape)
    return exists & _within_fk_tolerance(fk_columns, np.ascontiguousarray(poses.T))


def _drop_duplicates(columns: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """``keep`` (8, N) with every branch that repeats (within DUPLICATE_TOLERANCE, mod 2π) a kept earlier one cleared.

    Joint by joint, only the poses still alike are compared further (most branch pairs differ in θ1 already).
    """
    keep = keep.copy()
    for later in range(1, 8):
        for earlier in range(later):
            alike = np.flatnonzero(keep[later] & keep[earlier])
            for joint in (0, 4, 2, 1, 3, 5):
                if alike.size == 0:
                    break
                difference = columns[joint, later, alike] - columns[joint, earlier, alike]
                difference -= _TWO_PI * np.rint(difference / _TWO_PI)
                alike = alike[np.abs(difference) < DUPLICATE_TOLERANCE]
            keep[later, alike] = False
    return keep


def _solved_blocks(model, g: _Geometry, poses: np.ndarray, theta6_ref: np.ndarray):
    """Per block of poses: (rows, branches (6, 8, B) canonical, FK-filter mask (8, B), ambiguous (B,)).

    Where the mask is False a branch may hold any value (NaN or the clamped values of a branch that does not exist).

    ``rows`` (slice or index array) says which poses a block holds; ``ambiguous`` marks the poses where two
    branches may coincide (merged θ1, θ5 or θ3 signs) and need the duplicate check. Nominal models take the
    closed-form kernel; its poses near a wrist or elbow singularity are collected and redone last, one by one, by
    ik_all's own scalar path (single._branch_table), so that both paths merge the same branch pairs. Calibrated models
    take the general equations and Newton, their poses beside a singular wrist (_singular_wrist_poses) ik_all's
    path too.
    """
    if g.calibrated:
        alone, columns, valid = _calibrated_split(model, g, poses, theta6_ref)
        yield np.flatnonzero(~alone), columns, valid, np.ones(columns.shape[2], dtype=bool)
        if alone.any():
            rows = np.flatnonzero(alone)
            yield (rows,) + _redone_rows(model, poses, rows, theta6_ref) + (np.zeros(len(rows), dtype=bool),)
        return
    redo = []
    for rows, pair, columns, exists, merged, near_singular in _kernel_blocks(g, poses, IK_BLOCK):
        valid = _regular_fk_filter(g, columns, pair)
        valid &= exists
        if near_singular.any():
            valid[:, near_singular] = False
            redo.append(rows.start + np.flatnonzero(near_singular))
        yield rows, columns, valid, merged
    if redo:
        rows = np.concatenate(redo)
        yield (rows,) + _redone_rows(model, poses, rows, theta6_ref) + (np.zeros(len(rows), dtype=bool),)


def _kernel_blocks(g: _Geometry, poses: np.ndarray, size: int):
    """Per block of ``size`` poses of a nominal model: (rows (slice), TCP pairs (7, B), the closed-form kernel's
    branches (6, 8, B), exists (8, B), merged (B,), near_singular (B,)) (batch_kernels._regular_branches); no FK
    filter yet."""
    for start in range(0, len(poses), size):
        rows = slice(start, start + size)
        coefficients = np.ascontiguousarray(poses[rows].T)
        pair = _pair_rows(coefficients)
        flange = pair if g.tcp_inverse is None else _pair_rows(_flange_of(coefficients, g.tcp_inverse))
        with np.errstate(divide="ignore", invalid="ignore"):   # exact singularities: those poses are redone
            yield (rows, pair) + _regular_branches(g, flange)


def _redone_rows(model, poses: np.ndarray, rows: np.ndarray, theta6_ref: np.ndarray) -> tuple:
    """(branches (6, 8, R), FK-filter mask (8, R)) of the poses ``rows`` (near a singularity) by ik_all's own
    code, one by one (single._branch_table)."""
    columns, valid = np.empty((6, 8, len(rows))), np.empty((8, len(rows)), dtype=bool)
    for i, row in enumerate(rows):
        columns[:, :, i].T[:], valid[:, i] = _branch_table(model, poses[row], float(theta6_ref[row]))
    return columns, valid


def _pair_rows(coefficients) -> np.ndarray:
    """(7, B) thesis pairs (qw, qx, qy, qz, px, py, pz) of unit dual quaternions given as 8 rows of B: p = 2·d·r*."""
    return np.stack((*coefficients[:4], *_translation_columns(coefficients)))


def ik_all_batch(model, poses, q_ref=None) -> np.ndarray:
    """(N, 8, 6) every FK-verified solution of (N, 8) TCP poses, in (−π, π]; absent branches are rows of NaN.

    Branch k of every pose is the same sign choice (θ1, θ5, θ3) in that order, + first; duplicates are NaN.
    ``q_ref`` ((6,) or (N, 6), optional) only resolves the wrist singularity as in ik_all.
    The result is the transposed view of a joint-major (6, 8, N) array (each joint of each branch contiguous).
    """
    g = _geometry(model)
    poses = _batch_poses(poses)
    theta6_ref = np.zeros(len(poses)) if q_ref is None else wrap_angle(_batch_reference(q_ref, len(poses))[:, 5])
    out = np.empty((6, 8, len(poses)))
    for rows, columns, valid, ambiguous in _solved_blocks(model, g, poses, theta6_ref):
        keep = valid
        if ambiguous.any():   # only poses where two branches can coincide need the pairwise comparison
            keep = valid.copy()
            keep[:, ambiguous] = _drop_duplicates(columns[:, :, ambiguous], valid[:, ambiguous])
        columns += np.where(keep, 0.0, np.nan)   # + 0 keeps a value, + NaN blanks it (cheaper than a masked copy)
        out[:, :, rows] = columns
    return out.transpose(2, 1, 0)


def _batch_reference(q_ref, count: int) -> np.ndarray:
    """(count, 6) finite joint references from a (6,) or (count, 6) array; ValueError naming ``q_ref``."""
    try:
        reference = real_array(q_ref)
    except (TypeError, ValueError) as exc:
        raise ValueError("q_ref: expected numbers: 6 joint angles (radians), or a row of 6 per pose") from exc
    if reference.shape == (6,):
        reference = np.broadcast_to(reference, (count, 6))
    if reference.shape != (count, 6):
        raise ValueError(f"q_ref: expected shape (6,) or ({count}, 6), got {reference.shape}")
    if not np.all(np.isfinite(reference)):
        raise ValueError("q_ref: contains NaN or infinite values")
    return reference


def _joint_variants(angle: np.ndarray, reference, lower: float, upper: float) -> np.ndarray:
    """The ±2π variants of one joint's ``angle`` (any shape) nearest ``reference`` (broadcasting to it) inside
    [lower, upper]; NaN where none fits.

    As _closest_variant: the nearest variant of all when it is inside, else the end of the in-limit run on its
    side. Almost every nearest variant is inside the limits: only the others go through the limit cases.
    """
    centre = np.subtract(reference, angle)
    centre /= _TWO_PI
    np.rint(centre, out=centre)
    centre *= _TWO_PI
    centre += angle                               # angle + 2π·round((reference − angle)/2π)
    if lower == -np.inf and upper == np.inf:      # an unlimited joint (UR3 wrist 3): every variant fits
        return centre
    if centre.size == 0 or (centre.min() >= lower and centre.max() <= upper):   # False for NaN
        return centre
    outside = ~((centre >= lower) & (centre <= upper))
    centre[outside] = _limited_variants(np.broadcast_to(angle, centre.shape)[outside], centre[outside], lower, upper)
    return centre


def _nearest_variants(g: _Geometry, columns: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(6, 8, N) ±2π variants of the branches (6, 8, N) nearest ``reference`` (6, 1, N) inside the limits; NaN
    if none fits (_joint_variants per joint)."""
    return np.stack([_joint_variants(columns[j], reference[j], g.lower[j], g.upper[j]) for j in range(6)])


def _limited_variants(angle: np.ndarray, centre: np.ndarray, lower: float, upper: float) -> np.ndarray:
    """(M,) in-limit variants of one joint's ``angle`` (M,) whose nearest variant ``centre`` (M,) is outside
    [lower, upper], NaN where none fits: a centre a rounding past a limit is the limit, else the end of the
    in-limit run on the centre's side (_closest_variant's rule)."""
    with np.errstate(invalid="ignore"):   # ±inf limits: their end is never selected
        first = angle + _TWO_PI * np.ceil((lower - angle) / _TWO_PI)
        first = np.where(first < lower, first + _TWO_PI, first)
        last = angle + _TWO_PI * np.floor((upper - angle) / _TWO_PI)
        last = np.where(last > upper, last - _TWO_PI, last)
    # A centre a rounding outside a limit is the limit itself (a joint at exactly ±2π), as in _closest_variant.
    centre = np.where((centre < lower) & (centre >= lower - LIMIT_ROUNDING), lower, centre)
    centre = np.where((centre > upper) & (centre <= upper + LIMIT_ROUNDING), upper, centre)
    best = np.where(centre < lower, first, np.where(centre > upper, last, centre))
    return np.where((best >= lower) & (best <= upper), best, np.nan)


def _variant_costs(g: _Geometry, columns: np.ndarray, reference: np.ndarray, weight) -> tuple:
    """(variants (6, 8, N), cost (8, N)): the nearest in-limit ±2π variants of branches (6, 8, N) and their
    Σ wᵢ·(vᵢ − refᵢ)² to ``reference`` (6, 1, N); ``weight`` (6 floats), or None for unit weights (the product
    is skipped: 1·x is x). The cost is NaN where some joint has no in-limit variant."""
    variants = _nearest_variants(g, columns, reference)
    cost = None
    for j in range(6):
        term = _joint_cost(variants[j], reference[j], None if weight is None else weight[j])
        cost = term if cost is None else np.add(cost, term, out=cost)
    return variants, cost


def _joint_cost(variant: np.ndarray, reference, weight) -> np.ndarray:
    """wⱼ·(vⱼ − refⱼ)² of one joint's variants (any shape); ``weight`` None: unit weight."""
    shift = variant - reference
    shift *= shift
    if weight is not None:
        shift *= weight
    return shift


def _kernel_costs(g: _Geometry, columns: np.ndarray, reference: np.ndarray, weight) -> tuple:
    """(variants, cost (8, B)) of the closed-form kernel's branches (6, 8, B) as _variant_costs, with each
    joint's variants computed once per distinct value: θ1 is shared by the four branches of a θ1 sign, θ5 and θ6
    by the two of a (θ1, θ5) sign pair (_regular_branches). ``variants`` holds per joint an array of shape
    (2, 1, 1, B), (2, 2, 1, B) or (2, 2, 2, B) (θ1, θ5, θ3 signs), reference (6, B). The terms are summed in
    joint order, as _variant_costs does."""
    count = columns.shape[-1]
    joints = columns.reshape(6, 2, 2, 2, count)
    every, first = slice(None), slice(0, 1)
    # Per joint the sign axes (θ1, θ5, θ3) its value varies along: θ1 its own; θ2–θ4 all three; θ5, θ6 θ1 and θ5.
    shapes = ((every, first, first),) + ((every, every, every),) * 3 + ((every, every, first),) * 2
    variants, cost = [], None
    for j, shape in enumerate(shapes):
        variant = _joint_variants(joints[j][shape], reference[j], g.lower[j], g.upper[j])
        variants.append(variant)
        term = _joint_cost(variant, reference[j], None if weight is None else weight[j])
        cost = np.array(np.broadcast_to(term, (2, 2, 2, count))) if cost is None else np.add(cost, term, out=cost)
    return variants, cost.reshape(8, count)


def _select(cost: np.ndarray, allowed: np.ndarray) -> tuple:
    """(branch index (N,), its cost (N,)): per pose the allowed branch of least cost (the first of equal ones), from
    cost (8, N) and allowed (8, N); cost inf where no branch is allowed or fits the limits (NaN cost)."""
    cost = np.where(allowed & (cost == cost), cost, np.inf)   # cost == cost: False for NaN
    best = np.argmin(cost, axis=0)
    return best, cost[best, np.arange(cost.shape[1])]


def _chosen(variants, best: np.ndarray, least: np.ndarray) -> np.ndarray:
    """(6, N) the variants of branch ``best`` (N,) per pose, NaN where ``least`` is inf (nothing chosen).

    ``variants`` per joint (6 items or a (6, B, N) array), each of M·N values in branch order, M dividing the
    largest, B: a value shared by B/M consecutive branches is stored once (_kernel_costs: M of 2, 4, 8)."""
    count = best.size
    columns = np.arange(count)
    chosen = np.empty((6, count))
    sizes = [math.prod(variant.shape[:-1]) for variant in variants]
    for j, (variant, size) in enumerate(zip(variants, sizes)):
        chosen[j] = variant.reshape(size, count)[best // (max(sizes) // size), columns]
    chosen[:, least == np.inf] = np.nan
    return chosen


def _nearest_of_block(g: _Geometry, block: tuple, reference: np.ndarray, weight) -> np.ndarray:
    """(6, B) the solution nearest ``reference`` (6, B) of one _kernel_blocks block, NaN columns where none is
    (near-singular poses included: the caller redoes them).

    The FK filter runs on each pose's winner only (one branch instead of eight); a pose whose winner fails it is
    ranked again among its FK-verified branches. Same answer as filtering first: the winner among the existing
    branches, when it passes, is also the first least-cost one among the verified ones (a subset)."""
    _, pair, columns, exists, _, near_singular = block
    variants, cost = _kernel_costs(g, columns, reference, weight)
    best, least = _select(cost, exists & ~near_singular)
    count = best.size
    joints = columns.reshape(6, 8 * count)[:, best * count + np.arange(count)]
    rejected = np.isfinite(least) & ~_joints_fk_filter(g, joints, pair)
    if rejected.any():
        valid = exists[:, rejected] & _regular_fk_filter(g, columns[:, :, rejected], pair[:, rejected])
        best[rejected], least[rejected] = _select(cost[:, rejected], valid)
    return _chosen(variants, best, least)


def ik_batch(model, poses, q_ref, weights=None) -> np.ndarray:
    """(N, 6): for each (N, 8) TCP pose the solution nearest q_ref ((6,) or (N, 6)) as in ``ik``; NaN rows where
    the pose is unreachable or no solution lies inside the joint limits (no exception: batches keep going)."""
    poses = _batch_poses(poses)
    reference = _batch_reference(q_ref, len(poses))
    weight = None if weights is None else _weights(weights)
    g = _geometry(model)
    out = np.empty((len(poses), 6))
    theta6_ref = wrap_angle(reference[:, 5])
    if g.calibrated:   # the proven winners of one Newton row per pose (from q_ref); the others ranked as ik ranks
        out[:], proven, reference_rows = _calibrated_nearest(model, g, poses, reference, weight)
        rows, blocks = np.flatnonzero(~proven), []
        if rows.size:   # beside a singular wrist ik's own code, the others ranked in one block
            alone, *solved = _calibrated_split(model, g, poses[rows], theta6_ref[rows])
            for row in rows[alone]:
                out[row] = _nearest_alone(model, poses[row], reference[row], weight)
            rows = rows[~alone]
            blocks = [(rows,) + _calibrated_ranking(model, g, poses[rows], tuple(solved), reference_rows[rows])]
    else:   # the closed-form kernel, FK filter on the winners; near-singular poses redone by ik_all's code
        redo = []
        for block in _kernel_blocks(g, poses, NEAREST_BLOCK):
            rows, near_singular = block[0], block[5]
            out[rows] = _nearest_of_block(g, block, reference[rows].T, weight).T
            if near_singular.any():
                redo.append(rows.start + np.flatnonzero(near_singular))
        rows = np.concatenate(redo) if redo else np.empty(0, dtype=int)
        blocks = [(rows,) + _redone_rows(model, poses, rows, theta6_ref)] if redo else []
    for rows, columns, valid, *_ in blocks:
        variants, cost = _variant_costs(g, columns, reference[rows].T[:, None, :], weight)
        out[rows] = _ranked_choice(model, g, (columns, variants, cost, valid), poses[rows]).T
    return out


def _nearest_alone(model, pose: np.ndarray, reference: np.ndarray, weight) -> np.ndarray:
    """(6,) ``ik``'s answer for one pose (8,) of a batch (_singular_wrist_poses), NaN where ik finds it
    unreachable."""
    try:
        return ik(model, pose, reference, weight)
    except UnreachablePoseError:
        return np.full(6, np.nan)


def _ranked_choice(model, g: _Geometry, ranking: tuple, poses: np.ndarray) -> np.ndarray:
    """(6, R) per pose (R, 8) the in-limit variants of its least-cost allowed branch, ``ranking`` = (branches
    (6, k, R), their variants (6, k, R), costs (k, R), allowed (k, R)); NaN where none is allowed.

    On a calibrated model the winner's variants pass the FK filter as ik's ranking requires (nearest._passes,
    _shifted_rows_filter's rule: known where each joint is a 2π shift of Newton's, checked where one is clamped
    onto a limit), a rejected branch dropped and the next taken: a 50 m tool turns a 1e-10 rad clamp into 5e-9 m."""
    columns, variants, cost, valid = ranking
    best, least = _select(cost, valid)
    while g.calibrated:
        picked = np.flatnonzero(least < np.inf)
        joints = _chosen(variants, best, least)[:, picked]
        failed = picked[~_shifted_rows_filter(model, g, joints.T, columns[:, best[picked], picked].T, poses[picked])]
        if not failed.size:
            break
        valid = valid.copy()
        valid[best[failed], failed] = False
        best[failed], least[failed] = _select(cost[:, failed], valid[:, failed])
    return _chosen(variants, best, least)
