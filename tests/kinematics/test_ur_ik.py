"""Analytic UR inverse kinematics (ur3dq.kinematics.ur_ik): round trips, singularities, limits, batches, bad input.

FK here is the model's own (ur3dq.kinematics.models), an implementation independent of the IK's equations.
"""
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from ik_cost import assert_least_cost
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import UnreachablePoseError
from ur3dq.kinematics import MODEL_NAMES, DHParameters, URModel, robot_model, ur_ik
from ur3dq.kinematics.models import NOMINAL_ALPHA

ANGLE = st.floats(-math.pi, math.pi, allow_nan=False)
JOINTS = st.tuples(*(ANGLE,) * 6).map(np.array)
# Values at and around the singular points: exactly singular, a rounding error away, and just resolvable.
NEAR_ZERO = st.sampled_from([0.0, 1e-15, -1e-13, 1e-11, -1e-9, 1e-7, -1e-5, 1e-3])
CALIBRATION = {
    "a": [1.2e-4, -2.1e-4, 3.0e-4, 0.8e-4, -0.5e-4, 0.2e-4],
    "d": [-1.0e-4, 2.0e-4, -1.5e-4, 1.0e-4, 0.7e-4, -0.4e-4],
    "alpha": [2.0e-4, -1.0e-4, 1.5e-4, -2.0e-4, 1.0e-4, 0.5e-4],
    "theta": [1.0e-4, -3.0e-4, 2.0e-4, 1.0e-4, -1.0e-4, 2.0e-4],
}


def pose_error(model, q, pose):
    """(metres, radians) between the model's FK at q and ``pose``."""
    return model.fk(q).distance(pose)


def assert_fk_matches(model, q, pose, tol=ur_ik.FK_TOLERANCE_M):
    metres, radians = pose_error(model, q, pose)
    assert metres <= tol and radians <= tol, (q, metres, radians)


def wrapped_distance(a, b):
    """Largest joint difference modulo 2π."""
    return float(np.max(np.abs(ur_ik.wrap_angle(np.asarray(a) - np.asarray(b)))))


def contains(solutions, q, tol):
    return any(wrapped_distance(s, q) <= tol for s in solutions)


def well_conditioned(model, q, margin=1e-3):
    """True when q is at least ``margin`` from the wrist, elbow and shoulder singularities."""
    a2, a3, d5 = model.dh.a[1], model.dh.a[2], model.dh.d[4]
    shoulder = a2 * math.cos(q[1]) + a3 * math.cos(q[1] + q[2]) + d5 * math.sin(q[1] + q[2] + q[3])
    return abs(math.sin(q[4])) > margin and abs(math.sin(q[2])) > margin and abs(shoulder) > margin


@settings(max_examples=200, deadline=None)
@given(angle=st.floats(-1e3, 1e3, allow_nan=False) | st.sampled_from([math.pi, -math.pi, 3 * math.pi, 0.0]))
def test_wrap_angle_maps_into_minus_pi_exclusive_to_pi_inclusive(angle):
    wrapped = float(ur_ik.wrap_angle(angle))
    assert -math.pi < wrapped <= math.pi
    turns = (angle - wrapped) / (2 * math.pi)
    assert abs(turns - round(turns)) < 1e-9
    assert float(ur_ik.wrap_angle(np.array([angle]))[0]) == wrapped


# ------------------------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=60, deadline=None)
@given(q=JOINTS)
def test_fk_then_ik_all_recovers_the_configuration_for_every_model(name, q):
    model = robot_model(name)
    pose = model.fk(q)
    solutions = ur_ik.ik_all(model, pose)
    assert 1 <= len(solutions) <= 8
    for solution in solutions:
        assert np.all(solution > -math.pi) and np.all(solution <= math.pi)
        assert_fk_matches(model, solution, pose)
    for i, a in enumerate(solutions):
        for b in solutions[i + 1:]:
            assert wrapped_distance(a, b) >= ur_ik.DUPLICATE_TOLERANCE
    # Away from singularities the configuration itself is among them (near one, only its pose is guaranteed:
    # the ± roots there amplify rounding to √ε, and a singular wrist is a family).
    if well_conditioned(model, q):
        assert contains(solutions, q, 1e-6)


@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=40, deadline=None)
@given(q=JOINTS)
def test_ik_with_the_configuration_as_reference_returns_it(name, q):
    model = robot_model(name)
    assume(well_conditioned(model, q))
    assert np.max(np.abs(ur_ik.ik(model, model.fk(q), q) - q)) < 1e-9


@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=40, deadline=None)
@given(q=JOINTS, theta5=NEAR_ZERO, theta3=NEAR_ZERO, wrist_at_pi=st.booleans())
def test_near_singular_configurations_round_trip(name, q, theta5, theta3, wrist_at_pi):
    model = robot_model(name)
    q = q.copy()
    q[2] = theta3
    q[4] = theta5 + (math.pi if wrist_at_pi else 0.0)
    pose = model.fk(q)
    solutions = ur_ik.ik_all(model, pose)
    for solution in solutions:
        assert_fk_matches(model, solution, pose)
    nearest = ur_ik.ik(model, pose, q)
    assert_fk_matches(model, nearest, pose)
    # The wrist may turn into the θ4 ± θ6 family; a nearly singular wrist leaves the θ4/θ6 split uncertain by
    # ~ε/θ5 and a stretched elbow turns that into √ of it in θ2, θ3 (3e-4 rad at θ5 = 1e-9, the pose still met
    # to 1e-9). What must not happen is a flip to another branch (≥ 0.1 rad away).
    assert np.max(np.abs(nearest[:3] - q[:3])) < 5e-3


def test_stretched_elbow_with_a_nearly_singular_wrist_keeps_its_branch():
    # θ5 = −1e-5 leaves the θ234/θ6 split uncertain by ~1e-10 rad, enough to put the stretched elbow a rounding
    # error out of reach: the branch is moved back along the wrist family instead of being lost (found by search).
    model = robot_model("ur16e")
    q = np.array([-2.411725027493826, 1.3275180419148693, -1e-09, 0.057027735030118265, -1e-05, 2.8639610290870943])
    pose = model.fk(q)
    nearest = ur_ik.ik(model, pose, q)
    assert_fk_matches(model, nearest, pose)
    assert np.max(np.abs(nearest[:3] - q[:3])) < 5e-3
    # The batch path rounds differently (numpy vs libm) and this pose amplifies rounding: same branch, pose met.
    batch = ur_ik.ik_batch(model, pose.to_array()[None], q)[0]
    assert_fk_matches(model, batch, pose)
    assert np.max(np.abs(batch[:3] - q[:3])) < 5e-3


def shoulder_singular_configuration(model, theta1, theta3, sine234, theta5, theta6):
    """q whose wrist centre lies in the arm plane on the base axis (x5² + y5² = d4²), with sin θ234 = sine234.

    In the arm plane the wrist centre sits at a2 c2 + a3 c23 + d5 s234 = A cos(θ2 + γ) + d5 s234 from the base
    axis (A, γ: polar form of a2 + a3·e^{iθ3}); θ2 = acos(−d5 s234 / A) − γ puts it on the axis.
    """
    a2, a3, d5 = model.dh.a[1], model.dh.a[2], model.dh.d[4]
    along, across = a2 + a3 * math.cos(theta3), a3 * math.sin(theta3)
    theta2 = math.acos(-d5 * sine234 / math.hypot(along, across)) - math.atan2(across, along)
    theta234 = math.asin(sine234)
    return np.array([theta1, theta2, theta3, theta234 - theta2 - theta3, theta5, theta6])


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur16e"])
@settings(max_examples=40, deadline=None)
@given(theta1=ANGLE, theta3=ANGLE, sine234=st.floats(-0.3, 0.3), theta5=ANGLE, theta6=ANGLE)
def test_shoulder_singularity_merges_the_two_theta1_branches(name, theta1, theta3, sine234, theta5, theta6):
    model = robot_model(name)
    assume(abs(math.sin(theta5)) > 1e-3 and abs(math.sin(theta3)) > 1e-3)
    q = shoulder_singular_configuration(model, theta1, theta3, sine234, theta5, theta6)
    pose = model.fk(q)
    solutions = ur_ik.ik_all(model, pose)
    for solution in solutions:
        assert_fk_matches(model, solution, pose)
    # The ± of eq. 4.11 vanishes (up to √rounding): every solution's θ1 is the configuration's.
    assert all(abs(ur_ik.wrap_angle(s[0] - theta1)) < 1e-6 for s in solutions)
    # √ε ≈ 1e-8 rad in θ1 moves the other joints by up to ~1e-6 rad (pose still met to 1e-9): allow 1e-4.
    assert contains(solutions, q, 1e-4)


def test_seed_000_home_pose_gives_the_thesis_solution_and_passes_the_filter():
    # Thesis §4.5: q = (0, −π/2, 0, −π/2, 0, 0) is singular three times over (shoulder, stretched elbow, wrist);
    # its printout lists 4 sets that are this one configuration modulo 2π and ±3e-8 rounding in θ3.
    model = robot_model("ur3")
    home = np.array([0.0, -math.pi / 2, 0.0, -math.pi / 2, 0.0, 0.0])
    pose = model.fk(home)
    solutions = ur_ik.ik_all(model, pose)
    thesis_sets = [[2 * math.pi, -1.570796340704604, 2.98e-08, 4.7123889644920745, 0.0, 0.0],
                   [2 * math.pi, -1.5707963128851894, -2.98e-08, 4.71238896420745, 0.0, 0.0]]
    for solution in solutions:
        assert_fk_matches(model, solution, pose)
        assert wrapped_distance(solution, home) < 1e-7
    for thesis in thesis_sets:
        assert contains(solutions, thesis, 1e-7)
        assert pose_error(model, thesis, pose)[0] < 1e-3   # the thesis' own filter tolerance


# ----------------------------------------------------------------------------------------- wrist singularity
def test_wrist_singular_ik_all_puts_theta6_at_zero_and_keeps_the_sum():
    model = robot_model("ur5")
    q = np.array([0.4, -1.1, 1.3, -0.7, 0.0, 0.3])
    pose = model.fk(q)
    solutions = ur_ik.ik_all(model, pose)
    for solution in solutions:
        assert_fk_matches(model, solution, pose)
    # The configuration's θ1 makes the wrist singular (the other θ1 does not): there the two θ5 signs merge.
    singular = [s for s in solutions if abs(s[0] - q[0]) < 1e-9]
    assert len(singular) == 2
    assert all(s[4] == 0.0 and s[5] == 0.0 for s in singular)
    # The configuration's own branch: same θ1, same θ2 + θ3 + θ4 + θ6 (the only orientation the wrist fixes).
    same_branch = [s for s in solutions if abs(s[0] - q[0]) < 1e-9 and np.sign(s[2]) == np.sign(q[2])]
    assert len(same_branch) == 1
    assert abs(ur_ik.wrap_angle(same_branch[0][1:4].sum() - (q[1:4].sum() + q[5]))) < 1e-9


def test_wrist_singular_split_out_of_reach_moves_to_the_nearest_reachable_one():
    model = robot_model("ur5")
    # Elbow stretched and wrist singular: θ6 = 0 would put the wrist beyond reach, so θ6 moves just enough.
    q = np.array([0.0, -0.5, 0.0, 0.0, 0.0, 1.0])
    pose = model.fk(q)
    solutions = ur_ik.ik_all(model, pose)
    for solution in solutions:
        assert_fk_matches(model, solution, pose)
    assert contains(solutions, q, 1e-4)
    nearest = ur_ik.ik(model, pose, q)
    assert np.max(np.abs(nearest - q)) < 1e-4


def test_wrist_singular_at_pi_keeps_theta6_at_the_reference_and_the_difference():
    model = robot_model("ur10e")
    q = np.array([-0.8, -1.9, 0.9, 0.3, math.pi, -0.6])
    pose = model.fk(q)
    reference = q + np.array([0.01, 0.01, -0.01, 0.0, 0.0, 0.25])
    nearest = ur_ik.ik(model, pose, reference)
    assert nearest[5] == pytest.approx(reference[5], abs=1e-12)
    # At θ5 = π the wrist fixes θ2 + θ3 + θ4 − θ6 only; θ2, θ3 follow the position.
    assert abs(ur_ik.wrap_angle((nearest[1:4].sum() - nearest[5]) - (q[1:4].sum() - q[5]))) < 1e-9
    assert_fk_matches(model, nearest, pose)


def test_replay_through_the_wrist_singularity_keeps_theta6_continuous():
    model = robot_model("ur3e")
    base = np.array([0.3, -1.4, 1.2, -1.1, 0.0, 0.7])
    current = base.copy()
    current[4] = 2e-3
    steps = []
    for theta5 in np.linspace(2e-3, -2e-3, 41):   # passes exactly through θ5 = 0
        q = base.copy()
        q[4] = theta5
        solution = ur_ik.ik(model, model.fk(q), current)
        steps.append(np.max(np.abs(solution - current)))
        current = solution
        assert_fk_matches(model, solution, model.fk(q))
        assert abs(solution[5] - base[5]) < 1e-6
    assert max(steps) < 1e-3


# ------------------------------------------------------------------------------------------ unreachable
def test_far_pose_is_unreachable_too_far():
    model = robot_model("ur3")
    with pytest.raises(UnreachablePoseError, match="too far"):
        ur_ik.ik_all(model, DualQuaternion.from_ur_pose([1.5, 0.2, 0.3, 0.0, math.pi, 0.0]))


def test_wrist_centre_on_the_base_axis_is_too_close_to_the_base_axis():
    model = robot_model("ur5e")
    # Tool pointing straight down with the wrist centre on the base z-axis: closer than the d4 offset.
    d6 = model.dh.d[5]
    pose = DualQuaternion.from_ur_pose([0.0, 0.0, 0.4 - d6, math.pi, 0.0, 0.0])
    with pytest.raises(UnreachablePoseError, match="too close to the base axis"):
        ur_ik.ik(model, pose, np.zeros(6))


def test_pose_inside_the_folded_arm_is_unreachable_too_close():
    # On UR arms d5 > |a2| − |a3|, so the wrist offset always lets the folded elbow reach; a long upper arm
    # (a2 = 0.6 m, a3 = 0.2 m, d5 = 0.05 m) cannot bring its wrist within 0.4 m of the shoulder.
    dh = DHParameters(a=np.array([0.0, -0.6, -0.2, 0.0, 0.0, 0.0]), d=np.array([0.1, 0.0, 0.0, 0.1, 0.05, 0.08]),
                      alpha=np.array(NOMINAL_ALPHA), theta=np.zeros(6))
    model = URModel("long upper arm", dh, np.ones(6), np.full(6, -2 * math.pi), np.full(6, 2 * math.pi))
    with pytest.raises(UnreachablePoseError, match="too close: the elbow would have to span"):
        ur_ik.ik_all(model, DualQuaternion.from_ur_pose([0.0, -0.18, 0.1, math.pi / 2, 0.0, 0.0]))


def test_solutions_outside_narrow_limits_are_reported_as_outside_limits():
    nominal = robot_model("ur3")
    narrow = URModel("ur3", nominal.dh, nominal.max_joint_speed, np.full(6, -0.5), np.full(6, 0.5))
    q = np.array([0.3, -1.2, 1.1, -0.5, 0.8, 0.2])   # shoulder at −1.2 lies outside ±0.5
    with pytest.raises(UnreachablePoseError, match="outside limits"):
        ur_ik.ik(narrow, nominal.fk(q), np.zeros(6))


def test_unreachable_error_is_a_value_error():
    assert issubclass(UnreachablePoseError, ValueError)


# ------------------------------------------------------------------------------------ ±2π and the reference
def test_ik_picks_the_2pi_variant_nearest_the_reference_inside_the_limits():
    model = robot_model("ur3")   # ±2π everywhere, wrist 3 unlimited
    q = np.array([0.5, -1.0, 1.0, -1.5, 1.2, -0.4])
    pose = model.fk(q)
    shifted = q + np.array([-2 * math.pi, 0.0, -2 * math.pi, 0.0, 0.0, 6 * math.pi])
    assert np.allclose(ur_ik.ik(model, pose, shifted), shifted, atol=1e-9)
    # Joint 1 cannot go to 0.5 + 2π (beyond +2π): with the base weighted lightly (so this branch stays the
    # nearest) the variant inside the limits nearest the reference is 0.5 itself.
    beyond = shifted + np.array([4 * math.pi, 0, 0, 0, 0, 0])
    expected = shifted.copy()
    expected[0] = 0.5
    weights = [1e-3, 1.0, 1.0, 1.0, 1.0, 1.0]
    assert np.allclose(ur_ik.ik(model, pose, beyond, weights), expected, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(q=JOINTS, reference=JOINTS, weights=st.tuples(*(st.floats(0.1, 10.0),) * 6))
def test_ik_returns_the_weighted_nearest_of_all_variants(q, reference, weights):
    model = robot_model("ur5e")
    pose = model.fk(q)
    chosen = ur_ik.ik(model, pose, reference, weights)
    weights = np.array(weights)
    assert_least_cost(float(np.sum(weights * (chosen - reference) ** 2)), model, pose, reference, weights)
    assert_fk_matches(model, chosen, pose)


def test_joint_variants_lists_every_2pi_shift_inside_the_limits():
    model = robot_model("ur3")   # ±2π, wrist 3 unlimited (listed within ±2π)
    variants = ur_ik.joint_variants(model, [0.5, -3.0, 0.0, 1.0, 2.0, 3.0])
    per_joint = [sorted(set(np.round(variants[:, j], 12))) for j in range(6)]
    assert per_joint[0] == pytest.approx([0.5 - 2 * math.pi, 0.5])
    assert per_joint[1] == pytest.approx([-3.0, -3.0 + 2 * math.pi])
    assert per_joint[2] == pytest.approx([-2 * math.pi, 0.0, 2 * math.pi])
    assert len(variants) == 2 * 2 * 3 * 2 * 2 * 2
    assert np.all(variants >= model.joint_lower) and np.all(variants <= model.joint_upper)


def test_wrist_singular_pose_beyond_reach_says_so():
    model = robot_model("ur3")
    d4, d6 = model.dh.d[3], model.dh.d[5]
    # z6 along z1 of θ1 = 0 with the wrist centre exactly d4 from the base axis: θ5 = 0 for the only θ1.
    pose = DualQuaternion.from_ur_pose([0.0, -d4 - d6, 1.0, math.pi / 2, 0.0, 0.0])
    with pytest.raises(UnreachablePoseError, match="wrist singular .* too far"):
        ur_ik.ik_all(model, pose)


# ------------------------------------------------------------------------------------------ TCP, calibrated
@settings(max_examples=40, deadline=None)
@given(q=JOINTS)
def test_round_trip_with_a_tcp_offset(q):
    model = robot_model("ur10").with_tcp([0.02, -0.01, 0.18, 0.3, -0.2, 1.0])
    assume(well_conditioned(model, q))
    pose = model.fk(q)
    assert np.max(np.abs(ur_ik.ik(model, pose, q) - q)) < 1e-9


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur10"])
@settings(max_examples=30, deadline=None)
@given(q=JOINTS)
def test_calibrated_models_converge_to_the_configuration(name, q):
    # Documented limit: within ~0.05 rad of the wrist singularities or the folded elbow a calibrated model's
    # Newton steps may land on a neighbouring solution, so those neighbourhoods are left out here.
    assume(abs(math.sin(q[4])) > 0.05 and abs(math.sin(q[2])) > 0.05)
    model = robot_model(name, dh_deltas=CALIBRATION).with_tcp([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    pose = model.fk(q)
    solutions = ur_ik.ik_all(model, pose)
    for solution in solutions:
        metres, radians = pose_error(model, solution, pose)
        assert metres < 1e-11 and radians < 1e-11
    assert np.max(np.abs(ur_ik.ik(model, pose, q) - q)) < 1e-9


def test_calibrated_model_reaches_beyond_its_nominal_stretched_elbow():
    model = robot_model("ur5e", dh_deltas=CALIBRATION)
    q = np.array([0.7, -0.9, 0.004, -1.3, 1.1, 0.2])   # nearly stretched: outside the nominal reach
    pose = model.fk(q)
    assert np.max(np.abs(ur_ik.ik(model, pose, q) - q)) < 1e-9


# ------------------------------------------------------------------------------------------------- batches
@pytest.mark.parametrize("name", ["ur3", "ur16e"])
def test_ik_batch_equals_ik_row_by_row_with_nan_for_unreachable(name):
    model = robot_model(name)
    rng = np.random.default_rng(11)
    joints = rng.uniform(-math.pi, math.pi, (200, 6))
    poses = model.fk_batch(joints)
    poses[7] = DualQuaternion.from_ur_pose([3.0, 0.0, 0.0, 0.0, 0.0, 0.0]).to_array()
    references = joints + rng.normal(0.0, 0.05, joints.shape)
    batch = ur_ik.ik_batch(model, poses, references)
    assert np.all(np.isnan(batch[7]))
    for i in range(len(joints)):
        if i == 7:
            continue
        single = ur_ik.ik(model, DualQuaternion.from_array(poses[i]), references[i])
        assert np.max(np.abs(batch[i] - single)) < 1e-9


def test_ik_all_batch_holds_the_same_solution_sets_as_ik_all():
    model = robot_model("ur5").with_tcp([0.0, 0.05, 0.12, 0.0, 0.4, 0.0])
    rng = np.random.default_rng(5)
    joints = rng.uniform(-math.pi, math.pi, (100, 6))
    joints[:10, 4] = 0.0    # wrist singular rows
    joints[10:20, 2] = 0.0  # stretched elbow rows
    poses = model.fk_batch(joints)
    batch = ur_ik.ik_all_batch(model, poses)
    assert batch.shape == (100, 8, 6)
    for i in range(len(joints)):
        rows = [row for row in batch[i] if np.all(np.isfinite(row))]
        singles = ur_ik.ik_all(model, DualQuaternion.from_array(poses[i]))
        assert len(rows) == len(singles)
        for single in singles:
            assert contains(rows, single, 1e-9)


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur10e"])
def test_ik_all_batch_and_ik_all_merge_near_singular_pairs_alike(name):
    """One merge rule for both paths: near a singularity the branch pairs sit ~1e-8 rad apart after rounding, each
    path rounding differently; both must merge (or keep) the same pairs."""
    model = robot_model(name)
    rng = np.random.default_rng(17)
    joints = rng.uniform(-math.pi, math.pi, (2000, 6))
    near = np.array([0.0, 1e-15, -1e-12, 1e-10, -1e-9, 3e-9, 1e-8, -1e-7, 1e-6, -1e-5])
    joints[:1000, 4] = rng.choice(near, 1000) + rng.choice([0.0, math.pi], 1000)   # wrist
    joints[500:1500, 2] = rng.choice(near, 1000)                                    # elbow
    poses = model.fk_batch(joints)
    batch = ur_ik.ik_all_batch(model, poses)
    disagreements = []
    for i in range(len(joints)):
        count = int(np.sum(np.all(np.isfinite(batch[i]), axis=1)))
        try:
            singles = len(ur_ik.ik_all(model, DualQuaternion.from_array(poses[i])))
        except UnreachablePoseError:
            singles = 0
        if count != singles:
            disagreements.append((i, count, singles))
    assert disagreements == []


def test_calibrated_ik_batch_matches_the_configurations():
    model = robot_model("ur10e", dh_deltas=CALIBRATION)
    rng = np.random.default_rng(8)
    joints = rng.uniform(-math.pi, math.pi, (300, 6))
    joints = joints[(np.abs(np.sin(joints[:, 4])) > 0.05) & (np.abs(np.sin(joints[:, 2])) > 0.05)]
    solved = ur_ik.ik_batch(model, model.fk_batch(joints), joints)
    assert np.max(np.abs(solved - joints)) < 1e-9


# ----------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("pose, message", [
    ([1.0, 0, 0, 0, 0, 0, 0], "pose"),
    ([1.0, 0, 0, 0, 0, math.nan, 0, 0], "NaN"),
    ([2.0, 0, 0, 0, 0, 0, 0, 0], "not a unit"),
    ([1.0, 0, 0, 0, 0.3, 0, 0, 0], "not a unit dual quaternion"),
    ("text", "pose"),
])
def test_bad_pose_raises_value_error_naming_it(pose, message):
    model = robot_model("ur3")
    with pytest.raises(ValueError, match=message):
        ur_ik.ik_all(model, pose)
    with pytest.raises(ValueError, match=message):
        ur_ik.ik(model, pose, np.zeros(6))


@pytest.mark.parametrize("q_ref, weights, message", [
    (np.zeros(5), None, "q_ref"),
    ([0, 0, 0, math.inf, 0, 0], None, "q_ref.*NaN or infinite"),
    (np.zeros(6), [1, 1, 1, 1, 0, 1], "weights"),
    (np.zeros(6), [1, 1, 1], "weights"),
])
def test_bad_reference_or_weights_raise_value_error_naming_them(q_ref, weights, message):
    model = robot_model("ur3")
    pose = model.fk([0.1, -1.0, 1.0, -1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=message):
        ur_ik.ik(model, pose, q_ref, weights)


@pytest.mark.parametrize("poses, q_ref, message", [
    (np.zeros((3, 7)), np.zeros(6), "poses: expected shape"),
    (np.full((2, 8), math.nan), np.zeros(6), "poses"),
    (np.tile([1.0, 0, 0, 0, 0, 0, 0, 0], (2, 1)), np.zeros((3, 6)), "q_ref"),
])
def test_bad_batch_input_raises_value_error(poses, q_ref, message):
    with pytest.raises(ValueError, match=message):
        ur_ik.ik_batch(robot_model("ur3"), poses, q_ref)


def test_model_methods_delegate_to_the_solver():
    model = robot_model("ur3e")
    q = np.array([0.2, -1.3, 1.4, -0.9, 0.7, 0.1])
    pose = model.fk(q)
    assert np.allclose(model.ik(pose, q), q, atol=1e-9)
    assert contains(model.ik_all(pose), q, 1e-9)
    assert np.allclose(model.ik_batch(pose.to_array()[None], q), q[None], atol=1e-9)
