"""The cases an outside audit found (each failed before the compiled kernel): a calibrated UR10e table as a person
types it, ik_batch against ik on singular poses, a singular wrist beside a ±2π limit, joints at ±2π beside a
stretched elbow, degenerate tables, and the CLI's nearest-variant rule at a 2π limit."""
import math

import numpy as np
import pytest

from calibrated_arms import factory_model
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics import MODEL_NAMES, robot_model, robot_model_from_dh, ur_ik
from ur3dq.kinematics.arm import arm_vector
from ur3dq.kinematics.ur_ik import CALIBRATED_TOLERANCE, frames, newton
from ur3dq.replay import nearest_variant

#: sim_ursim's UR10E_DOCUMENTED rounded to 4–5 digits, as a person types it from UR's document: 4–7 mm from nominal.
TYPED = {"a": [2.1e-5, 0.0193, -0.5693, -4.6e-5, -6.4e-5, 0.0], "d": [0.1805, 439.14, -446.03, 7.0603, 0.1198, 0.1157],
         "alpha": [1.5701, 0.00139, 0.00694, 1.5700, -1.5704, 0.0],
         "theta": [-2.4e-7, 1.6023, -1.6861, 0.0837, -1.0e-7, 3.9e-8]}


def distance(a, b) -> float:
    """Largest joint difference modulo 2π."""
    return float(np.max(np.abs(ur_ik.wrap_angle(np.asarray(a) - np.asarray(b)))))


def random_seeded_solutions(model, pose, rng, seeds=50) -> list:
    """The distinct solutions damped Newton (Levenberg-Marquardt, newton.refine) reaches from ``seeds`` uniform
    random starts: an oracle that knows nothing of the closed form's branches."""
    arm, goal, chain = arm_vector(model), np.empty(frames.GOAL_SIZE), np.empty((7, 12))
    frames.goal_of(arm, np.asarray(pose, dtype=float), goal)
    found = []
    for q in rng.uniform(-math.pi, math.pi, (seeds, 6)):
        if newton.refine(arm, q, goal, chain) <= CALIBRATED_TOLERANCE and all(distance(q, f) > 1e-6 for f in found):
            found.append(ur_ik.wrap_angle(q))
    return found


def regular(q) -> bool:
    """Away from the wrist and elbow singularities (|sin θ5|, |sin θ3| ≥ 0.1)."""
    return abs(math.sin(q[4])) >= 0.1 and abs(math.sin(q[2])) >= 0.1


@pytest.mark.parametrize("table", ["typed"] + [f"{name}:{seed}" for name in MODEL_NAMES for seed in (1, 2)])
def test_ik_all_finds_every_regular_solution_newton_finds_from_50_random_seeds(table):
    model = robot_model_from_dh("ur10e", **TYPED) if table == "typed" else factory_model(table[:-2], int(table[-1]))
    rng = np.random.default_rng(7)
    missed = []
    for q in rng.uniform(-math.pi, math.pi, (60 if table == "typed" else 12, 6)):
        pose = model.fk(q).to_array()
        ours = model.ik_all(pose)   # never raises on an FK pose
        for solution in random_seeded_solutions(model, pose, rng):
            if regular(solution) and min(distance(solution, s) for s in ours) > 1e-6:
                missed.append((q, solution))
    assert missed == []


def test_the_audits_typed_table_configurations():
    model = robot_model_from_dh("ur10e", **TYPED)
    four_more = [-3.026425, -0.950807, -1.492652, 1.386414, -2.97839, 1.505654]   # 4 found of 8 before
    assert len(model.ik_all(model.fk(four_more))) == 8
    beside_the_base = [2.068137, -2.240949, 1.329572, -1.650219, -0.426616, 0.404068]   # "too close" before
    assert min(distance(s, beside_the_base) for s in model.ik_all(model.fk(beside_the_base))) < 1e-8


def test_ik_all_never_fails_on_an_fk_pose_of_the_typed_table():
    model = robot_model_from_dh("ur10e", **TYPED)
    rng = np.random.default_rng(3)
    q = rng.uniform(-math.pi, math.pi, (3600, 6))
    q[3000:, 4] = rng.normal(0.0, 0.03, 600) + rng.choice([0.0, math.pi], 600)   # beside a singular wrist
    solutions = ur_ik.ik_all_batch(model, model.fk_batch(q))
    assert np.isfinite(solutions[:, :, 0]).any(axis=1).all()
    own = np.nanmin(np.max(np.abs(ur_ik.wrap_angle(solutions - q[:, None])), axis=-1), axis=1)
    assert (own < 1e-8).mean() > 0.99   # the configuration itself too, nearly always (measured: 3579 of 3600)


def singular_configurations(count: int, seed: int) -> np.ndarray:
    """Joints with a wrist or elbow exactly or nearly singular, joints at ±2π, and regular rows between."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2 * math.pi, 2 * math.pi, (count, 6))
    near = np.array([0.0, 1e-15, -1e-12, 1e-9, -1e-7, 1e-5, 1e-3])
    kind = np.arange(count) % 5
    q[kind == 1, 4] = rng.choice(near, (kind == 1).sum()) + rng.choice([0.0, math.pi], (kind == 1).sum())
    q[kind == 2, 2] = rng.choice(near, (kind == 2).sum()) + rng.choice([0.0, math.pi], (kind == 2).sum())
    q[kind == 3, 1] = rng.choice([2 * math.pi, -2 * math.pi], (kind == 3).sum())
    return q


@pytest.mark.parametrize("name", ["ur3", "ur10e"])
def test_ik_batch_is_ik_row_by_row_on_singular_poses(name):
    model = robot_model(name)
    q = singular_configurations(10_000, 11)
    poses = model.fk_batch(q)
    references = q + np.random.default_rng(12).normal(0.0, 0.05, q.shape)
    batch = model.ik_batch(poses, references)
    for pose, reference, row in zip(poses, references, batch, strict=False):
        try:
            single = model.ik(pose, reference)
        except UnreachablePoseError:
            single = np.full(6, np.nan)
        np.testing.assert_array_equal(row, single)


def test_a_singular_wrist_beside_a_2pi_limit_keeps_its_branch():
    """At θ5 = π exactly θ6 = q_ref[5] would put θ4 past −2π: the split moves along the wrist's family until θ4 is at
    its limit, 0.07 rad from q_ref, instead of jumping 3.67 rad to another θ1 branch."""
    model = robot_model("ur3")
    q = np.array([0.8835, -4.6876, 1.615, -6.2696, math.pi, -1.1331])
    reference = np.array([0.8888, -4.6939, 1.6324, -6.2832, 3.0852, -1.1628])
    answer = model.ik(model.fk(q), reference)
    assert np.max(np.abs(answer - reference)) < 0.07
    assert np.all(answer >= model.joint_lower) and np.all(answer <= model.joint_upper)
    assert model.fk(answer).is_close(model.fk(q), 1e-9, 1e-9)
    assert answer[3] == pytest.approx(-2 * math.pi, abs=1e-9)


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur16e"])
def test_ik_of_fk_at_a_2pi_elbow_and_another_joint_at_2pi_is_the_configuration(name):
    """θ3 = ±2π is a stretched elbow, where θ3 comes back as the square root of rounding (~1.5e-8): its 2π variant
    lay past the limit, and ik answered 2π away. The elbow within ELBOW_ROUNDING of stretched is taken as stretched."""
    model = robot_model(name)
    rng = np.random.default_rng(2)
    for _ in range(200):
        q = rng.uniform(-math.pi, math.pi, 6)
        q[2] = rng.choice([2 * math.pi, -2 * math.pi])
        q[rng.choice([0, 1, 3])] = rng.choice([2 * math.pi, -2 * math.pi])
        answer = model.ik(model.fk(q), q)
        assert np.max(np.abs(answer - q)) < 1e-6, (q, answer)


@pytest.mark.parametrize("change, words", [
    ({"a": [0.0, 0.24365, 0.0, 0.0, 0.0, 0.0]}, "a2 = 0"),         # the catalogue's a2 = −0.24365 cancelled
    ({"a": [0.0, 0.0, 0.21325, 0.0, 0.0, 0.0]}, "a3 = 0"),
    ({"alpha": [0.0, 0.0, 0.0, -math.pi / 2, 0.0, 0.0]}, "α4 = 0 rad"),
])
def test_tables_the_analytic_ik_cannot_serve_are_refused_with_the_reason(change, words):
    with pytest.raises(ValueError, match=words):
        robot_model("ur3", dh_deltas=change)
    nominal = robot_model("ur3").dh
    absolute = {key: np.asarray(getattr(nominal, key)) + np.asarray(change.get(key, np.zeros(6)))
                for key in ("a", "d", "alpha", "theta")}
    with pytest.raises(ValueError, match=words):
        robot_model_from_dh("ur3", **absolute)


def test_the_cli_takes_the_librarys_variant_at_a_2pi_limit():
    """An angle 5e-11 rad past a 2π limit with the reference at 2π is the limit (the library's rule), not 5e-11 (a
    full turn away), in ur_ik.nearest_variant and in the replay/CLI helper alike."""
    model = robot_model("ur5e")
    q = np.array([2 * math.pi + 5e-11, -1.0, 1.2, -0.5, 1.1, 0.3])
    reference = np.array([2 * math.pi, -1.0, 1.2, -0.5, 1.1, 0.3])
    assert ur_ik.nearest_variant(model, q, reference)[0] == 2 * math.pi
    assert nearest_variant(model, [q], reference)[0] == 2 * math.pi
