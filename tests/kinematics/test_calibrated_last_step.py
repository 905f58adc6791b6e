"""A calibrated Newton refinement stops without a last FK when every row's step provably ends it
(calibrated._stepped_bound): the bound holds against the exact residual, and the answers are those of the refinement
that measures its rows once more."""
import math

import numpy as np
import pytest

from calibrated_arms import factory_model
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics.ur_ik import calibrated
from ur3dq.kinematics.ur_ik.geometry import CALIBRATED_TOLERANCE, _geometry
from ur3dq.kinematics.ur_ik.newton_floats import float_joints

MODELS = [("ur3", 31), ("ur5e", 32), ("ur10e", 33)]


def exact_residual(g, q: np.ndarray, rotation_t: np.ndarray, position_t: np.ndarray) -> np.ndarray:
    """(R, 6) errors e of joints q (R, 6) against one target, in extended precision (np.longdouble, 64-bit mantissa on
    x86): the float kernels' chain and residual (newton_floats.float_frames, float_residual) per column, the
    table's constants (a, d, offset, cos α, sin α) taken as exact."""
    wide = np.longdouble
    x, y, z = (np.array(v, dtype=wide)[:, None] for v in np.eye(3))
    p = np.zeros((3, 1), dtype=wide)
    for angle, (a, d, offset, cos_alpha, sin_alpha) in zip(q.T.astype(wide), float_joints(g.joints)):
        c, s = np.cos(angle + wide(offset)), np.sin(angle + wide(offset))
        x, turned = c * x + s * y, c * y - s * x
        p = p + wide(d) * z + wide(a) * x
        y, z = wide(cos_alpha) * turned + wide(sin_alpha) * z, wide(cos_alpha) * z - wide(sin_alpha) * turned
    target = rotation_t.astype(wide)
    position = position_t.astype(wide)[:, None] - p
    axial = 0.5 * sum(np.cross(column, target[:, c][:, None], axis=0) for c, column in enumerate((x, y, z)))
    return np.concatenate((position, axial)).T.astype(float)


@pytest.mark.parametrize("name, seed", MODELS)
def test_stepped_bound_holds_after_the_step(name, seed):
    """Rows 1e-10 to 1e-1 rad from solutions: after one step, the exact residual is within _stepped_bound of each
    row, up to the rounding of the measured error it stepped on (|e − e_exact|, which the bound takes as exact)."""
    model = factory_model(name, seed)
    g = _geometry(model)
    terms, curvature = calibrated._joint_terms(g), calibrated._curvature_bound(g)
    rng = np.random.default_rng(seed)
    met = 0
    for joints in rng.uniform(-math.pi, math.pi, (60, 6)):
        pose = model.fk(joints)
        pair = np.concatenate((pose.to_array()[:4], pose.translation))[None]   # (qw, qx, qy, qz, px, py, pz)
        rotation_t, position_t = calibrated._target_matrices(pair)
        q = joints + rng.normal(0.0, 1.0, (8, 6)) * 10.0 ** rng.uniform(-10.0, -1.0, (8, 1))
        error, frames = calibrated._matrix_residual(terms, q, (rotation_t, position_t))
        delta, solved = calibrated._matrix_step(frames, error)
        assert solved
        after = np.linalg.norm(exact_residual(g, q + delta, rotation_t[0], position_t[0]), axis=1)
        rounding = np.linalg.norm(exact_residual(g, q, rotation_t[0], position_t[0]) - error[:, :6], axis=1)
        measured = np.linalg.norm(error[:, :6], axis=1)
        for row in range(len(q)):
            bound = calibrated._stepped_bound(error[row:row + 1], measured[row:row + 1], delta[row:row + 1], curvature)
            assert after[row] <= bound + rounding[row], (q[row], after[row], bound, rounding[row])
            met += bound <= 0.01 * CALIBRATED_TOLERANCE
    assert met > 60   # the regime where the bound ends a refinement is exercised


def test_stepped_bound_is_infinite_for_a_flange_facing_away():
    """A flange 60° or more from its target (trace of R_t·Rᵀ ≤ 2) gets no bound, whatever its small error."""
    error = np.zeros((2, 7))
    error[:, 6] = [3.0, 2.0]
    assert calibrated._stepped_bound(error, np.zeros(2), np.full((2, 6), 1e-9), 10.0) == math.inf
    error[1, 6] = 2.5
    assert calibrated._stepped_bound(error, np.zeros(2), np.full((2, 6), 1e-9), 10.0) < 1e-12


def least_singular_value(model, q) -> float:
    """σ of the calibrated chain's 6×6 Jacobian at joints q."""
    frames = calibrated._chain_frames(calibrated._joint_terms(_geometry(model)), np.asarray(q)[None])
    return float(np.linalg.svd(calibrated._jacobian_rows(frames)[:, 0], compute_uv=False)[-1])


def same_solution(model, a, b) -> bool:
    """Whether joints a and b are one solution to Newton's rounding: 4e-12/σ + 1e-12 rad per joint, mod 2π."""
    apart = np.abs(np.remainder(np.asarray(a) - np.asarray(b) + math.pi, 2 * math.pi) - math.pi).max()
    return apart < 4e-12 / least_singular_value(model, a) + 1e-12


@pytest.mark.parametrize("name, seed", MODELS)
def test_a_refinement_ended_by_the_bound_answers_as_the_one_ended_by_an_fk(name, seed, monkeypatch):
    """ik_all and ik with the bound-ended last step against the path before (one more FK measures every row): the
    same solutions, to Newton's rounding (bit for bit where the table's rounding floor is below the stopping error;
    where it is above, as on the UR10e table here, the FK-ended rows step on through rounding noise until it stops
    halving), none lost or gained; with fewer FK evaluations."""
    model = factory_model(name, seed)
    rng = np.random.default_rng(seed + 1)
    q = rng.uniform(-math.pi, math.pi, (150, 6))
    q[::3, 4] = rng.normal(0.0, 0.05, 50)   # beside a singular wrist: patient and turned seeds
    refs = q + rng.normal(0.0, 0.02, q.shape)
    evaluations = []
    matrix_residual = calibrated._matrix_residual
    monkeypatch.setattr(calibrated, "_matrix_residual", lambda *a: (evaluations.append(1), matrix_residual(*a))[1])

    def answers():
        out = []
        for joints, reference in zip(q, refs):
            pose = model.fk(joints)
            try:
                out.append((np.array(model.ik_all(pose)), model.ik(pose, reference)))
            except UnreachablePoseError as error:
                out.append(str(error))
        return out

    ended = answers()
    with_bound = len(evaluations)
    evaluations.clear()
    monkeypatch.setattr(calibrated, "_LAST_STEP_ERROR", -1.0)   # no bound: every row stops on an FK
    for before, after, joints in zip(answers(), ended, q):
        assert type(before) is type(after), joints
        if isinstance(before, str):
            assert before == after
            continue
        assert len(before[0]) == len(after[0]), joints
        for solution in after[0]:
            assert any(same_solution(model, solution, other) for other in before[0]), (joints, solution)
        assert same_solution(model, after[1], before[1]), joints
    assert with_bound < len(evaluations)
