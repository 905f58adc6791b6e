"""Array kernels over (..., 8): each against pyquaternion / plain matrices, plus broadcasting and bad input."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from pyquaternion import Quaternion

from ur3dq import DualQuaternion, dqarray

# Timing on a shared 2-core CI machine is no property of the code: no per-example deadline.
NO_DEADLINE = settings(deadline=None)


def random_poses(count, seed=0):
    """(count, 8) unit dual quaternions: uniform random rotations, translations within ±1 m."""
    rng = np.random.default_rng(seed)
    rotations = rng.normal(size=(count, 4))
    rotations /= np.linalg.norm(rotations, axis=1, keepdims=True)
    return dqarray.from_rotation_translation(rotations, rng.uniform(-1, 1, (count, 3)))


def test_sincos_matches_numpy_everywhere_including_multiples_of_pi():
    angles = np.concatenate((np.linspace(-20, 20, 100001), np.arange(-8, 9) * math.pi, np.arange(-8, 9) * math.pi / 2))
    sin, cos = dqarray.sincos(angles)
    np.testing.assert_allclose(sin, np.sin(angles), rtol=0, atol=4e-15)
    np.testing.assert_allclose(cos, np.cos(angles), rtol=0, atol=4e-15)


def test_multiply_matches_pyquaternion_parts():
    a, b = random_poses(50, 1), random_poses(50, 2)
    product = dqarray.multiply(a, b)
    for pa, pb, pab in zip(a, b, product):
        ra, da, rb, db = Quaternion(pa[:4]), Quaternion(pa[4:]), Quaternion(pb[:4]), Quaternion(pb[4:])
        np.testing.assert_allclose(pab[:4], (ra * rb).q, atol=1e-15)
        np.testing.assert_allclose(pab[4:], (ra * db + da * rb).q, atol=1e-15)


def test_multiply_broadcasts_one_pose_against_many():
    many, one = random_poses(7, 3), random_poses(1, 4)[0]
    np.testing.assert_allclose(dqarray.multiply(one, many)[3], dqarray.multiply(one, many[3]), atol=0)
    assert dqarray.multiply(many.reshape(7, 1, 8), many).shape == (7, 7, 8)


def test_conjugates():
    a = np.arange(1.0, 9.0)
    np.testing.assert_array_equal(dqarray.conjugate(a), [1, -2, -3, -4, 5, -6, -7, -8])
    np.testing.assert_array_equal(dqarray.dual_conjugate(a), [1, 2, 3, 4, -5, -6, -7, -8])
    np.testing.assert_array_equal(dqarray.combined_conjugate(a), [1, -2, -3, -4, -5, 6, 7, 8])


def test_conjugate_inverts_unit_poses():
    poses = random_poses(100, 5)
    identity = np.tile([1.0, 0, 0, 0, 0, 0, 0, 0], (100, 1))
    np.testing.assert_allclose(dqarray.multiply(poses, dqarray.conjugate(poses)), identity, atol=1e-15)


def test_translation_and_rotation_round_trip():
    rng = np.random.default_rng(6)
    translations = rng.uniform(-2, 2, (100, 3))
    poses = dqarray.from_rotation_translation(random_poses(100, 7)[:, :4], translations)
    np.testing.assert_allclose(dqarray.translation(poses), translations, atol=1e-15)
    np.testing.assert_array_equal(dqarray.rotation(poses), poses[:, :4])


def test_matrix_round_trip_and_transform_points():
    poses = random_poses(200, 8)
    matrices = dqarray.to_matrix(poses)
    back = dqarray.from_matrix(matrices)
    metres, radians = dqarray.pose_distance(back, poses)
    assert metres.max() < 1e-15 and radians.max() < 1e-12
    np.testing.assert_allclose(back * np.sign(back[:, :1] * poses[:, :1]), poses, atol=1e-15)
    points = np.random.default_rng(9).uniform(-1, 1, (200, 3))
    expected = np.einsum("nij,nj->ni", matrices[:, :3, :3], points) + matrices[:, :3, 3]
    np.testing.assert_allclose(dqarray.transform_points(poses, points), expected, atol=1e-15)


@pytest.mark.parametrize(
    "rotation",
    [np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1]),
     Quaternion(axis=[1, 1, 0], angle=math.pi - 1e-9).rotation_matrix],
)
def test_matrix_to_quaternion_every_branch(rotation):
    # Identity takes the trace branch; the half-turns each take one of the diagonal branches.
    q = dqarray.matrix_to_quaternion(rotation)
    assert q[0] >= 0.0
    np.testing.assert_allclose(dqarray.quaternion_to_matrix(q), rotation, atol=1e-15)


@settings(NO_DEADLINE, max_examples=200)
@given(hnp.arrays(float, 3, elements=st.floats(min_value=-10, max_value=10, allow_nan=False)))
def test_rotation_vector_round_trip(vector):
    q = dqarray.rotation_vector_to_quaternion(vector)
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(dqarray.quaternion_to_matrix(q), Quaternion(axis=vector, angle=np.linalg.norm(vector))
                               .rotation_matrix if np.linalg.norm(vector) > 0 else np.eye(3), atol=1e-12)
    back = dqarray.quaternion_to_rotation_vector(q)
    assert np.linalg.norm(back) <= math.pi + 1e-12
    np.testing.assert_allclose(dqarray.quaternion_to_matrix(dqarray.rotation_vector_to_quaternion(back)),
                               dqarray.quaternion_to_matrix(q), atol=1e-12)


def test_rotation_vector_of_tiny_and_half_turn_rotations_is_exact():
    vectors = np.array([[0, 0, 0], [1e-14, 0, 0], [0, 3e-9, 0], [0, 0, 2e-5], [math.pi, 0, 0], [0, -math.pi, 0]])
    back = dqarray.quaternion_to_rotation_vector(dqarray.rotation_vector_to_quaternion(vectors))
    np.testing.assert_allclose(np.abs(back), np.abs(vectors), rtol=1e-12, atol=1e-20)


def test_ur_pose_kernels_match_the_single_pose_api():
    poses = random_poses(50, 10)
    vectors = dqarray.to_ur_pose(poses)
    for pose, vector in zip(poses, vectors):
        np.testing.assert_allclose(DualQuaternion.from_array(pose).to_ur_pose(), vector, atol=0)
    metres, radians = dqarray.pose_distance(dqarray.from_ur_pose(vectors), poses)
    assert metres.max() < 1e-15 and radians.max() < 1e-12


def test_pose_distance_ignores_the_sign_and_separates_units():
    poses = random_poses(20, 11)
    metres, radians = dqarray.pose_distance(poses, -poses)
    assert metres.max() < 1e-15 and radians.max() < 1e-12
    turned = dqarray.multiply(poses, DualQuaternion.from_axis_angle([0, 1, 0], 0.25).to_array())
    metres, radians = dqarray.pose_distance(poses, turned)
    np.testing.assert_allclose(radians, 0.25, atol=1e-12)
    np.testing.assert_allclose(metres, 0.0, atol=1e-15)


def test_normalise_makes_unit_dual_quaternions():
    noisy = random_poses(30, 12) * 1.3 + np.random.default_rng(13).normal(scale=1e-3, size=(30, 8))
    fixed = dqarray.normalise(noisy)
    dqarray.check_unit(fixed, tolerance=1e-15)
    with pytest.raises(ValueError, match="unit"):
        dqarray.check_unit(noisy)


def test_log_exp_round_trip_in_batch_and_small_angle_branch():
    poses = random_poses(300, 14)
    tiny = dqarray.from_rotation_translation(dqarray.rotation_vector_to_quaternion([[1e-6, 0, 0], [0, 0, 3e-5]]),
                                             [[0.1, 0.2, 0.3], [-1, 0, 1]])
    for batch in (poses, tiny):
        metres, radians = dqarray.pose_distance(dqarray.exp(dqarray.log(batch)), batch)
        assert metres.max() < 1e-12 and radians.max() < 1e-12


def test_exp_is_continuous_across_the_small_angle_switch():
    # Just below and above the Taylor-series threshold the two closed forms must agree.
    v = np.array([0.3, -0.2, 0.5])
    for axis in (np.array([1.0, 0, 0]), np.array([0.6, 0.8, 0])):
        below = dqarray.exp(np.concatenate((axis * (1e-4 * (1 - 1e-9)), v)))
        above = dqarray.exp(np.concatenate((axis * (1e-4 * (1 + 1e-9)), v)))
        np.testing.assert_allclose(below, above, atol=1e-13)


def test_sclerp_broadcasts_over_tau():
    a, b = random_poses(1, 15)[0], random_poses(1, 16)[0]
    path = dqarray.sclerp(a, b, np.linspace(0, 1, 11))
    assert path.shape == (11, 8)
    for tau, pose in zip(np.linspace(0, 1, 11), path):
        single = DualQuaternion.from_array(a).sclerp(DualQuaternion.from_array(b), tau)
        assert single.is_close(DualQuaternion.from_array(pose), tol_m=1e-14, tol_rad=1e-12)


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda: dqarray.multiply(np.zeros((3, 7)), np.zeros((3, 8))), "a: expected shape"),
        (lambda: dqarray.multiply(np.zeros(8), [np.nan] * 8), "b: contains NaN"),
        (lambda: dqarray.from_rotation_translation([[1, 0, 0, 0.5]], [[0, 0, 0]]), "rotation: not a unit"),
        (lambda: dqarray.from_rotation_translation([1, 0, 0, 0], [0, 0]), "translation"),
        (lambda: dqarray.from_matrix(np.diag([1.0, 1, 1, 2])), "bottom row"),
        (lambda: dqarray.from_ur_pose(np.zeros((2, 5))), "pose"),
        (lambda: dqarray.to_ur_pose([1, 0, 0, 0, 0, 0, 0, np.inf]), "NaN or infinite"),
        (lambda: dqarray.exp(np.zeros(5)), "screw"),
        (lambda: dqarray.normalise(np.zeros(8)), "real part is zero"),
        (lambda: dqarray.transform_points(np.zeros(8), "xyz"), "points"),
        (lambda: dqarray.matrix_to_quaternion(np.eye(4)), "rotation"),
    ],
)
def test_bad_input(call, words):
    with pytest.raises(ValueError, match=words):
        call()


def test_sclerp_names_its_arguments_for_bad_shapes_and_non_unit_poses():
    a = dqarray.from_ur_pose(np.zeros((3, 6)))
    b = dqarray.from_ur_pose(np.zeros((2, 6)))
    with pytest.raises(ValueError, match=r"a, b, tau: shapes \(3, 8\), \(2, 8\) and \(\) do not broadcast"):
        dqarray.sclerp(a, b, 0.5)
    with pytest.raises(ValueError, match="a: not a unit dual quaternion"):
        dqarray.sclerp(a * 1.1, a, 0.5)
    assert dqarray.sclerp(a[0], a, np.array([0.1, 0.2, 0.3])).shape == (3, 8)
