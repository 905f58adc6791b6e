"""SerialChain: DH rows (seed 003), base-frame joint axes (thesis §4.2), prismatic joints, offsets, frames."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq import DualQuaternion
from ur3dq.kinematics.chain import (
    PRISMATIC,
    REVOLUTE,
    SerialChain,
    dh_joint,
    dh_matrix,
    frame_with_z_axis,
    thesis_to_dh_flange,
)

# Timing on a shared 2-core CI machine is no property of the code: no per-example deadline.
NO_DEADLINE = settings(deadline=None)

DEG = math.pi / 180

# Seed 003's PUMA example (millimetres): the printed eq. (58) dual quaternion and eq. (59) matrix.
PUMA = dict(
    a=[0, 431.8, -20.32, 0, 0, 0],
    d=[0, 149.09, 0, 433.07, 0, 56.25],
    alpha=np.array([-90, 0, 90, -90, 90, 0]) * DEG,
)
PUMA_Q = np.array([90, 0, 90, 0, 0, 0]) * DEG
PUMA_EQ58 = [0.5, -0.5, 0.5, 0.5, -272.6325, 187.9275, 262.4725, 198.0875]
PUMA_EQ59 = [[0, -1, 0, -149.09], [0, 0, 1, 921.12], [-1, 0, 0, 20.32], [0, 0, 0, 1]]

lengths = st.floats(min_value=-0.8, max_value=0.8, allow_nan=False)
angles = st.floats(min_value=-math.pi, max_value=math.pi, allow_nan=False)


def matrix_product_fk(a, d, alpha, theta, q, joint_types):
    """Independent oracle: the textbook product of DH homogeneous matrices."""
    total = np.eye(4)
    for i, kind in enumerate(joint_types):
        if kind == REVOLUTE:
            total = total @ dh_matrix(theta[i] + q[i], d[i], a[i], alpha[i])
        else:
            total = total @ dh_matrix(theta[i], d[i] + q[i], a[i], alpha[i])
    return total


@st.composite
def dh_chains(draw):
    """Random DH chains of 1–7 joints, revolute or prismatic, with a configuration q."""
    n = draw(st.integers(min_value=1, max_value=7))
    a = [draw(lengths) for _ in range(n)]
    d = [draw(lengths) for _ in range(n)]
    alpha = [draw(angles) for _ in range(n)]
    theta = [draw(angles) for _ in range(n)]
    kinds = [draw(st.sampled_from([REVOLUTE, REVOLUTE, PRISMATIC])) for _ in range(n)]
    q = [draw(angles) if kind == REVOLUTE else draw(lengths) for kind in kinds]
    return a, d, alpha, theta, kinds, np.array(q)


def test_seed_003_puma_equations_58_and_59():
    pose = SerialChain.from_dh(**PUMA).fk(PUMA_Q)
    np.testing.assert_allclose(pose.to_array(), PUMA_EQ58, atol=1e-9)
    np.testing.assert_allclose(pose.to_matrix(), PUMA_EQ59, atol=1e-9)


def elementary_product(theta, d, a, alpha):
    """Rz(θ)·Tz(d)·Tx(a)·Rx(α) as four separate 4×4 matrices multiplied (the definition of a DH row)."""
    c, s, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    tz = np.eye(4)
    tz[2, 3] = d
    tx = np.eye(4)
    tx[0, 3] = a
    rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1]])
    return rz @ tz @ tx @ rx


@NO_DEADLINE
@given(angles, lengths, lengths, angles)
def test_dh_matrix_is_the_product_of_its_elementary_motions(theta, d, a, alpha):
    np.testing.assert_allclose(dh_matrix(theta, d, a, alpha), elementary_product(theta, d, a, alpha), atol=1e-15)


@NO_DEADLINE
@given(angles, lengths, lengths, angles)
def test_dh_joint_dual_quaternion_equals_the_dh_matrix(theta, d, a, alpha):
    np.testing.assert_allclose(
        DualQuaternion.from_array(dh_joint(theta, d, a, alpha)).to_matrix(), dh_matrix(theta, d, a, alpha), atol=1e-14
    )


def test_dh_joint_is_seed_003_closed_form_for_the_last_puma_joint():
    # Seed 003 eq. (48): ⁵DQ₆ = [cos(θ6/2), 0, 0, sin(θ6/2), −d6/2·sin(θ6/2), 0, 0, d6/2·cos(θ6/2)].
    theta, d6 = 0.7, 56.25
    expected = [math.cos(theta / 2), 0, 0, math.sin(theta / 2), -d6 / 2 * math.sin(theta / 2), 0, 0,
                d6 / 2 * math.cos(theta / 2)]
    np.testing.assert_allclose(dh_joint(theta, d6, 0.0, 0.0), expected, atol=1e-14)


@settings(NO_DEADLINE, max_examples=150)
@given(dh_chains())
def test_dh_chain_equals_the_dh_matrix_product(chain_case):
    a, d, alpha, theta, kinds, q = chain_case
    chain = SerialChain.from_dh(a, d, alpha, theta, joint_types=kinds)
    np.testing.assert_allclose(chain.fk(q).to_matrix(), matrix_product_fk(a, d, alpha, theta, q, kinds), atol=1e-12)


@settings(NO_DEADLINE, max_examples=150)
@given(dh_chains(), st.integers(min_value=0, max_value=2**32 - 1))
def test_axis_chain_equals_dh_chain(chain_case, seed):
    a, d, alpha, theta, kinds, q = chain_case
    base = DualQuaternion.from_ur_pose(np.random.default_rng(seed).uniform(-1, 1, 6))
    dh_chain = SerialChain.from_dh(a, d, alpha, theta, joint_types=kinds, base=base)
    zero = np.zeros(len(kinds))
    directions, points = dh_chain.joint_axes(zero)
    axis_chain = SerialChain.from_axes(directions, points, dh_chain.home(), joint_types=kinds)
    assert axis_chain.fk(q).is_close(dh_chain.fk(q), tol_m=1e-12, tol_rad=1e-12)
    # ... and the joint axes move the same way, which the DLS Jacobian relies on.
    for got, expected in zip(axis_chain.joint_axes(q), dh_chain.joint_axes(q)):
        np.testing.assert_allclose(got, expected, atol=1e-12)


@settings(NO_DEADLINE, max_examples=60)
@given(dh_chains())
def test_batch_fk_equals_single_fk(chain_case):
    a, d, alpha, theta, kinds, q = chain_case
    chain = SerialChain.from_dh(a, d, alpha, theta, joint_types=kinds)
    configurations = q + np.random.default_rng(1).uniform(-1, 1, (5, len(kinds)))
    batch = chain.fk_batch(configurations)
    assert batch.shape == (5, 8)
    for row, config in zip(batch, configurations):
        np.testing.assert_allclose(row, chain.fk(config).to_array(), atol=1e-14)


def test_batch_fk_spans_several_blocks():
    chain = SerialChain.from_dh(**PUMA)
    configurations = np.random.default_rng(2).uniform(-3, 3, (9000, 6))
    batch = chain.fk_batch(configurations)
    for index in (0, 4095, 4096, 8191, 8999):
        np.testing.assert_allclose(batch[index], chain.fk(configurations[index]).to_array(), atol=1e-12)


def test_prismatic_joints_translate_along_their_axes():
    # A Cartesian gantry: three prismatic axes x, y, z, from base-frame axes.
    gantry = SerialChain.from_axes(
        np.eye(3), np.zeros((3, 3)), DualQuaternion.identity(), joint_types=[PRISMATIC] * 3
    )
    pose = gantry.fk([0.1, -0.2, 0.3])
    np.testing.assert_allclose(pose.translation, [0.1, -0.2, 0.3], atol=1e-15)
    np.testing.assert_allclose(pose.rotation.q, [1, 0, 0, 0], atol=1e-15)


def test_revolute_axis_through_an_offset_point():
    # One joint about +z through (1, 0, 0); the end starts at (2, 0, 0) and turns to (1, 1, 0) at +90°.
    arm = SerialChain.from_axes([[0, 0, 1]], [[1, 0, 0]], DualQuaternion.from_translation([2, 0, 0]))
    np.testing.assert_allclose(arm.fk([math.pi / 2]).translation, [1, 1, 0], atol=1e-15)


def test_base_and_tool_offsets():
    chain = SerialChain.from_dh(**PUMA)
    base = DualQuaternion.from_ur_pose([0.5, 0.1, -0.2, 0.3, 0.2, 0.1])
    tool = [0, 0, 20.0, 0, 0, math.pi / 2]
    expected = base * chain.fk(PUMA_Q) * DualQuaternion.from_ur_pose(tool)
    assert chain.with_base(base).with_tool(tool).fk(PUMA_Q).is_close(expected, tol_m=1e-9)
    assert SerialChain.from_dh(**PUMA, base=base, tool=tool).fk(PUMA_Q).is_close(expected, tol_m=1e-9)


def test_joint_offsets_shift_the_joint_zero():
    plain = SerialChain.from_dh(**PUMA)
    offset = SerialChain(plain._constants, plain.joint_types, joint_offsets=[0.1, 0, 0, 0, 0, -0.2])
    assert offset.fk(PUMA_Q).is_close(plain.fk(PUMA_Q + [0.1, 0, 0, 0, 0, -0.2]))


def test_frames_are_the_dh_frames():
    chain = SerialChain.from_dh(**PUMA)
    frames = chain.frames(PUMA_Q)
    assert frames.shape == (7, 8)
    expected = np.eye(4)
    np.testing.assert_allclose(DualQuaternion.from_array(frames[0]).to_matrix(), expected, atol=1e-12)
    for i in range(6):
        expected = expected @ dh_matrix(PUMA_Q[i], PUMA["d"][i], PUMA["a"][i], PUMA["alpha"][i])
        np.testing.assert_allclose(DualQuaternion.from_array(frames[i + 1]).to_matrix(), expected, atol=1e-9)


def test_joint_axes_are_the_z_axes_of_the_previous_dh_frames():
    chain = SerialChain.from_dh(**PUMA)
    directions, points = chain.joint_axes(PUMA_Q)
    for i, frame in enumerate(chain.frames(PUMA_Q)[:-1]):
        matrix = DualQuaternion.from_array(frame).to_matrix()
        np.testing.assert_allclose(directions[i], matrix[:3, 2], atol=1e-12)
        # The point lies on the axis through the frame origin.
        np.testing.assert_allclose(np.cross(points[i] - matrix[:3, 3], matrix[:3, 2]), 0, atol=1e-9)


def test_axis_chain_frames_are_partial_products_of_exponentials():
    # Two joints about z through (0,0,0) and (1,0,0), end at (2,0,0): frame 1 = exp(ξ1 q1) is a turn about the origin.
    end = DualQuaternion.from_translation([2, 0, 0])
    arm = SerialChain.from_axes([[0, 0, 1], [0, 0, 1]], [[0, 0, 0], [1, 0, 0]], end)
    q = [math.pi / 2, math.pi / 2]
    frames = [DualQuaternion.from_array(f) for f in arm.frames(q)]
    assert frames[0].is_close(DualQuaternion.identity())
    assert frames[1].is_close(DualQuaternion.from_axis_angle([0, 0, 1], math.pi / 2), tol_m=1e-15, tol_rad=1e-15)
    # The last frame is the end pose, exp(ξ1 q1)·exp(ξ2 q2)·M; exp(ξ2 q2) fixes (1,0,0), exp(ξ1 q1) takes it to (0,1,0).
    assert frames[2].is_close(arm.fk(q))
    partial = frames[2] * end.inverse()
    np.testing.assert_allclose(partial.transform_point([1, 0, 0]), [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(arm.fk(q).translation, [-1, 1, 0], atol=1e-15)


@pytest.mark.parametrize("direction", [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0.3, -0.4, 0.5], [1e-9, 0, -1]])
def test_frame_with_z_axis(direction):
    frame = DualQuaternion.from_array(frame_with_z_axis(direction, [1, 2, 3]))
    np.testing.assert_allclose(frame.to_matrix()[:3, 2], np.array(direction) / np.linalg.norm(direction), atol=1e-12)
    np.testing.assert_allclose(frame.translation, [1, 2, 3], atol=1e-15)


@NO_DEADLINE
@given(dh_chains())
def test_thesis_frame_differs_from_the_dh_flange_by_the_home_rotation(chain_case):
    a, d, alpha, theta, kinds, q = chain_case
    dh_chain = SerialChain.from_dh(a, d, alpha, theta, joint_types=kinds)
    home = dh_chain.home()
    directions, points = dh_chain.joint_axes(np.zeros(len(kinds)))
    # The thesis' end frame is parallel to the base at q = 0: home position, identity orientation.
    thesis = SerialChain.from_axes(directions, points, DualQuaternion.from_translation(home.translation), kinds)
    assert thesis.fk(q).is_close(dh_chain.fk(q) * thesis_to_dh_flange(home), tol_m=1e-12, tol_rad=1e-12)


@pytest.mark.parametrize(
    "build, words",
    [
        (lambda: SerialChain.from_dh([0, 1], [0], [0, 0]), "d"),
        (lambda: SerialChain.from_dh([0, float("nan")], [0, 0], [0, 0]), "a"),
        (lambda: SerialChain.from_dh([0], [0], [0], joint_types=["spherical"]), "unknown joint type"),
        (lambda: SerialChain.from_dh([0], [0], [0], joint_types=[REVOLUTE, REVOLUTE]), "joint_types"),
        (lambda: SerialChain.from_dh([0], [0], [0], tool=[0, 0, 0, 0, 0]), "tool"),
        (lambda: SerialChain.from_dh([0], [0], [0], base=[2, 0, 0, 0, 0, 0, 0, 0]), "base"),
        (lambda: SerialChain.from_axes([[0, 0, 0]], [[0, 0, 0]], DualQuaternion.identity()), "direction"),
        (lambda: SerialChain.from_axes([[0, 0, 1]], [[0, 0]], DualQuaternion.identity()), "points"),
        (lambda: SerialChain.from_dh(**PUMA).fk([0, 0, 0]), "q"),
        (lambda: SerialChain.from_dh(**PUMA).fk([0, 0, 0, 0, 0, float("inf")]), "q"),
        (lambda: SerialChain.from_dh(**PUMA).fk_batch(np.zeros((3, 5))), "joint_matrix"),
        (lambda: SerialChain.from_dh(**PUMA).fk_batch(np.zeros(6)), "joint_matrix"),
    ],
)
def test_bad_input_is_a_value_error_naming_the_argument(build, words):
    with pytest.raises(ValueError, match=words):
        build()
