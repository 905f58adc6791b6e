"""ur3dq's analytic IK against an independent oracle: ``ur_analytic_ik`` (PyPI, C++/Eigen, test-only dependency).

The oracle's conventions, checked here rather than assumed: ``ur_analytic_ik.<model>.forward_kinematics(q1..q6)``
returns the 4×4 flange pose (DH frame 6) in DH frame 0 — the UR controller's base frame, the same as ours (not
ROS ``base_link``, which is turned π about z); ``inverse_kinematics(T)`` returns a list of (6,) arrays, angles
wrapped into [−π, π], duplicates closer than 1e-12 dropped and an element-wise 1e-9 FK filter applied. It has no
UR16e-specific quirks: every one of our seven models exists there under the same name.
Its ``inverse_kinematics_closest`` minimises a different distance (sum of wrapped |Δq|, then a ±2π pick per joint
without joint limits), so the nearest-solution choice is tested against brute force in test_ur_ik.py instead.
"""
import math

import numpy as np
import pytest

from ur3dq import dqarray
from ur3dq.kinematics import MODEL_NAMES, robot_model, ur_ik

ur_analytic_ik = pytest.importorskip("ur_analytic_ik")

POSES_PER_MODEL = 3000
SINGLE_CALLS_PER_MODEL = 300


def random_configurations(seed: int, count: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-math.pi, math.pi, (count, 6))


def oracle_solutions(oracle, matrix) -> list:
    return [np.asarray(solution, dtype=float).reshape(6) for solution in oracle.inverse_kinematics(matrix)]


def same_set(ours, theirs, tol=1e-9) -> bool:
    """Equal as sets of joint vectors modulo 2π (each element of one within ``tol`` of some element of the other)."""
    if len(ours) != len(theirs):
        return False
    if not ours:
        return True
    gaps = np.max(np.abs(ur_ik.wrap_angle(np.array(ours)[:, None, :] - np.array(theirs)[None, :, :])), axis=-1)
    return bool(np.all(gaps.min(axis=1) <= tol) and np.all(gaps.min(axis=0) <= tol))


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_forward_kinematics_agrees_with_the_oracle_to_1e12(name):
    model = robot_model(name)
    oracle = getattr(ur_analytic_ik, name)
    joints = random_configurations(1, POSES_PER_MODEL)
    ours = dqarray.to_matrix(model.fk_batch(joints))
    ur_analytic_ik_matrices = np.array([oracle.forward_kinematics(*q) for q in joints])
    assert np.max(np.abs(ours - ur_analytic_ik_matrices)) < 1e-12


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_batch_ik_finds_the_oracles_solution_set_on_thousands_of_poses(name, capfd):
    model = robot_model(name)
    oracle = getattr(ur_analytic_ik, name)
    joints = random_configurations(2, POSES_PER_MODEL)
    poses = model.fk_batch(joints)
    ours = ur_ik.ik_all_batch(model, poses)
    differing = []
    for i, q in enumerate(joints):
        mine = [row for row in ours[i] if np.all(np.isfinite(row))]
        theirs = oracle_solutions(oracle, oracle.forward_kinematics(*q))
        if not same_set(mine, theirs):
            differing.append((q, mine, theirs))
    capfd.readouterr()   # the oracle prints a warning for each branch its own FK filter drops
    assert differing == []
    # Also: every configuration drawn is among our solutions (the oracle agreeing is not the only evidence).
    gaps = np.max(np.abs(ur_ik.wrap_angle(ours - joints[:, None, :])), axis=-1)
    assert np.all(np.nanmin(gaps, axis=1) < 1e-8)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_single_ik_all_finds_the_oracles_solution_set(name, capfd):
    model = robot_model(name)
    oracle = getattr(ur_analytic_ik, name)
    for q in random_configurations(3, SINGLE_CALLS_PER_MODEL):
        pose = model.fk(q)
        theirs = oracle_solutions(oracle, pose.to_matrix())
        assert same_set(ur_ik.ik_all(model, pose), theirs), q
    capfd.readouterr()
