"""IK of calibrated arms (factory-style DH tables): ``ik`` is the full ranking's answer, the isolation proof and the
curvature bound it rests on hold, Newton's residual tells a flange facing away, and the configurations beside a
singular wrist that the nominal seeds once missed are found (``ur3dq.kinematics.ur_ik.newton``, ``solve``)."""
import math

import numpy as np
import pytest

from calibrated_arms import factory_model
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics import fk
from ur3dq.kinematics.arm import THIRD_DERIVATIVE, arm_vector
from ur3dq.kinematics.models import URModel
from ur3dq.kinematics.ur_ik import CALIBRATED_TOLERANCE, LIMIT_ROUNDING, frames, ik_all_batch, nearest, newton, solve

MODELS = [("ur3", 21), ("ur5e", 22), ("ur10e", 23), ("ur10e", 24)]


def hard_configurations(count: int, seed: int) -> np.ndarray:
    """(count, 6) joints: a quarter regular in (−π, π], the others with |sin θ5| or |sin θ3| between 1e-4 and 0.05
    (the wrist or elbow near singular) or one joint at ±2π (or a float step inside)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-math.pi, math.pi, (count, 6))
    kind = np.arange(count) % 4
    small = rng.choice([-1.0, 1.0], count) * 10.0 ** rng.uniform(-4.0, math.log10(0.05), count)
    wrist, elbow, limit = kind == 1, kind == 2, kind == 3
    q[wrist, 4] = small[wrist] + rng.choice([0.0, math.pi], wrist.sum())
    q[elbow, 2] = small[elbow]
    ends = [2 * math.pi, -2 * math.pi, np.nextafter(2 * math.pi, 0.0), np.nextafter(-2 * math.pi, 0.0)]
    for row in np.flatnonzero(limit):
        q[row, rng.choice([0, 1, 3])] = ends[rng.integers(4)]
    return q


def goal(model, pose) -> np.ndarray:
    """The kernels' goal of a TCP pose (8 coefficients or a DualQuaternion)."""
    out = np.empty(frames.GOAL_SIZE)
    frames.goal_of(arm_vector(model), np.asarray(pose.to_array() if hasattr(pose, "to_array") else pose, float), out)
    return out


def ranked(model, pose, reference, weights):
    """ik's answer by the full ranking, no proof: every candidate (Newton from the 8 seeds, their wrist turns, and
    from the reference), nearest in-limit variants first, the first that passes the FK filter; or the error type."""
    arm, target, chain = arm_vector(model), goal(model, pose), np.empty((7, 12))
    rows = np.full((9, 6), np.nan)
    solve.candidates(arm, target, float(solve.wrap(reference[5])), rows[:8], chain)
    rows[8] = reference
    if not newton.refine(arm, rows[8], target, chain) <= CALIBRATED_TOLERANCE:
        rows[8] = np.nan
    best, best_cost, variant = None, math.inf, np.empty(6)
    for row in rows[np.isfinite(rows[:, 0])]:
        for rounding in (LIMIT_ROUNDING, 0.0):   # a joint clamped onto a limit, or strictly inside
            cost = solve.variants(arm, row, reference, weights, rounding, variant)[0]
            if cost < best_cost and solve.meets(arm, variant, target, chain):
                best, best_cost = variant.copy(), cost
    return UnreachablePoseError if best is None else best


def least_singular_value(model, q) -> float:
    """σ of the calibrated chain's 6×6 Jacobian at joints q."""
    return float(np.linalg.svd(jacobian(model, q), compute_uv=False)[-1])


def jacobian(model, q) -> np.ndarray:
    """(6, 6) base-frame Jacobian [z_i × (p − o_i); z_i] of the DH chain at joints q."""
    chain = np.empty((7, 12))
    fk.chain_frames(arm_vector(model), np.asarray(q, dtype=float), chain)
    axes, origins, end = chain[:6, 6:9], chain[:6, 9:12], chain[6, 9:12]
    return np.concatenate((np.cross(axes, end - origins), axes), axis=1).T


def flange_vector(arm: np.ndarray, q: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """F = (flange position, rotation columns / √2) (12) of the DH chain at joints q: newton.isolated's map."""
    fk.chain_frames(arm, q, chain)
    return np.concatenate((chain[6, 9:12], chain[6, :9] / math.sqrt(2)))


def flange_jacobian(arm: np.ndarray, q: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """(12, 6) Jacobian of flange_vector: zᵢ × (p − oᵢ) and zᵢ × r_c / √2."""
    fk.chain_frames(arm, q, chain)
    axes, levers = chain[:6, 6:9], chain[6, 9:12] - chain[:6, 9:12]
    rotation = [np.cross(axes, chain[6, 3 * c:3 * c + 3]) / math.sqrt(2) for c in range(3)]
    return np.concatenate((np.cross(axes, levers), *rotation), axis=1).T


def flange_hessian(arm: np.ndarray, q: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """(6, 6, 12) second derivatives of flange_vector: zᵢ × (zⱼ × (v − oⱼ)) for i ≤ j."""
    fk.chain_frames(arm, q, chain)
    axes, out = chain[:6, 6:9], np.empty((6, 6, 12))
    for i, j in zip(*np.triu_indices(6), strict=True):
        vectors = [chain[6, 9:12] - chain[j, 9:12], *(chain[6, 3 * c:3 * c + 3] / math.sqrt(2) for c in range(3))]
        out[i, j] = out[j, i] = np.concatenate([np.cross(axes[i], np.cross(axes[j], v)) for v in vectors])
    return out


@pytest.mark.parametrize("name, seed", MODELS)
def test_ik_equals_the_full_ranking_on_factory_tables(name, seed):
    model = factory_model(name, seed)
    q = hard_configurations(400, seed)
    rng = np.random.default_rng(seed + 100)
    refs = q + rng.normal(0.0, 1.0, q.shape) * np.array([0.0, 1e-6, 1e-4, 1e-2, 0.3])[np.arange(len(q)) % 5, None]
    poses = model.fk_batch(q)
    batch = model.ik_batch(poses, refs)
    for row, (pose, reference) in enumerate(zip(poses, refs, strict=False)):
        weights = np.ones(6) if row % 3 else rng.uniform(0.2, 5.0, 6)
        expected = ranked(model, pose, reference, weights)
        try:
            answer = model.ik(pose, reference, weights)
        except UnreachablePoseError:
            answer = UnreachablePoseError
        if row % 3:
            np.testing.assert_array_equal(batch[row], answer if answer is not UnreachablePoseError else np.nan)
        if expected is UnreachablePoseError or answer is UnreachablePoseError:
            assert answer is expected, (q[row], reference)
            continue
        # Newton's copies of one solution lie up to ~2e-12/σ apart: the proof returns the one from q_ref.
        atol = 4e-12 / least_singular_value(model, expected) + 1e-12
        np.testing.assert_allclose(answer, expected, rtol=0, atol=atol, err_msg=str((q[row], reference)))


@pytest.mark.parametrize("name, seed", MODELS[:2])
def test_isolation_proof_never_claims_a_radius_another_solution_lies_in(name: str, seed: int) -> None:
    model = factory_model(name, seed)
    arm, chain, isolated = arm_vector(model), np.empty((7, 12)), 0
    for joints in hard_configurations(150, seed + 300):
        try:
            solutions = np.array(model.ik_all(model.fk(joints)))
        except UnreachablePoseError:
            continue
        for i, a in enumerate(solutions):
            for j, b in enumerate(solutions):
                apart = np.linalg.norm(np.remainder(a - b + math.pi, 2 * math.pi) - math.pi)
                if i != j:
                    assert not newton.isolated(arm, a, apart * (1 + 1e-9) + 1e-12, chain), (a, b)
            isolated += newton.isolated(arm, a, 0.05, chain)
    assert isolated > 100   # the proof does decide, at the distance of a reference 0.01 rad per joint off


def near_pairs(model: URModel, count: int, seed: int) -> list[tuple[np.ndarray, float]]:
    """(solution, distance to the nearest other solution) of ``count`` configurations beside the stretched elbow
    (|θ3| in 0.01–0.05: the fold where two branches meet) with another solution within 0.1 rad."""
    rng, pairs = np.random.default_rng(seed), []
    while len(pairs) < count:
        q = rng.uniform(-math.pi, math.pi, 6)
        q[2] = rng.choice([-1.0, 1.0]) * rng.uniform(0.01, 0.05)
        solutions = np.array(model.ik_all(model.fk(q)))
        offsets = np.linalg.norm(np.remainder(solutions - q + math.pi, 2 * math.pi) - math.pi, axis=1)
        apart = np.sort(offsets)
        if apart[0] < 1e-6 and len(apart) > 1 and apart[1] < 0.1:
            pairs.append((solutions[np.argmin(offsets)], float(apart[1])))
    return pairs


@pytest.mark.parametrize("name, seed", MODELS[:2])
def test_isolation_proof_stops_short_of_a_near_second_solution_and_holds_nearer(name: str, seed: int) -> None:
    """Beside a fold the proof must not reach the other solution, and still holds at a fraction of its distance (the
    bound proves 1/8 to 1/25 of it there: it does not use that only the fold's direction is weak)."""
    model = factory_model(name, seed)
    arm, chain, held = arm_vector(model), np.empty((7, 12)), 0
    for solution, apart in near_pairs(model, 40, seed):
        assert not newton.isolated(arm, solution, apart * (1 + 1e-9), chain), solution
        held += newton.isolated(arm, solution, apart / 30, chain)
    assert held >= 30


@pytest.mark.parametrize("name, seed", MODELS[:2])
def test_isolation_proof_decides_by_its_documented_inequality(name: str, seed: int) -> None:
    """newton.isolated holds exactly up to the radius where a·g/t + ½·β·t + a·M₃·t²/6 reaches 1 − PROOF_MARGIN,
    each figure recomputed here with numpy (a = √trace((JᵀJ)⁻¹), β from the Hessian): a bound made looser (a term
    dropped or shrunk) proves beyond that radius and fails here."""
    model = factory_model(name, seed)
    arm, chain, rng = arm_vector(model), np.empty((7, 12)), np.random.default_rng(seed)
    for x in np.concatenate((rng.uniform(-math.pi, math.pi, (60, 6)), hard_configurations(60, seed))):
        jacobian_x, h = flange_jacobian(arm, x, chain), flange_hessian(arm, x, chain)
        normal = jacobian_x.T @ jacobian_x
        pseudo, a = np.linalg.solve(normal, jacobian_x.T), math.sqrt(np.trace(np.linalg.inv(normal)))
        beta, gap = math.sqrt(np.sum(np.einsum("km,ijm->ijk", pseudo, h) ** 2)), newton.SOLUTION_GAP

        def spare(t: float, a: float = a, beta: float = beta, gap: float = gap) -> float:
            return 1.0 - newton.PROOF_MARGIN - a * gap / t - 0.5 * beta * t - a * arm[THIRD_DERIVATIVE] * t * t / 6

        if spare(2 * a * gap) <= 0:
            assert not newton.isolated(arm, x, 1.0, chain)
            continue
        low, high = 2 * a * gap, 10.0
        for _ in range(60):   # the radius where spare() turns negative
            low, high = ((low + high) / 2, high) if spare((low + high) / 2) > 0 else (low, (low + high) / 2)
        assert newton.isolated(arm, x, low * (1 - 1e-6), chain), x
        assert not newton.isolated(arm, x, low * (1 + 1e-6), chain), x


@pytest.mark.parametrize("name, seed", MODELS[:3])
def test_second_order_bound_is_that_of_the_exact_hessian(name: str, seed: int) -> None:
    """newton.second_order's β² = Σᵢⱼ |A·Fᵢⱼ|² against the Hessian of F = (p, columns / √2) built here with numpy
    (checked against central differences of the Jacobian), and Taylor's third-order remainder against M₃."""
    model = factory_model(name, seed)
    arm, chain, bound = arm_vector(model), np.empty((7, 12)), arm_vector(model)[THIRD_DERIVATIVE]
    rng = np.random.default_rng(seed)
    for x in rng.uniform(-math.pi, math.pi, (100, 6)):
        value, jacobian_x = flange_vector(arm, x, chain), flange_jacobian(arm, x, chain)
        h, step = flange_hessian(arm, x, chain), 1e-5
        for j in range(6):
            shift = np.eye(6)[j] * step
            difference = flange_jacobian(arm, x + shift, chain) - flange_jacobian(arm, x - shift, chain)
            np.testing.assert_allclose(difference / (2 * step), h[:, j].T, rtol=0, atol=1e-6)   # table rounding / step
        pseudo = np.linalg.solve(jacobian_x.T @ jacobian_x, jacobian_x.T)
        normal, rhs, rows, lower = np.empty((6, 6)), np.empty(6), np.empty((6, 6)), np.empty((6, 6))
        fk.chain_frames(arm, x, chain)
        newton.normal_equations(chain, np.zeros(6), normal, rhs, rows)
        assert newton.cholesky(normal, 0.0, 0.0, lower)
        expected = float(np.sum(np.einsum("km,ijm->ijk", pseudo, h) ** 2))
        rounding = 1e-9 + 1e-13 * np.linalg.cond(jacobian_x.T @ jacobian_x)   # two solves of (JᵀJ)·x = b
        assert newton.second_order(rows, lower) == pytest.approx(expected, rel=rounding)
        d = rng.normal(0.0, 1.0, 6) * 10.0 ** rng.uniform(-3.0, 0.0)
        taylor = value + jacobian_x @ d + 0.5 * np.einsum("i,j,ijk->k", d, d, h)
        assert np.linalg.norm(flange_vector(arm, x + d, chain) - taylor) <= bound * np.linalg.norm(d) ** 3 / 6 + 1e-12


@pytest.mark.parametrize("name, seed", [("ur3", 31), ("ur10e", 32)])
def test_ik_with_a_near_reference_equals_the_full_ranking(name: str, seed: int) -> None:
    """References 0.003–0.03 rad per joint from a configuration (a third beside a singularity or at ±2π), as a path
    of small steps gives them: every answer is the full ranking's, the proof decides half the poses, and it decides
    by the span nearest.reference_row documents (|out − q_ref| + √(c / min w) + 5·LIMIT_ROUNDING): a span cut
    short would decide more poses, and a bound as conservative as this one would hide it from the ranking."""
    model = factory_model(name, seed)
    rng = np.random.default_rng(seed)
    q = np.concatenate((rng.uniform(-math.pi, math.pi, (500, 6)), hard_configurations(250, seed)))
    refs = q + rng.normal(0.0, 1.0, q.shape) * 10.0 ** rng.uniform(-2.5, -1.5, (len(q), 1))
    weights = np.where(np.arange(len(q))[:, None] % 3, 1.0, rng.uniform(0.2, 5.0, q.shape))
    poses, arm, chain, proved = model.fk_batch(q), arm_vector(model), np.empty((7, 12)), 0
    for pose, reference, weight in zip(poses, refs, weights, strict=True):
        expected = ranked(model, pose, reference, weight)
        answer = model.ik_batch(pose[None], reference[None], weight)[0]
        if expected is UnreachablePoseError:
            assert np.isnan(answer).all()
            continue
        atol = 4e-12 / least_singular_value(model, expected) + 1e-12
        np.testing.assert_allclose(answer, expected, rtol=0, atol=atol, err_msg=str(reference))
        target, out, row = goal(model, pose), np.empty(6), np.empty(6)
        decided = nearest.reference_row(arm, target, reference, weight, out, chain, row)
        if np.isfinite(row).all():
            cost = float(np.sum(weight * (out - reference) ** 2))
            span = np.linalg.norm(out - reference) + math.sqrt(cost / weight.min()) + 5 * LIMIT_ROUNDING
            assert decided == ((cost == 0 or newton.isolated(arm, row, span, chain))
                               and solve.meets(arm, out, target, chain))
        proved += decided
    assert proved >= 0.4 * len(q)


def test_a_seed_with_an_exactly_singular_jacobian_takes_a_bounded_step():
    """Beside the singular wrist (θ5 = π − 1.8e-4) the seed at θ5 = π has an exactly singular Jacobian: the damped
    step stays bounded and every answer is a verified solution."""
    model = factory_model("ur10e", 73)
    q = np.array([2.215134511018282, 1.5390903755923233, 1.2738721622232836, 2.1093858663185454,
                  3.141416101479907, 3.0261392082218075])
    pose = model.fk(q)
    solutions = model.ik_all(pose)
    assert any(np.allclose(solution, q, rtol=0, atol=1e-6) for solution in solutions)
    for answer in [*solutions, model.ik(pose, q + 0.3), model.ik_batch(pose.to_array()[None], (q + 0.3)[None])[0]]:
        assert model.fk(answer).is_close(pose, 1e-9, 1e-9), answer


def test_a_row_at_zero_error_facing_away_from_its_target_is_no_solution():
    """Newton's rotation error sin φ·axis vanishes at φ = π: a flange turned half a turn about its z axis from the
    target has zero error, yet is no solution; its residual is inf (from the trace of R_t·Rᵀ)."""
    model = factory_model("ur10e", 24)
    arm, chain = arm_vector(model), np.empty((7, 12))
    q = np.array([0.3, -1.2, 1.1, -0.4, 0.9, 0.2])
    turned = goal(model, model.fk(q) * DualQuaternion.from_axis_angle([0.0, 0.0, 1.0], math.pi))
    assert newton.refine(arm, q.copy(), turned, chain) == math.inf
    assert newton.refine(arm, q.copy(), goal(model, model.fk(q)), chain) <= CALIBRATED_TOLERANCE


#: A UR3 factory table's configuration at θ5 = −0.0015 whose nominal seeds of its (θ1, elbow) pair both diverge: the
#: turns of the wrist's family find it.
MISSED = [-1.1612051042373295, 1.379655701486345, -2.9196383056944066, -2.9158776758500142, -0.0014765392074586267,
          2.3150071628319635]
MISSED_REFERENCE = [-1.181891637719581, 1.298038699419245, -2.8380830971919506, -2.9084284109361933,
                    -0.07414182876320465, 2.369044842943544]
#: Configurations beside a singular wrist whose own seeds wander for several steps before they converge.
WANDERING = [
    ("ur10", 1, [-2.6545893776333913, 2.965088302181308, 2.8319959077912245, -0.952980456428536,
                 0.01162954968941295, -2.219696976356699]),
    ("ur3e", 1, [-1.8441883077367531, 1.6645534075697554, 0.273603078557477, 2.6203465803622663,
                 0.03568688378252453, 2.3173657323280414]),
    ("ur5e", 1, [1.1011201066150917, -2.9827667901993404, -2.755392952170523, -2.29526860249773,
                 -0.04074190690989708, 1.77744362328475]),
]


def distance(a, b) -> float:
    """Largest joint difference of a and b (6,) modulo 2π."""
    return float(np.max(np.abs(np.remainder(np.asarray(a) - b + math.pi, 2 * math.pi) - math.pi)))


def test_ik_all_and_ik_find_the_configuration_both_nominal_seeds_missed():
    model = factory_model("ur3", 1).with_tcp([0.01, -0.02, 0.15, 0.1, 0.2, -0.3])
    pose = model.fk(MISSED)
    assert min(distance(solution, MISSED) for solution in model.ik_all(pose)) < 1e-8
    assert distance(model.ik(pose, MISSED_REFERENCE), MISSED) < 1e-8
    poses = model.fk_batch(np.array([MISSED]))
    assert distance(model.ik_batch(poses, np.array([MISSED_REFERENCE]))[0], MISSED) < 1e-8
    rows = ik_all_batch(model, poses)[0]
    assert min(distance(row, MISSED) for row in rows if np.isfinite(row).all()) < 1e-8


@pytest.mark.parametrize("name, seed, q", WANDERING)
def test_seeds_that_wander_beside_a_singular_wrist_still_converge(name, seed, q):
    model = factory_model(name, seed)
    assert min(distance(solution, q) for solution in model.ik_all(model.fk(q))) < 1e-8


@pytest.mark.parametrize("name, seed", [("ur3", 0), ("ur5e", 1), ("ur10", 2)])
def test_beside_a_singular_wrist_every_solution_is_verified_and_distinct(name, seed):
    model = factory_model(name, seed)
    rng = np.random.default_rng(seed)
    q = rng.uniform(-math.pi, math.pi, (60, 6))
    q[:, 4] = rng.choice([-1.0, 1.0], 60) * 10 ** rng.uniform(-6, -1, 60) + rng.choice([0.0, math.pi], 60)
    found = 0
    for joints, pose in zip(q, model.fk_batch(q), strict=False):
        solutions = model.ik_all(pose)
        for i, solution in enumerate(solutions):
            assert model.fk(solution).is_close(DualQuaternion.from_array(pose), 1e-9, 1e-9)
            assert all(distance(solution, other) >= 1e-6 for other in solutions[:i])
        found += min(distance(solution, joints) for solution in solutions) < 1e-6
    # Beside a singular wrist a calibrated arm can have more than 8 solutions; ik_all lists 8 at most.
    assert found >= 50
