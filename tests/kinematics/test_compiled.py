"""The compiled kernels as a user meets them: the interpreted Python (NUMBA_DISABLE_JIT=1) agrees with the compiled
code, commands without kinematics never load numba, and the first use compiles once per cache, saying so on
stderr (numba's cache in the package, a per-user directory where the package is read-only, or memory)."""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from ur3dq.kinematics import MODEL_NAMES, robot_model, ur_ik
from ur3dq.kinematics.jit import COMPILE_SECONDS

NOTICE = f"compiling kinematics kernels, once (about {COMPILE_SECONDS} s)…"

#: Solves a sample of poses (nominal UR5e with singular rows, a calibrated UR3 factory table), writes the results to
#: the .npz file named by argv[1].
SAMPLE = """
import math, sys
import numpy as np
sys.path.insert(0, {tests!r})
from calibrated_arms import factory_model
from ur3dq.kinematics import robot_model, ur_ik
rng = np.random.default_rng(4)
q = rng.uniform(-math.pi, math.pi, (40, 6))
q[:8, 4] = [0.0, 1e-12, math.pi, 1e-6, 0.0, -1e-9, math.pi, 1e-3]
q[8:14, 2] = [0.0, 1e-15, math.pi, 1e-8, -1e-7, 0.0]
q[14:18, 1] = 2 * math.pi
out = {{}}
for label, model, rows in (("nominal", robot_model("ur5e"), q), ("calibrated", factory_model("ur3", 21), q[::5])):
    poses = model.fk_batch(rows)
    out[label + "_poses"] = poses
    out[label + "_all"] = ur_ik.ik_all_batch(model, poses)
    out[label + "_nearest"] = ur_ik.ik_batch(model, poses, rows + 0.03)
np.savez(sys.argv[1], **out)
"""


def run_python(code: str, *arguments: str, env: dict | None = None,
               user: int | None = None) -> subprocess.CompletedProcess:
    """``code`` run by this interpreter in a fresh process (as ``user``, a uid, if given)."""
    command = [sys.executable, "-c", code, *arguments]
    if user is not None:
        command = ["setpriv", f"--reuid={user}", f"--regid={user}", "--clear-groups", *command]
    return subprocess.run(command, capture_output=True, text=True, env={**os.environ, **(env or {})}, timeout=600,
                          check=False)


def test_the_interpreted_kernels_agree_with_the_compiled_ones(tmp_path):
    tests = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    for mode, flag in (("interpreted", "1"), ("compiled", "0")):
        result = run_python(SAMPLE.format(tests=tests), str(tmp_path / f"{mode}.npz"), env={"NUMBA_DISABLE_JIT": flag})
        assert result.returncode == 0, result.stderr
    interpreted, compiled = np.load(tmp_path / "interpreted.npz"), np.load(tmp_path / "compiled.npz")
    for key in compiled.files:
        np.testing.assert_array_equal(np.isnan(interpreted[key]), np.isnan(compiled[key]), err_msg=key)
        np.testing.assert_allclose(interpreted[key], compiled[key], rtol=0, atol=1e-12, equal_nan=True, err_msg=key)
    # The interpreted solutions are the oracle's too (ur-analytic-ik, on the regular rows).
    oracle = pytest.importorskip("ur_analytic_ik").ur5e
    model = robot_model("ur5e")
    for _pose, rows in zip(interpreted["nominal_poses"][18:], interpreted["nominal_all"][18:], strict=False):
        ours = rows[np.isfinite(rows[:, 0])]
        theirs = np.array(oracle.inverse_kinematics(model.fk(ours[0]).to_matrix())).reshape(-1, 6)
        assert len(ours) == len(theirs)
        assert np.max(np.min(np.max(np.abs(ur_ik.wrap_angle(ours[:, None] - theirs[None])), axis=-1), axis=1)) < 1e-9


#: Runs a CLI command in this process and reports whether numba was imported.
CLI = """
import json, sys
from ur3dq.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(json.dumps("numba" in sys.modules))
"""


@pytest.mark.parametrize("command", [["--help"], ["poses", "list"], ["poses", "list", "--json"], ["robot", "--help"],
                                     ["status", "--help"]])
def test_commands_without_kinematics_never_import_numba(command, tmp_path):
    result = run_python(CLI, "--store", str(tmp_path / "poses.json"), *command)
    assert result.stdout.strip().splitlines()[-1] == "false", (result.stdout, result.stderr)


#: Runs a CLI command in this process and prints its JSON answer's solutions and whether numba was imported.
ONE_POSE = """
import contextlib, io, json, sys
from ur3dq.cli import main
out = io.StringIO()
with contextlib.redirect_stdout(out):
    try:
        main(sys.argv[1:])
    except SystemExit:
        pass
print(json.dumps({"answer": json.loads(out.getvalue()), "numba": "numba" in sys.modules}))
"""


@pytest.mark.parametrize("command", [["fk", "0.1", "-1.2", "1", "-1.4", "-1.57", "0.2", "--json"],
                                     ["ik", "0.3", "0.1", "0.2", "0", "3.1", "0", "--json"]])
def test_one_pose_commands_run_the_kernels_as_python_in_their_own_process(command, tmp_path):
    """`ur3dq fk` and `ur3dq ik` solve one pose: the kernels run interpreted (no numba loaded), with the answer the
    compiled kernels give; NUMBA_DISABLE_JIT=0 keeps them compiled."""
    store = ["--store", str(tmp_path / "poses.json")]
    interpreted = json.loads(run_python(ONE_POSE, *store, *command).stdout.splitlines()[-1])
    compiled = json.loads(run_python(ONE_POSE, *store, *command, env={"NUMBA_DISABLE_JIT": "0"}).stdout
                          .splitlines()[-1])
    assert (interpreted["numba"], compiled["numba"]) == (False, True)
    key = "solutions" if command[0] == "ik" else "ur_pose"
    assert len(interpreted["answer"][key]) == len(compiled["answer"][key]) > 0
    np.testing.assert_allclose(interpreted["answer"][key], compiled["answer"][key], rtol=0, atol=1e-12)


def test_the_kinematics_import_numba_only_when_a_kernel_runs():
    code = ("import sys\nfrom ur3dq.kinematics import robot_model, ur_ik\nfrom ur3dq import pathcheck, replay\n"
            "model = robot_model('ur3', dh_deltas={'a': [1e-4] * 6})\nbefore = 'numba' in sys.modules\n"
            "model.ik_all(robot_model('ur3').fk([0.1] * 6))\nprint(before, 'numba' in sys.modules)")
    assert run_python(code).stdout.split() == ["False", "True"]


#: Solves one pose twice in a fresh process, printing the answer.
SOLVE = """
import json
from ur3dq.kinematics import robot_model
model = robot_model("ur10e")
pose = model.fk([0.1, -1.2, 1.3, -0.4, 0.9, 0.2])
model.ik(pose, [0.1, -1.2, 1.3, -0.4, 0.9, 0.2])
print(json.dumps(model.ik(pose, [0.1, -1.2, 1.3, -0.4, 0.9, 0.2]).tolist()))
"""


AS_ANOTHER_USER = os.geteuid() == 0 and shutil.which("setpriv") is not None
NOBODY = 65534


@pytest.fixture
def user_home():
    """A home directory under /tmp for user nobody (who cannot write the package) when this runs as root, else a
    temporary directory of this user's; (home, user or None)."""
    home = Path(tempfile.mkdtemp(prefix="ur3dq-user-cache-"))
    if AS_ANOTHER_USER:
        os.chown(home, NOBODY, NOBODY)
    yield home, NOBODY if AS_ANOTHER_USER else None
    shutil.rmtree(home)


@pytest.mark.timeout(1200)   # a fresh compilation: half a minute of CPU, minutes on a loaded machine
def test_the_first_use_compiles_once_per_cache_and_says_so(user_home):
    """As a user who cannot write the package (nobody, when the tests run as root), the kernels compile once into
    numba's per-user cache directory, with the notice once (though they run several times); the next process loads
    them, silently. As any other user: the same with the cache directory named by NUMBA_CACHE_DIR."""
    home, user = user_home
    env = {"XDG_CACHE_HOME": str(home), "HOME": str(home), "NUMBA_CACHE_DIR": "" if user else str(home / "cache")}
    first, second = run_python(SOLVE, env=env, user=user), run_python(SOLVE, env=env, user=user)
    assert first.returncode == 0 and second.returncode == 0, first.stderr + second.stderr
    assert first.stderr.count(NOTICE) == 1, first.stderr
    assert NOTICE not in second.stderr, second.stderr
    assert any(home.rglob("*.nbi"))   # the cache directory holds the kernels
    assert json.loads(first.stdout) == json.loads(second.stdout)


@pytest.mark.skipif(not AS_ANOTHER_USER, reason="needs root to run as another user")
@pytest.mark.timeout(1200)   # a fresh compilation
def test_with_nowhere_to_write_the_kernels_compile_in_memory_and_say_so():
    """A user who can write neither the package nor a cache directory: the kernels compile in memory, so every
    process says so (one is enough to see it), with the answer a cached compilation gives."""
    env = {"XDG_CACHE_HOME": "/proc/none", "HOME": "/proc/none", "NUMBA_CACHE_DIR": ""}
    alone = run_python(SOLVE, env=env, user=NOBODY)
    assert alone.returncode == 0 and alone.stderr.count(NOTICE) == 1, alone.stderr
    assert json.loads(alone.stdout) == json.loads(run_python(SOLVE).stdout)


#: Prints how many kernels were compiled (numba's cache misses: not found in the cache nor compiled by the warm-up)
#: by batches of a block and a half, whose last block is shorter than the others.
BLOCK_AND_A_HALF = """
import numpy as np
from ur3dq.kinematics import robot_model, ur_ik

def compiled():
    return sum(sum(kernel.stats.cache_misses.values()) for module in ur_ik.kernels()
               for kernel in vars(module).values() if hasattr(kernel, "stats"))

model = robot_model("ur5e")
before = compiled()   # the warm-up's compilations, where the cache was cold
q = np.random.default_rng(1).uniform(-3.0, 3.0, (6100, 6))
poses = model.fk_batch(q)
ur_ik.ik_batch(model, poses, q)
ur_ik.ik_all_batch(model, poses)
print(compiled() - before)
"""


def test_batches_of_any_length_run_the_warmed_kernels_without_compiling_more():
    """A batch whose last block is shorter than the others hands the kernels the same contiguous arrays the warm-up
    compiled them for: nothing compiles at run time (silently, after the one notice)."""
    result = run_python(BLOCK_AND_A_HALF, env={"NUMBA_DISABLE_JIT": "0"})
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "0", result.stdout


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_fk_batch_takes_every_sine_from_the_vectorised_tangents(name):
    """fk_batch (numpy's tan of half angles, then the closed form) and fk (libm's sin and cos) agree to 1e-14, also
    where the half-angle tangent blows up (angles at ±π, ±3π)."""
    model = robot_model(name)
    q = np.random.default_rng(1).uniform(-7.0, 7.0, (300, 6))
    q[:20] = np.random.default_rng(2).choice([math.pi, -math.pi, 3 * math.pi, 0.0, 2 * math.pi], (20, 6))
    batch = model.fk_batch(q)
    for row, joints in zip(batch, q, strict=False):
        assert np.max(np.abs(row * np.sign(row @ model.fk(joints).to_array()) - model.fk(joints).to_array())) < 1e-14


def test_every_kernel_module_warms_once_with_the_notice(monkeypatch):
    """`--warm` (make test, make demo) reaches the IK's and the DLS's kernels, and each module's first use goes
    through jit.warm_once (the one-line notice where its cache lacks them) once per process."""
    import importlib

    from ur3dq.kinematics import dls, jit

    assert set(jit.KERNEL_MODULES) == {"ur3dq.kinematics.ur_ik", "ur3dq.kinematics.dls"}
    for name in jit.KERNEL_MODULES:
        assert callable(importlib.import_module(name).kernels)
    labels = []
    monkeypatch.setattr(jit, "warm_once", lambda label, sources, warm: labels.append((label, sources)))
    monkeypatch.setattr(dls, "_warmed", False)
    chain = robot_model("ur3").chain
    dls.dls_ik(chain, chain.fk(np.zeros(6)), np.full(6, 0.1), mode="improved")
    dls.pose_jacobian(chain, np.zeros(6))
    assert [label for label, _ in labels] == ["dls"]
    assert {Path(source).name for source in labels[0][1]} >= {"dls_kernels.py", "chain_kernels.py", "chain.py",
                                                              "dualquat.py"}


@pytest.mark.timeout(1200)   # `--warm` compiles where the cache lacks the kernels (make test warms it first)
def test_a_warm_cache_is_found_whatever_module_a_process_imports_first():
    """The cache's marker is looked up by the kernels' sources, not by the order their modules were imported: a
    process that imports a kernel module before ur_ik loads the cache `--warm` left, silently."""
    warm = subprocess.run([sys.executable, "-m", "ur3dq.kinematics.jit", "--warm"], capture_output=True, text=True,
                          check=False, timeout=1200)
    assert warm.returncode == 0, warm.stderr
    for first in ("ur3dq.kinematics.ur_ik.nearest", "ur3dq.kinematics.fk", "ur3dq.kinematics.dls_kernels"):
        result = run_python(f"import {first}\nfrom ur3dq.kinematics import dls, ur_ik\nur_ik.kernels()\n"
                            "dls.kernels()")
        assert result.returncode == 0 and NOTICE not in result.stderr, (first, result.stderr)
