"""The DLS solver's compiled kernels: interpreted (NUMBA_DISABLE_JIT=1) and compiled agree, the damped solve's two
paths, and the kernels against numpy references."""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq import dqarray
from ur3dq.kinematics import SerialChain, robot_model
from ur3dq.kinematics import dls_kernels as kernels
from ur3dq.kinematics.chain_kernels import chain_axes
from ur3dq.kinematics.dls import damped_least_squares_step, pose_error

# One sample of every kernel path, run here compiled and in a subprocess interpreted: the improved mode with one and
# with two searches (the second's answer turned by a whole turn), paper mode with both Jacobians, and the solve.
SAMPLE = r"""
import json, math
import numpy as np
from ur3dq.kinematics import SerialChain, robot_model
from ur3dq.kinematics import dls_kernels
from ur3dq.kinematics.dls import dls_ik, damped_least_squares_step

ur3 = robot_model("ur3")
planar = SerialChain.from_dh(a=[60.0, 100.0, 80.0], d=[0.0] * 3, alpha=[0.0] * 3)
goal = np.array([-190.5256, -110.0, 0.0, 0.0, 0.0, 3.6652])
rng = np.random.default_rng(5)
runs = []
for _ in range(3):
    q_goal = rng.uniform(-math.pi, math.pi, 6)
    runs.append(dls_ik(ur3, ur3.fk(q_goal), q_goal + rng.uniform(-0.2, 0.2, 6), mode="improved"))
runs.append(dls_ik(planar, goal, [0.0, -1.0, 0.3], mode="improved", lower=[0.0, -np.inf, -np.inf],
                   upper=[6.0, np.inf, np.inf]))
runs.append(dls_ik(planar, goal, np.zeros(3)))
runs.append(dls_ik(ur3, ur3.fk([0.5] * 6), [0.4] * 6, gamma=0.22e-3, tolerance=1e-6, jacobian="exact"))
matrix = rng.normal(size=(6, 4))
matrix[:, 3] = matrix[:, 0]   # rank 3: the undamped solve takes the SVD path
steps = [damped_least_squares_step(matrix, rng.normal(size=6), 1.0, gamma) for gamma in (0.0, 0.1)]
print(json.dumps({
    "compiled": hasattr(dls_kernels.improved_solve, "py_func"),
    "runs": [[r.iterations, r.searches, r.q.tolist(), r.error_log.tolist(), r.pose_log.tolist()] for r in runs],
    "steps": [step.tolist() for step in steps],
}))
"""


def run_sample(environment: dict) -> dict:
    done = subprocess.run([sys.executable, "-c", SAMPLE], env=environment, capture_output=True, text=True,
                          timeout=170, check=True)
    return json.loads(done.stdout)


def test_interpreted_and_compiled_kernels_agree():
    compiled = run_sample({**os.environ, "NUMBA_DISABLE_JIT": "0"})
    interpreted = run_sample({**os.environ, "NUMBA_DISABLE_JIT": "1"})
    assert compiled["compiled"] and not interpreted["compiled"]
    assert len(compiled["runs"]) == len(interpreted["runs"])
    assert any(run[1] == 2 for run in compiled["runs"])   # the sample covers the second search
    for ours, reference in zip(compiled["runs"], interpreted["runs"], strict=True):
        assert ours[:2] == reference[:2]   # passes and searches
        for got, expected in zip(ours[2:], reference[2:], strict=True):
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(compiled["steps"], interpreted["steps"], rtol=0, atol=1e-12)


def svd_reference(jacobian: np.ndarray, error: np.ndarray, damping: float) -> np.ndarray:
    """Σ s/(s² + damping)·v·uᵀ·error by numpy's SVD, rank deficiency dropped as the kernel drops it."""
    u, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
    denominator = singular * singular + damping
    kept = denominator > (np.finfo(float).eps * max(float(singular.max(initial=0.0)), 1.0)) ** 2
    gains = np.divide(singular, denominator, out=np.zeros_like(singular), where=kept)
    return vt.T @ (gains * (u.T @ error))


@pytest.mark.parametrize("shape", [(6, 6), (6, 7), (6, 3)])
@pytest.mark.parametrize("damping", [0.0, 1e-8, 1e-2, 3.0])
def test_damped_solve_matches_numpy_on_both_paths(shape, damping):
    rng = np.random.default_rng(sum(shape))
    for rank_deficient in (False, True):
        jacobian = rng.normal(size=shape)
        if rank_deficient:
            jacobian[:, -1] = 0.5 * jacobian[:, 0]
        error = rng.normal(size=shape[0])
        expected = svd_reference(jacobian, error, damping)
        step, svd_step = np.empty(shape[1]), np.empty(shape[1])
        kernels.damped_least_squares_into(jacobian, error, damping, step)
        kernels.svd_damped_solve_into(jacobian, error, damping, svd_step)
        # Where J is short of rank its rounding-level singular value over a damping of 1e-8 leaves ~1e-8 of noise
        # in any SVD; Cholesky's error grows with the condition number it accepts (below ~1e8).
        np.testing.assert_allclose(svd_step, expected, rtol=1e-7, atol=1e-7)
        np.testing.assert_allclose(step, expected, rtol=1e-7, atol=1e-7)


def test_singular_system_takes_the_svd_path():
    jacobian = np.array([[1.0, 1.0], [0.0, 0.0], [2.0, 2.0]])
    normal = jacobian.T @ jacobian
    assert not kernels.cholesky_solve_into(normal, np.ones(2), np.empty(2))
    np.testing.assert_allclose(damped_least_squares_step(jacobian, [1.0, 0.0, 2.0], 1.0, 0.0), [0.5, 0.5])


@settings(max_examples=200, deadline=None)
@given(q=st.tuples(*(st.floats(-3.2, 3.2),) * 6), delta=st.tuples(*(st.floats(-1.0, 1.0),) * 6),
       tiny=st.sampled_from([1.0, 1e-3, 1e-5, 1e-9, 0.0]), flip=st.booleans())
def test_pose_error_equals_the_numpy_forms(q, delta, tiny, flip):
    # At large, small (Taylor branch) and zero differences, and with the goal given on the other sheet.
    chain = robot_model("ur3").chain
    sigma = chain.fk(np.array(q)).to_array()
    goal = chain.fk(np.array(q) + tiny * np.array(delta)).to_array() * (-1.0 if flip else 1.0)
    relative = dqarray.quaternion_multiply(goal[:4], dqarray.quaternion_conjugate(sigma[:4]))
    expected = np.concatenate((dqarray.translation(goal) - dqarray.translation(sigma),
                               dqarray.quaternion_to_rotation_vector(relative)))
    np.testing.assert_allclose(pose_error(sigma, goal), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("chain", [robot_model("ur3").chain, SerialChain.from_dh(
    a=[0.35, 0.3, 0.0, 0.0], d=[0.4, 0.0, 0.0, 0.1], alpha=[0.0, math.pi, 0.0, 0.0],
    joint_types=["revolute", "revolute", "prismatic", "revolute"], tool=[0.0, 0.02, 0.05, 0.1, 0.0, 0.0])],
    ids=["ur3", "scara-prismatic"])
def test_chain_axes_match_the_chain(chain):
    q = np.linspace(-0.7, 0.9, chain.n_joints)
    directions, points = np.empty((chain.n_joints, 3)), np.empty((chain.n_joints, 3))
    end = chain_axes(*chain.product_form(), q, directions, points)
    np.testing.assert_allclose(end, chain.fk(q).to_array(), rtol=0, atol=1e-15)
    for got, expected in zip((directions, points), chain.joint_axes(q), strict=True):
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-15)


def test_warm_runs_every_mode():
    from ur3dq.kinematics import dls

    dls.warm()   # compiles or loads every DLS kernel; raises if one no longer compiles
