"""UR models: FK against ur_analytic_ik, the thesis' home pose, calibrated DH, limits, speeds, bad input."""
import math

import numpy as np
import pytest
import ur_analytic_ik
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq import DualQuaternion, dqarray
from ur3dq.errors import JointLimitError
from ur3dq.kinematics import MODEL_NAMES, robot_model, robot_model_from_dh

# Timing on a shared 2-core CI machine is no property of the code: no per-example deadline.
NO_DEADLINE = settings(deadline=None)

HOME = np.array([0, -math.pi / 2, 0, -math.pi / 2, 0, 0])  # seed 000 §4.5
joint_angle = st.floats(min_value=-2 * math.pi, max_value=2 * math.pi, allow_nan=False)
configurations = st.tuples(*[joint_angle] * 6).map(np.array)


def oracle(name):
    """ur_analytic_ik's C++ forward kinematics for the model (a test-only, independent implementation)."""
    return getattr(ur_analytic_ik, name)


def random_configurations(count, seed=0):
    return np.random.default_rng(seed).uniform(-2 * math.pi, 2 * math.pi, (count, 6))


# ------------------------------------------------------------------------------------------------ FK vs oracle
@pytest.mark.parametrize("name", MODEL_NAMES)
def test_fk_equals_ur_analytic_ik(name):
    model = robot_model(name)
    for q in random_configurations(2000):
        np.testing.assert_allclose(model.fk(q).to_matrix(), oracle(name).forward_kinematics(*q), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_fk_batch_equals_ur_analytic_ik(name):
    model = robot_model(name)
    joints = random_configurations(10000, seed=1)
    expected = np.array([oracle(name).forward_kinematics(*q) for q in joints])
    np.testing.assert_allclose(dqarray.to_matrix(model.fk_batch(joints)), expected, rtol=0, atol=1e-12)


SINGULAR_CONFIGURATIONS = np.array([
    [0, 0, 0, 0, 0, 0],                              # everything zero: wrist singular (q5 = 0), arm stretched
    [0.3, -1.2, 0, -0.4, 0, 2.0],                    # stretched elbow and wrist singular together
    [1.0, -math.pi / 2, 0, -math.pi / 2, 0, 0],      # seed 000's home pose, turned
    [-2.0, -0.7, math.pi, 0.2, math.pi, -1.0],       # folded elbow, wrist 2 at π
    [2 * math.pi, -2 * math.pi, 2 * math.pi, -2 * math.pi, 2 * math.pi, -2 * math.pi],   # the limits
])


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_fk_at_singular_and_extreme_configurations(name):
    model = robot_model(name)
    batch = model.fk_batch(SINGULAR_CONFIGURATIONS)
    for q, row in zip(SINGULAR_CONFIGURATIONS, batch):
        expected = oracle(name).forward_kinematics(*q)
        np.testing.assert_allclose(model.fk(q).to_matrix(), expected, rtol=0, atol=1e-12)
        np.testing.assert_allclose(DualQuaternion.from_array(row).to_matrix(), expected, rtol=0, atol=1e-12)


def test_fk_batch_of_no_configurations_is_empty():
    assert robot_model("ur3").fk_batch(np.zeros((0, 6))).shape == (0, 8)
    assert robot_model("ur3", dh_deltas={"a": [1e-4] * 6}).fk_batch(np.zeros((0, 6))).shape == (0, 8)


def test_fk_accepts_lists_tuples_and_integer_arrays():
    model = robot_model("ur10")
    expected = model.fk(np.zeros(6))
    for q in ([0, 0, 0, 0, 0, 0], (0.0,) * 6, np.zeros(6, dtype=int)):
        assert model.fk(q) == expected
    np.testing.assert_array_equal(model.fk_batch([[0] * 6]), [expected.to_array()])


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_fk_dual_quaternion_equals_dqrobotics(name):
    # dqrobotics (installed with the bench extra) uses the same σ = r + ε½tr: the 8 coefficients agree up to sign.
    robot_modeling = pytest.importorskip("dqrobotics.robot_modeling")
    model = robot_model(name)
    dh = model.dh
    reference = robot_modeling.DQ_SerialManipulatorDH(np.array([dh.theta, dh.d, dh.a, dh.alpha, np.zeros(6)]))
    for q in random_configurations(200, seed=7):
        ours = model.fk(q).to_array()
        theirs = reference.fkm(q).vec8()
        np.testing.assert_allclose(ours * np.sign(ours @ theirs), theirs, rtol=0, atol=1e-12)


@settings(NO_DEADLINE, max_examples=150)
@given(configurations, st.sampled_from(MODEL_NAMES))
def test_fk_batch_equals_fk(q, name):
    model = robot_model(name).with_tcp([0.01, -0.02, 0.15, 0.1, -0.2, 0.3])
    batch = model.fk_batch(np.stack([q, -q]))
    assert DualQuaternion.from_array(batch[0]).is_close(model.fk(q), tol_m=1e-14, tol_rad=1e-14)
    assert DualQuaternion.from_array(batch[1]).is_close(model.fk(-q), tol_m=1e-14, tol_rad=1e-14)


@pytest.mark.parametrize("angle", [0.0, math.pi, -math.pi, math.pi / 2, 2 * math.pi, -2 * math.pi, 3 * math.pi])
def test_fk_batch_at_angles_where_the_half_angle_tangent_blows_up(angle):
    model = robot_model("ur5e")
    joints = np.full((1, 6), angle)
    expected = oracle("ur5e").forward_kinematics(*joints[0])
    np.testing.assert_allclose(dqarray.to_matrix(model.fk_batch(joints))[0], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_fk_with_tcp_equals_ur_analytic_ik(name):
    tcp = DualQuaternion.from_ur_pose([0.02, -0.01, 0.2, 0.3, -0.1, 1.2])
    model = robot_model(name).with_tcp(tcp)
    for q in random_configurations(200, seed=2):
        expected = oracle(name).forward_kinematics_with_tcp(*q, tcp.to_matrix())
        np.testing.assert_allclose(model.fk(q).to_matrix(), expected, rtol=0, atol=1e-12)
        assert model.fk(q).is_close(model.fk_flange(q) * tcp, tol_m=1e-14, tol_rad=1e-14)
    assert model.tcp is tcp
    assert robot_model(name).with_tcp(tcp.to_ur_pose()).fk(HOME).is_close(model.fk(HOME))


def test_models_really_differ():
    poses = [robot_model(name).fk(HOME) for name in MODEL_NAMES]
    heights = [pose.translation[2] for pose in poses]
    assert len(set(np.round(heights, 6))) == len(MODEL_NAMES)


# ------------------------------------------------------------------------------------ seed 000: the home pose
def test_seed_000_home_pose_with_the_dh_tool():
    # A 0.2 m tool along the flange z axis: TCP (0, −0.394, 0.694) in the printout, (0, −0.39425, 0.69415) exactly.
    model = robot_model("ur3").with_tcp([0, 0, 0.2, 0, 0, 0])
    pose = model.fk(HOME)
    np.testing.assert_allclose(pose.translation, [0, -0.39425, 0.69415], atol=1e-12)
    np.testing.assert_allclose(pose.translation, [0, -0.394, 0.694], atol=5e-4)
    # The printout's DH flange rotation: [0, 0, 0.707, −0.707] (σ ≡ −σ).
    expected = DualQuaternion.from_rotation_translation([0, 0, math.sqrt(0.5), -math.sqrt(0.5)], pose.translation)
    assert pose.is_close(expected, tol_m=1e-12, tol_rad=1e-12)


def test_seed_000_home_pose_with_the_thesis_axis_angle_chain():
    # The thesis frame is parallel to the base at q = 0 and its tool point is (0, −0.2, 0) in that frame.
    model = robot_model("ur3")
    thesis = model.thesis_chain(tool_point=[0, -0.2, 0]).fk(HOME)
    np.testing.assert_allclose(thesis.translation, [0, -0.39425, 0.69415], atol=1e-12)
    # Its printed end rotation is [0, 0, 1, 0]: π about y.
    assert thesis.is_close(DualQuaternion.from_rotation_translation([0, 0, 1, 0], thesis.translation), tol_rad=1e-12)
    # The printed pair before the tool: ([0 0 1 0], <0 −0.194 0.694>) — the flange point.
    np.testing.assert_allclose(model.thesis_chain().fk(HOME).translation, [0, -0.19425, 0.69415], atol=1e-12)


@settings(NO_DEADLINE, max_examples=50)
@given(configurations, st.sampled_from(MODEL_NAMES))
def test_thesis_frame_is_the_flange_times_the_inverse_home_rotation(q, name):
    model = robot_model(name)
    r0 = model.flange_rotation_at_zero()
    assert model.thesis_chain().fk(q).is_close(model.fk(q) * r0.conjugate(), tol_m=1e-12, tol_rad=1e-12)


def test_ur_flange_orientation_at_zero():
    # At q = 0 only the α twists act: π/2 + π/2 − π/2 about x. The flange z axis points along −y of the base.
    for name in MODEL_NAMES:
        rotation = robot_model(name).flange_rotation_at_zero().to_matrix()[:3, :3]
        np.testing.assert_allclose(rotation, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-15)


# ---------------------------------------------------------------------------------------------- calibrated DH
DELTAS = {
    "a": [3e-5, -2.1e-4, 1.7e-4, 2e-5, -1e-5, 0],
    "d": [1.2e-4, 1.5, -1.49, 2e-4, -1e-4, 1e-4],
    "alpha": [1e-4, -2e-4, 3e-4, 5e-5, -7e-5, 0],
    "theta": [2e-6, -3e-4, 4e-4, 1e-4, -2e-4, 3e-5],
}


def calibrated_matrix_fk(name, q):
    """Independent oracle: nominal DH table (as docs/conventions.md prints it) + deltas, multiplied as 4×4 matrices."""
    table = {
        "ur3": (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819),
        "ur5e": (0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),
        "ur16e": (0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655),
    }[name]
    d1, a2, a3, d4, d5, d6 = table
    a = np.array([0, a2, a3, 0, 0, 0]) + DELTAS["a"]
    d = np.array([d1, 0, 0, d4, d5, d6]) + DELTAS["d"]
    alpha = np.array([math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2, 0]) + DELTAS["alpha"]
    total = np.eye(4)
    for i in range(6):
        theta = q[i] + DELTAS["theta"][i]
        ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha[i]), math.sin(alpha[i])
        total = total @ np.array(
            [[ct, -st * ca, st * sa, a[i] * ct], [st, ct * ca, -ct * sa, a[i] * st], [0, sa, ca, d[i]], [0, 0, 0, 1]]
        )
    return total


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur16e"])
def test_calibrated_model_equals_the_dh_matrix_product(name):
    model = robot_model(name, dh_deltas=DELTAS)
    assert model.calibrated
    joints = random_configurations(300, seed=3)
    batch = model.fk_batch(joints)
    for q, row in zip(joints, batch):
        expected = calibrated_matrix_fk(name, q)
        np.testing.assert_allclose(model.fk(q).to_matrix(), expected, rtol=0, atol=1e-12)
        np.testing.assert_allclose(DualQuaternion.from_array(row).to_matrix(), expected, rtol=0, atol=1e-12)


def test_model_from_reported_dh_values():
    # URSim reports the nominal table in Kinematics Info (docs/protocols.md): that gives the nominal model back.
    ursim = robot_model_from_dh("ur5e", [0, -0.425, -0.3922, 0, 0, 0], [0.1625, 0, 0, 0.1333, 0.0997, 0.0996],
                                [math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2, 0], [0] * 6)
    assert ursim.calibrated
    np.testing.assert_array_equal(ursim.dh.a, robot_model("ur5e").dh.a)
    q = random_configurations(1, seed=6)[0]
    assert ursim.fk(q) == robot_model("ur5e").fk(q)
    # A real arm's absolute values become deltas on the nominal table.
    nominal = robot_model("ur3").dh
    real = robot_model_from_dh("ur3", nominal.a + DELTAS["a"], nominal.d + DELTAS["d"],
                               nominal.alpha + DELTAS["alpha"], nominal.theta + DELTAS["theta"])
    assert real.fk(q).is_close(DualQuaternion.from_matrix(calibrated_matrix_fk("ur3", q)), tol_m=1e-12, tol_rad=1e-12)
    with pytest.raises(ValueError, match="alpha"):
        robot_model_from_dh("ur3", nominal.a, nominal.d, [0] * 5, nominal.theta)


def test_calibrated_model_is_millimetres_off_the_nominal_one():
    nominal = robot_model("ur5e").fk(HOME)
    calibrated = robot_model("ur5e", dh_deltas={"a": [0, 1e-3, 0, 0, 0, 0]}).fk(HOME)
    metres, _ = nominal.distance(calibrated)
    assert metres == pytest.approx(1e-3, rel=1e-6)


def test_zero_deltas_give_the_nominal_model():
    model = robot_model("ur10e", dh_deltas={})
    for q in random_configurations(20, seed=4):
        assert model.fk(q).is_close(robot_model("ur10e").fk(q), tol_m=1e-15, tol_rad=1e-15)
    np.testing.assert_array_equal(model.dh.d, robot_model("ur10e").dh.d)


# ------------------------------------------------------------------------------------------- DH, limits, speeds
def test_dh_table_of_the_ur3():
    dh = robot_model("UR3").dh
    np.testing.assert_array_equal(dh.a, [0, -0.24365, -0.21325, 0, 0, 0])
    np.testing.assert_array_equal(dh.d, [0.1519, 0, 0, 0.11235, 0.08535, 0.0819])
    np.testing.assert_array_equal(dh.alpha, [math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2, 0])
    np.testing.assert_array_equal(dh.theta, np.zeros(6))
    assert not dh.a.flags.writeable


@pytest.mark.parametrize(
    "name, degrees_per_second",
    [
        ("ur3", [180, 180, 180, 360, 360, 360]),
        ("ur3e", [180, 180, 180, 360, 360, 360]),
        ("ur5", [180] * 6),
        ("ur5e", [180] * 6),
        ("ur10", [120, 120, 180, 180, 180, 180]),
        ("ur10e", [120, 120, 180, 180, 180, 180]),
        ("ur16e", [120, 120, 180, 180, 180, 180]),
    ],
)
def test_maximum_joint_speeds(name, degrees_per_second):
    model = robot_model(name)
    np.testing.assert_allclose(np.degrees(model.max_joint_speed), degrees_per_second)
    assert np.all(model.max_joint_acceleration > 0)


def test_models_are_immutable_values():
    model = robot_model("ur3")
    with pytest.raises(AttributeError, match="immutable"):
        model.tcp = DualQuaternion.from_translation([0, 0, 0.1])
    with pytest.raises(ValueError):
        model.joint_upper[0] = 1.0
    moved = model.with_tcp([0, 0, 0.1, 0, 0, 0])
    assert moved is not model and model.tcp == DualQuaternion.identity()


def test_joint_limits():
    ur3 = robot_model("ur3")
    np.testing.assert_allclose(ur3.joint_upper[:5], 2 * math.pi)
    np.testing.assert_allclose(ur3.joint_lower[:5], -2 * math.pi)
    assert ur3.joint_upper[5] == math.inf and ur3.joint_lower[5] == -math.inf
    assert robot_model("ur5e").joint_upper[5] == pytest.approx(2 * math.pi)


def test_check_joints():
    ur3, ur5 = robot_model("ur3"), robot_model("ur5")
    np.testing.assert_array_equal(ur3.check_joints(HOME), HOME)
    ur3.check_joints([0, 0, 0, 0, 0, 100.0])  # the UR3's wrist 3 is unlimited
    with pytest.raises(JointLimitError, match=r"joint 6 \(wrist 3\)"):
        ur5.check_joints([0, 0, 0, 0, 0, 7.0])
    with pytest.raises(JointLimitError, match=r"joint 2 \(shoulder\)"):
        ur3.check_joints([0, -6.3, 0, 0, 0, 0])
    with pytest.raises(ValueError, match="NaN"):
        ur3.check_joints([0, float("nan"), 0, 0, 0, 0])
    with pytest.raises(ValueError, match="6 joint"):
        ur3.check_joints([0, 0, 0])


def test_frames_and_joint_axes_for_a_jacobian():
    model = robot_model("ur5").with_tcp([0, 0, 0.1, 0, 0, 0])
    q = random_configurations(1, seed=5)[0]
    frames = model.frames(q)
    assert frames.shape == (7, 8)
    assert DualQuaternion.from_array(frames[-1]).is_close(model.fk(q), tol_m=1e-14, tol_rad=1e-14)
    directions, points = model.joint_axes(q)
    assert directions.shape == points.shape == (6, 3)
    np.testing.assert_allclose(directions[0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(points[0], [0, 0, 0.089159], atol=1e-15)


def test_ik_methods_delegate_to_the_analytic_solver():
    model = robot_model("ur5e")
    q = np.array([0.4, -1.1, 1.3, -0.9, 1.2, 0.3])
    pose = model.fk(q)
    solutions = model.ik_all(pose)
    assert any(np.allclose(solution, q, atol=1e-9) for solution in solutions)
    for solution in solutions:
        assert model.fk(solution).is_close(pose, tol_m=1e-9, tol_rad=1e-9)
    np.testing.assert_allclose(model.ik(pose, q), q, atol=1e-9)
    np.testing.assert_allclose(model.ik_batch(pose.to_array()[None, :], q), [q], atol=1e-9)
    np.testing.assert_allclose(model.ik_batch(pose.to_array()[None, :], q, weights=[1, 2, 3, 4, 5, 6]), [q], atol=1e-9)
    assert any(np.allclose(solution, q, atol=1e-9) for solution in model.ik_all(pose, q_ref=q))


# ------------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "build, error, words",
    [
        (lambda: robot_model("ur7"), ValueError, "unknown robot model 'ur7'"),
        (lambda: robot_model(None), ValueError, "name"),
        (lambda: robot_model("ur3", dh_deltas={"b": [0] * 6}), ValueError, "unknown key 'b'"),
        (lambda: robot_model("ur3", dh_deltas={"a": [0] * 5}), ValueError, r"dh_deltas\['a'\]"),
        (lambda: robot_model("ur3", dh_deltas={"d": [0, 0, 0, 0, 0, float("nan")]}), ValueError, "NaN"),
        (lambda: robot_model("ur3", dh_deltas=[0] * 6), ValueError, "dh_deltas"),
        (lambda: robot_model("ur3").fk([0] * 5), ValueError, "q: expected 6"),
        (lambda: robot_model("ur3").fk([0, 0, 0, 0, 0, float("nan")]), ValueError, "q: contains NaN"),
        (lambda: robot_model("ur3").fk([0, 0, 0, 0, float("-inf"), 0]), ValueError, "q: contains NaN"),
        (lambda: robot_model("ur3").fk(np.zeros((6, 2))), ValueError, "q"),
        (lambda: robot_model("ur3").fk("abcdef"), ValueError, "q"),
        (lambda: robot_model("ur3").fk(["0.1"] * 6), ValueError, r"q: expected 6 joint angles .*'0\.1'"),
        (lambda: robot_model("ur3").fk([0.0] * 5 + [True]), ValueError, "q: expected 6 joint angles .*True"),
        (lambda: robot_model("ur3").fk(np.ones(6, dtype=bool)), ValueError, "q: expected 6 joint angles"),
        (lambda: robot_model("ur3").ik(DualQuaternion.identity(), ["0"] * 6), ValueError, "q_ref: expected 6"),
        (lambda: robot_model("ur3").ik_all(["1", 0, 0, 0, 0, 0, 0, 0]), ValueError, "pose: expected"),
        (lambda: robot_model("ur3").ik_batch([["1", 0, 0, 0, 0, 0, 0, 0]], [0] * 6), ValueError, "poses: expected"),
        (lambda: robot_model("ur3").ik_batch([[1, 0, 0, 0, 0, 0, 0, 0]], [False] * 6), ValueError, "q_ref: expected"),
        (lambda: robot_model("ur3").fk_batch([[0.0] * 5 + [True]]), ValueError, "joint_matrix: expected numbers"),
        (lambda: robot_model("ur3").with_tcp(["0", 0, 0.1, 0, 0, 0]), ValueError, "tcp: expected numbers"),
        (lambda: robot_model("ur3", dh_deltas={"d": ["0.001"] + [0] * 5}), ValueError, r"dh_deltas\['d'\]"),
        (lambda: robot_model_from_dh("ur3", *(["0"] * 6,) * 4), ValueError, "expected numbers"),
        (lambda: robot_model("ur3").fk_batch(np.zeros((4, 5))), ValueError, "joint_matrix"),
        (lambda: robot_model("ur3").fk_batch(np.zeros(6)), ValueError, "joint_matrix"),
        (lambda: robot_model("ur3").fk_batch(np.full((2, 6), np.nan)), ValueError, "joint_matrix"),
        (lambda: robot_model("ur3").with_tcp([0, 0, 0.1]), ValueError, "tcp: expected"),
        (lambda: robot_model("ur3").with_tcp(DualQuaternion.from_array([2, 0, 0, 0, 0, 0, 0, 0])), ValueError, "tcp"),
    ],
)
def test_bad_input_is_a_clear_error(build, error, words):
    with pytest.raises(error, match=words):
        build()


def test_fk_errors_are_each_rows_distance_with_its_own_tcp():
    """fk_errors groups rows by TCP offset (shared objects, equal values in other objects, other values): each
    row's figures are its own FK with its own offset against its own pose."""
    model = robot_model("ur5e")
    rng = np.random.default_rng(4)
    joints = list(rng.uniform(-3, 3, (12, 6)))
    shared, other = (0.0, 0.0, 0.1, 0.0, 0.0, 0.0), (0.02, 0.0, 0.05, 0.0, 0.3, 0.0)
    offsets = [shared, other, list(shared), shared, (0.0,) * 6, tuple(other)] * 2
    poses = [model.with_tcp(offsets[(i + i % 2) % 12]).fk(q).to_array() for i, q in enumerate(joints)]   # odd: off
    metres, radians = model.fk_errors(joints, poses, offsets)
    for q, pose, offset, m, r in zip(joints, poses, offsets, metres, radians):
        expected = model.with_tcp(offset).fk(q).distance(DualQuaternion.from_array(pose))
        assert m == pytest.approx(expected[0], abs=1e-12) and r == pytest.approx(expected[1], abs=1e-9)
    assert metres[3] > 0.01 and metres[4] < 1e-12   # a pose made with another offset, and one with its own
