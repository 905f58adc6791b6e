"""DualQuaternion: algebra laws, conversions, screw log/exp, ScLERP, pose comparison and bad input."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyquaternion import Quaternion

from ur3dq import DualQuaternion

# Timing on a shared 2-core CI machine is no property of the code: no per-example deadline.
NO_DEADLINE = settings(deadline=None)

finite = st.floats(min_value=-2.0, max_value=2.0, allow_nan=False, allow_infinity=False)
vectors = st.tuples(finite, finite, finite).map(np.array)


@st.composite
def unit_axes(draw):
    """Unit vectors (rejecting near-zero draws before normalising)."""
    v = draw(vectors)
    norm = np.linalg.norm(v)
    if norm < 1e-3:
        v, norm = np.array([0.0, 0.0, 1.0]), 1.0
    return v / norm


@st.composite
def poses(draw):
    """Random rigid transforms: a rotation of any angle about any axis, then a translation within ±2 m."""
    axis = draw(unit_axes())
    angle = draw(st.floats(min_value=-2 * math.pi, max_value=2 * math.pi, allow_nan=False))
    rotation = Quaternion(axis=axis, angle=angle)
    return DualQuaternion.from_rotation_translation(rotation, draw(vectors))


def assert_same_pose(a, b, tol=1e-9):
    metres, radians = a.distance(b)
    assert metres <= tol and radians <= tol, (a, b, metres, radians)


# ------------------------------------------------------------------------------------------------ algebra laws
@NO_DEADLINE
@given(poses(), poses(), poses())
def test_product_is_associative(a, b, c):
    np.testing.assert_allclose(((a * b) * c).to_array(), (a * (b * c)).to_array(), atol=1e-12)


@NO_DEADLINE
@given(poses())
def test_inverse_and_conjugate_undo_a_pose(a):
    identity = DualQuaternion.identity().to_array()
    np.testing.assert_allclose((a * a.inverse()).to_array(), identity, atol=1e-12)
    np.testing.assert_allclose((a.inverse() * a).to_array(), identity, atol=1e-12)
    np.testing.assert_allclose(a.conjugate().to_array(), a.inverse().to_array(), atol=1e-12)


def test_inverse_of_a_non_unit_dual_quaternion():
    a = DualQuaternion(Quaternion(2.0, 0.5, -1.0, 0.3), Quaternion(0.1, 0.7, -0.2, 0.4))
    np.testing.assert_allclose((a * a.inverse()).to_array(), [1, 0, 0, 0, 0, 0, 0, 0], atol=1e-14)


@NO_DEADLINE
@given(poses(), poses())
def test_conjugates_reverse_products(a, b):
    # (ab)* = b* a* holds for the quaternion and the combined conjugate; the dual conjugate keeps the order.
    np.testing.assert_allclose((a * b).conjugate().to_array(), (b.conjugate() * a.conjugate()).to_array(), atol=1e-12)
    np.testing.assert_allclose(
        (a * b).combined_conjugate().to_array(),
        (b.combined_conjugate() * a.combined_conjugate()).to_array(),
        atol=1e-12,
    )
    np.testing.assert_allclose(
        (a * b).dual_conjugate().to_array(), (a.dual_conjugate() * b.dual_conjugate()).to_array(), atol=1e-12
    )


def test_conjugate_signs():
    a = DualQuaternion.from_array([1, 2, 3, 4, 5, 6, 7, 8])
    assert a.conjugate().to_array().tolist() == [1, -2, -3, -4, 5, -6, -7, -8]
    assert a.dual_conjugate().to_array().tolist() == [1, 2, 3, 4, -5, -6, -7, -8]
    assert a.combined_conjugate().to_array().tolist() == [1, -2, -3, -4, -5, 6, 7, 8]


@NO_DEADLINE
@given(poses(), poses())
def test_product_is_the_matrix_product(a, b):
    np.testing.assert_allclose((a * b).to_matrix(), a.to_matrix() @ b.to_matrix(), atol=1e-12)


def test_equal_dual_quaternions_hash_alike():
    a = DualQuaternion.from_ur_pose([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    b = DualQuaternion.from_array(a.to_array())
    assert a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert a != -a


def test_from_matrix_accepts_a_rounded_printout_with_a_looser_tolerance():
    # Seed 003 eq. (59) is exact; a matrix printed with 3 decimals needs a tolerance of the print precision.
    rounded = np.round(DualQuaternion.from_ur_pose([0, 0, 0, 0.3, 0.2, 0.1]).to_matrix(), 3)
    with pytest.raises(ValueError, match="orthonormal"):
        DualQuaternion.from_matrix(rounded)
    pose = DualQuaternion.from_matrix(rounded, tolerance=5e-3)
    assert pose.is_unit(1e-15)
    assert pose.distance(DualQuaternion.from_ur_pose([0, 0, 0, 0.3, 0.2, 0.1]))[1] < 2e-3


@NO_DEADLINE
@given(poses(), poses(), vectors)
def test_composition_transforms_points_in_order(a, b, p):
    np.testing.assert_allclose((a * b).transform_point(p), a.transform_point(b.transform_point(p)), atol=1e-11)


@NO_DEADLINE
@given(poses())
def test_negated_pose_is_the_same_pose(a):
    assert (-a).is_close(a)
    assert a.is_close(-a, tol_m=0.0, tol_rad=1e-12) or a.distance(-a)[0] < 1e-15
    np.testing.assert_allclose((-a).to_matrix(), a.to_matrix(), atol=1e-15)


def test_is_close_uses_separate_tolerances():
    a = DualQuaternion.identity()
    shifted = DualQuaternion.from_translation([0.001, 0, 0])
    turned = DualQuaternion.from_axis_angle([0, 0, 1], 0.001)
    assert a.is_close(shifted, tol_m=0.0011, tol_rad=0.0)
    assert not a.is_close(shifted, tol_m=0.0009, tol_rad=1.0)
    assert a.is_close(turned, tol_m=0.0, tol_rad=0.0011)
    assert not a.is_close(turned, tol_m=1.0, tol_rad=0.0009)
    assert a.distance(turned) == pytest.approx((0.0, 0.001), abs=1e-15)


def test_normalised_restores_a_unit_pose_and_keeps_translation():
    pose = DualQuaternion.from_ur_pose([0.3, -0.2, 0.5, 0.1, 2.0, -0.4])
    drifted = DualQuaternion.from_array(pose.to_array() * 1.01 + np.array([0, 0, 0, 0, 1e-3, 0, 0, 0]))
    assert not drifted.is_unit()
    fixed = drifted.normalised()
    assert fixed.is_unit(1e-15)
    assert_same_pose(fixed, DualQuaternion.from_rotation_translation(pose.rotation, fixed.translation))
    np.testing.assert_allclose(fixed.real.q, pose.real.q, atol=1e-15)


# ------------------------------------------------------------------------------------------------ conversions
def test_rotation_then_translation_in_the_parent_frame():
    # 90° about z, then 1 m along x: the child's x axis points along the parent's y, origin at (1, 0, 0).
    pose = DualQuaternion.from_rotation_translation(Quaternion(axis=[0, 0, 1], angle=math.pi / 2), [1, 0, 0])
    np.testing.assert_allclose(pose.transform_point([1, 0, 0]), [1, 1, 0], atol=1e-15)
    np.testing.assert_allclose(pose.translation, [1, 0, 0], atol=1e-15)
    # σ = r + ε½tr, so the dual part is ½·(0,1,0,0)·r.
    r = Quaternion(axis=[0, 0, 1], angle=math.pi / 2)
    np.testing.assert_allclose(pose.dual.q, (0.5 * Quaternion(0, 1, 0, 0) * r).q, atol=1e-15)


@NO_DEADLINE
@given(poses())
def test_matrix_round_trip(a):
    matrix = a.to_matrix()
    np.testing.assert_allclose(matrix[:3, :3] @ matrix[:3, :3].T, np.eye(3), atol=1e-12)
    assert_same_pose(DualQuaternion.from_matrix(matrix), a)
    np.testing.assert_allclose(matrix[:3, :3], a.rotation.rotation_matrix, atol=1e-12)


@NO_DEADLINE
@given(poses())
def test_ur_pose_round_trip(a):
    pose = a.to_ur_pose()
    assert np.linalg.norm(pose[3:]) <= math.pi + 1e-12
    assert_same_pose(DualQuaternion.from_ur_pose(pose), a)


@NO_DEADLINE
@given(vectors, unit_axes(), st.floats(min_value=0.0, max_value=math.pi - 1e-9))
def test_ur_pose_vector_survives_a_round_trip_below_pi(t, axis, angle):
    pose = np.concatenate((t, axis * angle))
    np.testing.assert_allclose(DualQuaternion.from_ur_pose(pose).to_ur_pose(), pose, atol=1e-9)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-7, 1e-5, 1e-3, math.pi - 1e-3, math.pi - 1e-9, math.pi])
def test_ur_pose_rotation_vector_near_zero_and_pi(angle):
    axis = np.array([0.48, -0.6, 0.64])
    pose = np.concatenate(([0.1, 0.2, 0.3], axis * angle))
    back = DualQuaternion.from_ur_pose(pose).to_ur_pose()
    expected_angle = np.linalg.norm(back[3:])
    assert expected_angle == pytest.approx(angle, abs=1e-12)
    if angle < math.pi - 1e-6:
        np.testing.assert_allclose(back, pose, atol=1e-12)
    else:
        # At π the vectors ±axis·π are the same rotation: only the pose must survive.
        assert_same_pose(DualQuaternion.from_ur_pose(back), DualQuaternion.from_ur_pose(pose))


def test_ur_pose_beyond_pi_maps_to_the_short_equivalent():
    pose = [0, 0, 0, 0, 0, 1.5 * math.pi]
    back = DualQuaternion.from_ur_pose(pose).to_ur_pose()
    np.testing.assert_allclose(back, [0, 0, 0, 0, 0, -0.5 * math.pi], atol=1e-12)


def test_ur_pose_matches_the_matrix_rotation():
    pose = DualQuaternion.from_ur_pose([0.1, 0.2, 0.3, 0, math.pi / 2, 0])
    np.testing.assert_allclose(pose.to_matrix()[:3, :3], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-15)


@NO_DEADLINE
@given(poses())
def test_pair_and_thesis_line_round_trip(a):
    q, p = a.to_pair()
    assert isinstance(q, Quaternion)
    assert_same_pose(DualQuaternion.from_pair(q, p), a)
    assert_same_pose(DualQuaternion.from_pair(q, Quaternion(0, *p)), a)
    line = a.to_thesis_line()
    fields = [float(f) for f in line.split()]
    assert len(fields) == 8 and fields[4] == 0.0
    np.testing.assert_allclose(fields[5:], a.translation, atol=0)
    assert_same_pose(DualQuaternion.from_thesis_line(line), a, tol=1e-14)


def test_thesis_line_of_the_home_pose_printout():
    # Seed 000 §4.5: ([0 0 1 0], <0 0 −0.194 0.694>) rounded to 3 decimals in the printout.
    pose = DualQuaternion.from_thesis_line("0.000 0.000 1.000 0.000 0 -0.000 -0.194 0.694")
    np.testing.assert_allclose(pose.translation, [0, -0.194, 0.694], atol=1e-15)
    np.testing.assert_allclose(pose.transform_point([0, -0.2, 0]), [0, -0.394, 0.694], atol=1e-15)


@NO_DEADLINE
@given(poses())
def test_array_round_trip(a):
    assert DualQuaternion.from_array(a.to_array()) == a
    assert DualQuaternion(a.real, a.dual) == a


# ----------------------------------------------------------------------------------------------- log and exp
@NO_DEADLINE
@given(poses())
def test_log_exp_round_trip(a):
    assert_same_pose(DualQuaternion.exp(a.log()), a, tol=1e-9)


@NO_DEADLINE
@given(vectors, unit_axes(), st.floats(min_value=-3.1, max_value=3.1))
def test_exp_log_round_trip_on_the_principal_sheet(v, axis, half_turn):
    screw = np.concatenate((axis * half_turn / 2, v))
    np.testing.assert_allclose(DualQuaternion.exp(screw).log(), screw, atol=1e-9)


def test_log_of_simple_motions():
    np.testing.assert_allclose(DualQuaternion.from_translation([0.2, -0.4, 0.6]).log(), [0, 0, 0, 0.1, -0.2, 0.3])
    rotation = DualQuaternion.from_axis_angle([0, 0, 1], 1.0)
    np.testing.assert_allclose(rotation.log(), [0, 0, 0.5, 0, 0, 0], atol=1e-15)


@NO_DEADLINE
@given(poses())
def test_log_is_smooth_at_tiny_rotations(a):
    tiny = DualQuaternion.from_rotation_translation(Quaternion(axis=[1, 2, 3], angle=1e-7), a.translation)
    assert_same_pose(DualQuaternion.exp(tiny.log()), tiny, tol=1e-14)


@pytest.mark.parametrize("angle", [math.pi, math.pi - 1e-9, math.pi + 1e-9, -math.pi, 1e-12])
def test_log_exp_round_trip_at_half_turns_and_tiny_turns(angle):
    pose = DualQuaternion.from_rotation_translation(Quaternion(axis=[0.2, -0.3, 0.9], angle=angle), [0.4, -0.1, 0.7])
    assert_same_pose(DualQuaternion.exp(pose.log()), pose, tol=1e-12)
    assert_same_pose(pose.power(0.5) * pose.power(0.5), pose, tol=1e-12)


# ---------------------------------------------------------------------------------------------------- ScLERP
@NO_DEADLINE
@given(poses(), poses())
def test_sclerp_endpoints(a, b):
    assert_same_pose(a.sclerp(b, 0.0), a)
    assert_same_pose(a.sclerp(b, 1.0), b, tol=1e-8)


@settings(NO_DEADLINE, max_examples=50)
@given(poses(), poses())
def test_sclerp_moves_at_constant_speed_along_one_screw(a, b):
    samples = [a.sclerp(b, tau) for tau in np.linspace(0.0, 1.0, 9)]
    steps = [(first.inverse() * second) for first, second in zip(samples, samples[1:], strict=False)]
    for step in steps[1:]:
        assert_same_pose(step, steps[0], tol=1e-8)


def test_sclerp_reaches_a_half_turn_away():
    a = DualQuaternion.from_ur_pose([0.1, 0.2, 0.3, 0.0, 0.0, 0.5])
    b = a * DualQuaternion.from_rotation_translation(Quaternion(axis=[1, 0, 0], angle=math.pi), [0.0, 0.5, 0.0])
    assert_same_pose(a.sclerp(b, 1.0), b, tol=1e-12)
    assert a.distance(a.sclerp(b, 0.5))[1] == pytest.approx(math.pi / 2, abs=1e-12)


def test_sclerp_halfway_of_a_pure_translation_and_rotation():
    a = DualQuaternion.identity()
    np.testing.assert_allclose(a.sclerp(DualQuaternion.from_translation([1, 2, 3]), 0.5).translation, [0.5, 1, 1.5])
    halfway = a.sclerp(DualQuaternion.from_axis_angle([0, 1, 0], 2.0), 0.5)
    assert_same_pose(halfway, DualQuaternion.from_axis_angle([0, 1, 0], 1.0))


# ------------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "build, words",
    [
        (lambda: DualQuaternion.from_ur_pose([0, 0, float("nan"), 0, 0, 0]), "pose"),
        (lambda: DualQuaternion.from_ur_pose([0, 0, 0, 0, 0]), "pose"),
        (lambda: DualQuaternion.from_ur_pose([0, 0, 0, 0, float("inf"), 0]), "pose"),
        (lambda: DualQuaternion.from_rotation_translation(Quaternion(1, 1, 0, 0), [0, 0, 0]), "rotation"),
        (lambda: DualQuaternion.from_rotation_translation([1, 0, 0, 0], [0, 0]), "translation"),
        (lambda: DualQuaternion.from_matrix(np.eye(3)), "matrix"),
        (lambda: DualQuaternion.from_matrix(np.diag([1.0, 1.0, -1.0, 1.0])), "reflection"),
        (lambda: DualQuaternion.from_matrix(np.diag([1.0, 2.0, 1.0, 1.0])), "orthonormal"),
        (lambda: DualQuaternion.from_array([1, 0, 0, 0, 0, 0, 0]), "coefficients"),
        (lambda: DualQuaternion.from_array(["a"] * 8), "coefficients"),
        (lambda: DualQuaternion.from_thesis_line("1 0 0 0 0 1 2"), "8 coefficients"),
        (lambda: DualQuaternion.from_thesis_line("1 0 0 0 0.5 1 2 3"), "5th"),
        (lambda: DualQuaternion.from_thesis_line("1 0 0 x 0 1 2 3"), "not a number"),
        (lambda: DualQuaternion.from_pair([2, 0, 0, 0], [0, 0, 0]), "q: not a unit"),
        (lambda: DualQuaternion([1, 0, 0, float("nan")]), "real"),
        (lambda: DualQuaternion.from_array([2, 0, 0, 0, 0, 0, 0, 0]).to_matrix(), "unit"),
        (lambda: DualQuaternion.from_array([1, 0, 0, 0, 1, 0, 0, 0]).to_ur_pose(), "real·dual"),
        (lambda: DualQuaternion.identity().transform_point([1, 2]), "point"),
        (lambda: DualQuaternion.exp([0, 0, 0, 0, 0]), "screw"),
        (lambda: DualQuaternion.identity().sclerp("pose", 0.5), "other"),
        (lambda: DualQuaternion.identity().sclerp(DualQuaternion.identity(), float("nan")), "tau"),
        (lambda: DualQuaternion.from_axis_angle([0, 0, 0], 1.0), "axis"),
        (lambda: DualQuaternion.from_array([0] * 8).inverse(), "no inverse"),
    ],
)
def test_bad_input_is_a_value_error_naming_the_problem(build, words):
    with pytest.raises(ValueError, match=words):
        build()


@pytest.mark.parametrize("vector, message", [
    ([1e300, 0.0, 0.0, 0.0, 0.0, 0.0], r"1e\+300 m is beyond ±100 m: give metres"),
    ([0.0, -100.5, 0.0, 0.0, 0.0, 0.0], r"100 m is beyond ±100 m: give metres"),
    ([0.0, 0.0, 0.0, 1e20, 0.0, 0.0], r"1e\+20 rad is beyond ±100 rad: a rotation vector in radians"),
])
def test_a_ur_pose_no_cell_holds_is_refused_naming_the_argument(vector, message):
    from ur3dq.kinematics import robot_model

    with pytest.raises(ValueError, match=rf"^pose: {message}"):
        DualQuaternion.from_ur_pose(vector)
    with pytest.raises(ValueError, match=rf"^tcp: {message}"):
        robot_model("ur3").with_tcp(vector)


def test_a_ur_pose_at_the_bounds_is_a_pose():
    at_bounds = DualQuaternion.from_ur_pose([100.0, -100.0, 0.0, 0.0, 0.0, 100.0])
    np.testing.assert_allclose(at_bounds.translation, [100.0, -100.0, 0.0])
