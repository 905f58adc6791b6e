"""A failed path check read under --deg and --mm, in real subprocesses: every number of a problem (the TCP, a joint
past its limit, a singularity, a joint speed, a clearance) in the units the user chose, each value worked out here
from the SI figures of `check --json`; the JSON itself the same whatever the options."""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.steps import Motion, Waypoint
from ur3dq.store import PoseStore

UR3DQ = str(Path(sys.executable).with_name("ur3dq"))
UR5 = robot_model("ur5")
# Tool down, wrist 3 at 6.0 rad: 0.28 rad from its +2π limit.
LOW = np.array([0.0, -1.9, 1.9, -1.5708, -1.5708, 6.0])
# θ5 = 0.015 rad: a line along the base-joint direction at constant orientation passes 0.86° from the wrist
# singularity (θ1 changes through the line, θ5 = acos(z1·z6) comes down to about θ5 of this pose).
NEAR_SINGULAR = np.array([0.0, -1.2, 1.5, -1.8, 0.015, 0.5])
TWIST = 0.5   # rad the 'twist' line turns the tool about its axis: wrist 3 goes 6.0 → 6.5 rad, past +2π


def program(directory):
    """A cell program that fails a joint limit ('twist'), the wrist singularity and a joint speed ('across') and a
    clearance ('low', to the keep-out box "fixture" under the tool), with its cell file."""
    z1 = np.array([0.0, -1.0, 0.0])   # the base joint's direction at θ1 = 0

    def shifted(offset):
        return DualQuaternion.from_translation(offset * z1) * UR5.fk(NEAR_SINGULAR)

    start, end = (UR5.ik(shifted(offset).to_array(), NEAR_SINGULAR) for offset in (-0.06, 0.06))
    twisted = LOW.copy()
    twisted[5] = 6.0 + TWIST - 2 * math.pi     # the recorded target joints: the solution inside the limits
    moves = [("low", UR5.fk(LOW), LOW, "joint"), ("twist", UR5.fk(LOW) * DualQuaternion.from_axis_angle(
        [0, 0, 1], TWIST), twisted, "linear"), ("start", UR5.fk(start), start, "joint"),
        ("across", UR5.fk(end), end, "linear")]
    steps = [Waypoint(name, Pose.from_dual_quaternion(name, pose, "ur5", joints=tuple(map(float, joints))),
                      Motion(move, speed=0.1 if move == "linear" else None)) for name, pose, joints, move in moves]
    PoseStore(directory / "poses.json").update_program(lambda old: (steps, None))
    tcp = UR5.fk(LOW).translation
    (directory / "cell.json").write_text(json.dumps({"margin": 0.005, "boxes": [
        {"name": "fixture", "min": list(tcp + [-0.05, -0.05, -0.2]), "max": list(tcp + [0.05, 0.05, -0.02])}]}))


@pytest.fixture(scope="module")
def checked(tmp_path_factory):
    """{options: (exit code, stdout + stderr)} of `ur3dq OPTIONS check --cell cell.json --joints` on the program,
    and "json": the SI document of `check --json`."""
    directory = tmp_path_factory.mktemp("check-units")
    program(directory)
    environment = {k: v for k, v in os.environ.items() if not k.startswith("UR3DQ_")}
    environment.update(UR3DQ_STATE_DIR=str(directory / "state"), UR3DQ_STORE=str(directory / "poses.json"),
                       COLUMNS="200")
    runs = {}
    for options in ((), ("--deg",), ("--mm",), ("--json",), ("--deg", "--mm", "--json")):
        result = subprocess.run([UR3DQ, *options, "check", "--cell", "cell.json", "--joints"], cwd=directory,
                                env=environment, capture_output=True, text=True, timeout=120)
        runs[options] = (result.returncode, result.stdout + result.stderr if "--json" not in options else
                         json.loads(result.stdout))
    return runs


def si(checked):
    """(problems by (step, check), steps' margins by name, limits) of the SI run."""
    code, document = checked[("--json",)]
    assert code == 4
    problems = {(p["step"], p["check"]): p for p in document["problems"]}
    return problems, {step["name"]: step["margins"] for step in document["steps"]}, document["limits"]


def test_under_deg_a_joint_past_its_limit_a_singularity_and_a_joint_speed_read_in_degrees(checked):
    code, text = checked[("--deg",)]
    assert code == 4, text
    text = " ".join(text.split())   # lines a terminal would wrap, whole
    _, margins, limits = si(checked)
    lower, upper = (math.degrees(UR5.joint_lower[5]), math.degrees(UR5.joint_upper[5]))
    assert (f"joint 6 (wrist 3) at {math.degrees(6.0 + TWIST):.2f} ° passes its limit [{lower:.2f}, {upper:.2f}] "
            "(margin 0.0 °)") in text
    wrist = math.degrees(math.asin(margins["across"]["wrist"] + limits["wrist"]))
    keep = math.degrees(math.asin(limits["wrist"]))
    assert f"wrist 2 passes {wrist:.1f} ° from 0°/180° (keep ≥ {keep:.1f} °" in text
    top = UR5.max_joint_speed[3]
    needed = (limits["joint_speed"] - margins["across"]["joint_speed"]) * top
    assert f"joint 4 (wrist 1) would need {math.degrees(needed):.0f} °/s at 0.1 m/s, over 1 × its " \
           f"{math.degrees(top):.0f} °/s" in text
    assert "rad" not in text, text


def test_under_mm_the_tcp_a_clearance_and_a_speed_read_in_millimetres(checked):
    code, text = checked[("--mm",)]
    assert code == 4, text
    text = " ".join(text.split())
    problems, margins, limits = si(checked)
    for (step, _), problem in problems.items():
        x, y, z = (1000 * v for v in problem["tcp"])
        assert f"step {step!r} at {problem['fraction']:.0%} of the move (TCP {x:.1f}, {y:.1f}, {z:.1f} mm)" in text
    depth = -1000 * (margins["low"]["cell"] + limits["cell"])
    assert f'wrist 3 capsule {depth:.0f} mm inside keep-out box "fixture" (margin 5 mm)' in text
    ratio = limits["joint_speed"] - margins["across"]["joint_speed"]
    assert f"at 100 mm/s, over 1 × its 3.14 rad/s; lower the step's speed to ≤ {100 / ratio:.1f} mm/s" in text
    assert " m)" not in text and " m/s" not in text


def test_without_options_the_tcp_is_in_metres_and_the_small_values_in_mm_and_degrees(checked):
    code, text = checked[()]
    text = " ".join(text.split())
    problems, margins, limits = si(checked)
    x, y, z = problems[("twist", "joint_limit")]["tcp"]
    assert code == 4 and f"(TCP {x:.4f}, {y:.4f}, {z:.4f} m): joint 6 (wrist 3) at 6.5000 rad passes its limit " \
                         "[-6.2832, 6.2832] (margin 0.000 rad)" in text
    depth = -1000 * (margins["low"]["cell"] + limits["cell"])
    assert f'wrist 3 capsule {depth:.0f} mm inside keep-out box "fixture" (margin 5 mm)' in text
    assert "at 0.1 m/s, over 1 × its 3.14 rad/s" in text


def test_the_json_is_si_and_the_same_whatever_the_units(checked):
    code, document = checked[("--deg", "--mm", "--json")]
    assert code == 4 and document == checked[("--json",)][1]
    limit = next(p for p in document["problems"] if p["check"] == "joint_limit")
    assert "at 6.5000 rad passes its limit" in limit["message"]
    assert all(abs(v) < 2 for p in document["problems"] for v in p["tcp"])   # metres
