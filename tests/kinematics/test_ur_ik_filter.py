"""ik_all's grouped FK filter (fk_filter._nominal_meets) against the general one (fk_filter._nominal_check).

The grouped check computes the flange rotation once per θ1 (elbow partners and the wrist flip share it) and each
branch's position from shared terms plus its planar 2-link term; it must give exactly the general check's verdict,
on the branches the IK solves and on corrupted ones (a joint off by a little or a lot, an elbow partner moved to
the very edge of the tolerance, a wrist flip that no longer holds, branches moved or absent), and so reject every
wrong branch the general check rejects.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq.kinematics import MODEL_NAMES, robot_model, ur_fk
from ur3dq.kinematics.ur_ik import fk_filter, geometry, single

ANGLE = st.floats(-math.pi, math.pi, allow_nan=False)
JOINTS = st.tuples(*(ANGLE,) * 6).map(np.array)
NEAR_ZERO = st.sampled_from([0.0, 1e-15, -1e-13, 1e-11, -1e-9, 1e-7, -1e-5, 1e-3])
TCP = [0.01, -0.02, 0.15, 0.1, -0.2, 0.3]
# Joint errors around the filter's tolerance (1e-9) and far from it.
ERRORS = st.sampled_from([1e-14, -1e-12, 3e-10, -6e-10, 1e-9, -2e-9, 1e-6, -1e-3, 0.5, math.pi, 2 * math.pi])


def branches_of(name, q, tcp, singular="", theta5=0.0, theta3=0.0):
    """(geometry, _fk_target, the 8 branches of single._nominal_branches) of the pose model.fk(q)."""
    model = robot_model(name).with_tcp(TCP) if tcp else robot_model(name)
    q = np.array(q, dtype=float)
    if singular in ("wrist", "both"):
        q[4] = theta5
    if singular in ("elbow", "both"):
        q[2] = theta3
    g = geometry._geometry(model)
    coefficients, target = fk_filter._targets(g, model.fk(q))
    return g, fk_filter._fk_target(coefficients), single._nominal_branches(g, target, 0.0)


def assert_same_verdicts(g, branches, target):
    expected = [fk_filter._nominal_check(g, branch, target) for branch in branches]
    assert fk_filter._nominal_meets(g, branches, target) == expected, branches


@settings(max_examples=300, deadline=None)
@given(name=st.sampled_from(MODEL_NAMES), q=JOINTS, tcp=st.booleans(), theta5=NEAR_ZERO, theta3=NEAR_ZERO,
       singular=st.sampled_from(["", "wrist", "elbow", "both"]), index=st.integers(0, 7), joint=st.integers(0, 5),
       error=ERRORS)
def test_grouped_filter_gives_the_general_verdicts_on_solved_and_corrupted_branches(name, q, tcp, theta5, theta3,
                                                                                    singular, index, joint, error):
    g, target, branches = branches_of(name, q, tcp, singular, theta5, theta3)
    assert_same_verdicts(g, branches, target)
    corrupted = list(branches)
    corrupted[index] = tuple(v + error if j == joint else v for j, v in enumerate(branches[index]))
    assert_same_verdicts(g, corrupted, target)


@settings(max_examples=100, deadline=None)
@given(name=st.sampled_from(MODEL_NAMES), q=JOINTS, tcp=st.booleans(), first=st.integers(0, 7),
       second=st.integers(0, 7), absent=st.integers(0, 7))
def test_grouped_filter_gives_the_general_verdicts_when_branches_are_moved_or_absent(name, q, tcp, first, second,
                                                                                    absent):
    # Swapped branches break the pairs' shared θ1, θ5, θ6; an absent (NaN) first branch leaves its partner alone.
    g, target, branches = branches_of(name, q, tcp)
    moved = list(branches)
    moved[first], moved[second] = branches[second], branches[first]
    moved[absent] = (math.nan,) * 6
    assert_same_verdicts(g, moved, target)


@settings(max_examples=100, deadline=None)
@given(name=st.sampled_from(MODEL_NAMES), q=JOINTS, tcp=st.booleans(), pair=st.integers(0, 3),
       offset=st.floats(-3e-3, 3e-3))
def test_elbow_partner_at_the_edge_of_the_tolerance_gets_the_general_check(name, q, tcp, pair, offset):
    # θ2 + e and θ4 − e keep θ234 (the pair's rotation) and move the flange by e·|(x4, z4)|, the distance between
    # the axes of joints 2 and 4: e is chosen to put the partner within 0.3 % of the position limit (on a regular
    # pose), where the shared terms' rounding could tip the verdict, so the general check must decide.
    g, target, branches = branches_of(name, q, tcp)
    partner = branches[2 * pair + 1]
    if math.isnan(partner[1]):
        return
    span = math.sqrt(g.a2 ** 2 + g.a3 ** 2 + 2.0 * g.a2 * g.a3 * math.cos(partner[2]))
    error = geometry.FK_TOLERANCE_M / span * (1.0 + offset)
    moved = list(branches)
    moved[2 * pair + 1] = (partner[0], partner[1] + error, partner[2], partner[3] - error, partner[4], partner[5])
    checked = []
    general = fk_filter._nominal_check
    with pytest.MonkeyPatch.context() as patch:   # a spy on the general check
        patch.setattr(fk_filter, "_nominal_check", lambda *args: checked.append(args[1]) or general(*args))
        verdicts = fk_filter._nominal_meets(g, moved, target)
    assert verdicts == [general(g, branch, target) for branch in moved]
    edge = abs(half_distance(g, moved[2 * pair + 1], target) - 0.5 * geometry.FK_TOLERANCE_M)
    if edge < 0.5 * fk_filter._VERDICT_MARGIN:
        assert moved[2 * pair + 1] in checked


def half_distance(g, q, target):
    """|½p_fk − ½p_target| of joints q, from the general FK filter's terms."""
    flange = ur_fk.flange_rotation_position(*g.half_lengths, *q)
    if g.tcp_offset is not None:
        flange = fk_filter._tool_floats(flange, g.tcp_offset)
    return math.dist(flange[4:], target[4:])


@settings(max_examples=100, deadline=None)
@given(name=st.sampled_from(MODEL_NAMES), q=JOINTS, other=JOINTS, tcp=st.booleans())
def test_grouped_filter_rejects_the_branches_of_another_pose(name, q, other, tcp):
    g, target, branches = branches_of(name, q, tcp)
    _, other_target, _ = branches_of(name, other, tcp)
    if np.allclose(target, other_target, atol=1e-6):
        return
    assert not any(fk_filter._nominal_meets(g, branches, other_target))
    assert_same_verdicts(g, branches, other_target)


@settings(max_examples=150, deadline=None)
@given(name=st.sampled_from(MODEL_NAMES), q=JOINTS, tcp=st.booleans(), shoulder=st.sampled_from([0, 4]),
       error=ERRORS, sign=st.sampled_from([-1.0, 1.0]))
def test_grouped_filter_gives_the_general_verdicts_when_a_wrist_flip_is_off(name, q, tcp, shoulder, error, sign):
    # The second pair of a θ1 is judged as the first's wrist flip only while (−θ5, θ6 ∓ π, θ234 ± π) holds within
    # 1e-13: θ6 + e, θ4 ∓ e keep one of θ234 ± θ6 and move the other by 2e, a turn of θ6 (e = 2π) keeps the pose.
    g, target, branches = branches_of(name, q, tcp)
    moved = list(branches)
    for index in (shoulder + 2, shoulder + 3):
        b = branches[index]
        moved[index] = (b[0], b[1], b[2], b[3] + sign * error, b[4], b[5] + error)
    assert_same_verdicts(g, moved, target)
