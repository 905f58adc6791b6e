"""Batches of poses: every solution (`ik_all_batch`) and the nearest one (`ik_batch`), block by block."""
from __future__ import annotations

import numpy as np

from ur3dq import dqarray
from ur3dq.kinematics.ur_ik.batch_kernels import _regular_branches, _regular_fk_filter
from ur3dq.kinematics.ur_ik.calibrated import _refine_batch
from ur3dq.kinematics.ur_ik.equations import _ArrayOps, _branches, wrap_angle
from ur3dq.kinematics.ur_ik.fk_filter import _EXACT_UNIT, _within_fk_tolerance
from ur3dq.kinematics.ur_ik.geometry import (
    LIMIT_ROUNDING,
    _flange_of,
    CALIBRATED_TOLERANCE,
    DUPLICATE_TOLERANCE,
    IK_BLOCK,
    _Geometry,
    _TWO_PI,
    _geometry,
    _translation_columns,
)
from ur3dq.kinematics.ur_ik.nearest import _weights
from ur3dq.kinematics.ur_ik.single import _branch_table


def _batch_poses(poses) -> np.ndarray:
    """(N, 8) unit dual quaternions; ValueError naming ``poses`` for a wrong shape, NaN/inf or non-unit rows.

    Rows off unit by more than rounding (but within dqarray.UNIT_TOLERANCE) are normalised, as single poses are
    (fk_filter._pose_coefficients): the same pose gives the same answer in both paths."""
    array = np.asarray(poses, dtype=float)
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


def _batch_candidates(g: _Geometry, targets: tuple, theta6_ref) -> np.ndarray:
    """(6, 8, N) canonical analytic branches (joint, branch, pose) of flange targets (seven (N,) arrays).

    Joint-major layout: every joint of every branch is one contiguous run, which is what the elementwise
    kernels (and the model's fk_batch, reading columns) want; refined by Newton first on calibrated models.
    """
    count = len(targets[0])
    columns = np.empty((6, 8, count))
    for k, branch in enumerate(_branches(_ArrayOps, g, targets, theta6_ref)):
        for j, value in enumerate(branch):
            columns[j, k] = value
    if g.calibrated:
        flat = columns.reshape(6, -1).T
        repeated = np.tile(np.stack(targets, axis=-1), (8, 1))
        usable = np.all(np.isfinite(flat), axis=1)
        refined, residual = _refine_batch(g, flat[usable], repeated[usable])
        flat = flat.copy()
        flat[usable] = np.where((residual <= CALIBRATED_TOLERANCE)[:, None], refined, np.nan)
        columns = np.ascontiguousarray(flat.T).reshape(6, 8, count)
    # θ2, θ3 come from atan2 already in (−π, π]; θ1, θ4, θ6 are sums and θ5 may be −π.
    for j in (0, 3, 4, 5):
        columns[j] = wrap_angle(columns[j])
    return columns


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
    closed-form kernel; its poses near a wrist or elbow singularity are collected and redone last, one by
    one, by ik_all's own scalar path (single._branch_table), so that both paths merge the same branch pairs. Calibrated models take the general equations and
    Newton throughout.
    """
    if g.calibrated:
        columns = _batch_candidates(g, _batch_flange_targets(g, poses), theta6_ref)
        yield slice(0, len(poses)), columns, _fk_filter(model, columns, poses), np.ones(len(poses), dtype=bool)
        return
    redo = []
    for start in range(0, len(poses), IK_BLOCK):
        rows = slice(start, start + IK_BLOCK)
        coefficients = np.ascontiguousarray(poses[rows].T)
        pair = _pair_rows(coefficients)
        flange = pair if g.tcp_inverse is None else _pair_rows(_flange_of(coefficients, g.tcp_inverse))
        with np.errstate(divide="ignore", invalid="ignore"):   # exact singularities: those poses are redone
            columns, exists, merged, near_singular = _regular_branches(g, flange)
        valid = _regular_fk_filter(g, columns, pair)
        valid &= exists
        if near_singular.any():
            valid[:, near_singular] = False
            redo.append(start + np.flatnonzero(near_singular))
        yield rows, columns, valid, merged
    if redo:
        rows = np.concatenate(redo)
        columns, valid = np.empty((6, 8, len(rows))), np.empty((8, len(rows)), dtype=bool)
        for i, row in enumerate(rows):
            columns[:, :, i].T[:], valid[:, i] = _branch_table(model, poses[row], float(theta6_ref[row]))
        yield rows, columns, valid, np.zeros(len(rows), dtype=bool)


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
    reference = np.asarray(q_ref, dtype=float)
    if reference.shape == (6,):
        reference = np.broadcast_to(reference, (count, 6))
    if reference.shape != (count, 6):
        raise ValueError(f"q_ref: expected shape (6,) or ({count}, 6), got {reference.shape}")
    if not np.all(np.isfinite(reference)):
        raise ValueError("q_ref: contains NaN or infinite values")
    return reference


def _nearest_variants(g: _Geometry, columns: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(6, 8, N) ±2π variants of the branches nearest ``reference`` (6, 1, N) inside the limits; NaN if none fits.

    As _closest_variant: the nearest variant of all when it is inside, else the end of the in-limit run on its side.
    """
    centre = columns + _TWO_PI * np.rint((reference - columns) / _TWO_PI)
    lower, upper = np.array(g.lower)[:, None, None], np.array(g.upper)[:, None, None]
    with np.errstate(invalid="ignore"):   # ±inf limits: their end is never selected
        first = columns + _TWO_PI * np.ceil((lower - columns) / _TWO_PI)
        first = np.where(first < lower, first + _TWO_PI, first)
        last = columns + _TWO_PI * np.floor((upper - columns) / _TWO_PI)
        last = np.where(last > upper, last - _TWO_PI, last)
    # A centre a rounding outside a limit is the limit itself (a joint at exactly ±2π), as in _closest_variant.
    centre = np.where((centre < lower) & (centre >= lower - LIMIT_ROUNDING), lower, centre)
    centre = np.where((centre > upper) & (centre <= upper + LIMIT_ROUNDING), upper, centre)
    best = np.where(centre < lower, first, np.where(centre > upper, last, centre))
    return np.where((best >= lower) & (best <= upper), best, np.nan)


def ik_batch(model, poses, q_ref, weights=None) -> np.ndarray:
    """(N, 6): for each (N, 8) TCP pose the solution nearest q_ref ((6,) or (N, 6)) as in ``ik``; NaN rows where
    the pose is unreachable or no solution lies inside the joint limits (no exception: batches keep going)."""
    poses = _batch_poses(poses)
    reference = _batch_reference(q_ref, len(poses))
    weight = np.array(_weights(weights))[:, None, None]
    g = _geometry(model)
    out = np.empty((len(poses), 6))
    for rows, columns, valid, _ in _solved_blocks(model, g, poses, wrap_angle(reference[:, 5])):
        # Duplicates cannot change which branch is nearest: only the FK filter is needed here.
        reference_columns = reference[rows].T[:, None, :]
        variants = _nearest_variants(g, columns, reference_columns)
        cost = np.sum(weight * (variants - reference_columns) ** 2, axis=0)
        cost = np.where(valid & ~np.isnan(cost), cost, np.inf)
        best = np.argmin(cost, axis=0)
        chosen = np.take_along_axis(variants, best[None, None, :], axis=1)[:, 0, :].T
        reachable = np.isfinite(np.take_along_axis(cost, best[None, :], axis=0)[0])
        out[rows] = np.where(reachable[:, None], chosen, np.nan)
    return out
