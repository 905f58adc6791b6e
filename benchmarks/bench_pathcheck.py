"""Path-check benchmark: ur3dq.pathcheck.check_path against a per-sample loop built on ur-analytic-ik, in one run.

The program: 10 waypoints on a UR5 — one joint move to the first, then 9 linear moves adding up to 1 m of straight
TCP travel (the default resolution: ≤ 1 mm, ≤ 0.5° per sample), with self-collision and a cell of 5 keep-out
boxes plus a floor. Both sides sample the same moves at the same resolution and run the same checks:
  * ur3dq:  check_path (IK of all samples of a move at once with ur_ik.ik_all_batch, checks as numpy arrays);
  * peer:   a Python loop over the samples: ur-analytic-ik's inverse_kinematics_closest(4×4, q_previous) for
            the IK of each sample (C++ via nanobind), then the same checks on that one sample (the same geometry
            kernels called with one sample).
Each side is timed in this process's CPU time (time.process_time), best of --passes interleaved passes.
Goals: check_path ≤ 50 ms for this program, and ≥ 10× faster than the per-sample peer loop; the same program on a
calibrated arm (the factory-style table sim_ursim reports: IK by Newton on the full DH chain) ≤ 50 ms too.
The IK alone (both sides on the same line samples) is printed too: most of the ratio comes from checking all
samples at once, not from the IK.

Run:  .venv/bin/python benchmarks/bench_pathcheck.py [--passes 7]
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np
import ur_analytic_ik

from sim_ursim.calibration import factory_calibration
from sim_ursim.models import robot_model as simulator_model
from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model, robot_model_from_dh, ur_ik
from ur3dq.pathcheck import Margins, PathPlan, PathSegment, cell_from_dict, check_path
from ur3dq.pathcheck.checks import StepChecker
from ur3dq.pathcheck.sampling import line_poses, sample_joint_move

START = np.array([0.3, -1.7, 1.6, -1.5, -1.57, 0.2])
FIRST = np.array([0.0, -1.5, 1.5, -1.57, -1.57, 0.0])
CELL = {"floor": {"z": -0.05}, "margin": 0.01,
        "tool": {"capsule": {"from": [0, 0, 0], "to": [0, 0, 0.08], "radius": 0.03}},
        # a table 4 cm under the tool's lowest point (exact distances along the whole path), 4 fixtures around
        "boxes": [{"name": "table", "min": [-0.8, -0.35, 0.2], "max": [-0.3, 0.25, 0.28]}] +
                 [{"name": f"fixture {i}", "min": [x, y, 0.0], "max": [x + 0.1, y + 0.1, 0.1]}
                  for i, (x, y) in enumerate([(0.6, 0.6), (-0.3, -0.7), (0.5, -0.7), (-0.7, -0.6)])]}


def program(model) -> PathPlan:
    """10 waypoints: a joint move, then 9 linear moves (a zig-zag in a horizontal square) totalling 1 m."""
    pose = model.fk(FIRST)
    offsets = [(0.12, 0, 0), (0, 0.12, 0), (-0.12, 0, 0), (0, -0.1, 0), (0.1, 0, 0.05), (0, 0.12, 0),
               (-0.1, 0, -0.05), (0, -0.12, 0), (0.06, 0.0, 0)]
    scale = 1.0 / sum(math.dist((0, 0, 0), o) for o in offsets)
    segments = [PathSegment("w0", "joint", target_joints=FIRST)]
    for i, offset in enumerate(offsets):
        pose = DualQuaternion.from_translation(np.array(offset) * scale) * pose
        segments.append(PathSegment(f"w{i + 1}", "linear", target_pose=pose.to_array(), speed=0.25))
    return PathPlan(START, segments)


def peer_check(model, plan: PathPlan, cell, margins: Margins, oracle) -> int:
    """The same sampling and checks, one sample at a time, IK by ur-analytic-ik; returns the samples checked."""
    checker = StepChecker(model, cell, margins)
    q = plan.start_joints
    checked = 0
    for segment in plan.segments:
        if segment.move == "joint":
            move = sample_joint_move(model, q, segment.target_joints, margins.tcp_resolution,
                                     margins.joint_resolution)
            fractions, joints = move.fraction, move.joints
        else:
            pose0 = model.fk(q).to_array()
            metres, radians = dqarray.pose_distance(pose0, segment.target_pose)
            count = max(1, math.ceil(metres / margins.tcp_resolution), math.ceil(radians / margins.joint_resolution))
            fractions = np.linspace(0.0, 1.0, count + 1)
            joints = []
            previous = q
            for pose in line_poses(pose0, segment.target_pose, fractions):
                previous = oracle.inverse_kinematics_closest(dqarray.to_matrix(pose), *previous)[0]
                joints.append(previous)
            joints = np.array(joints)
        previous_q = q
        for _fraction, sample in zip(fractions, joints):
            pair = np.vstack((previous_q, sample))
            tcp = dqarray.translation_unchecked(model.fk_batch(pair))
            checker.margins_of(segment, pair, np.array([0.0, 1.0 / len(fractions)]), tcp, np.zeros(2), 1.0)
            previous_q = sample
            checked += 1
        q = joints[-1]
    return checked


def line_sample_poses(model, plan: PathPlan, margins: Margins) -> np.ndarray:
    """(n, 8) the TCP poses of every linear move's samples (for the IK-only measurements)."""
    poses, pose0 = [], model.fk(plan.segments[0].target_joints).to_array()
    for segment in plan.segments[1:]:
        metres, _ = dqarray.pose_distance(pose0, segment.target_pose)
        count = max(1, math.ceil(float(metres) / margins.tcp_resolution))
        poses.append(line_poses(pose0, segment.target_pose, np.linspace(0.0, 1.0, count + 1)))
        pose0 = segment.target_pose
    return np.vstack(poses)


def peer_ik_only(matrices, start, oracle) -> None:
    previous = start
    for matrix in matrices:
        previous = oracle.inverse_kinematics_closest(matrix, *previous)[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--passes", type=int, default=7, help="interleaved passes, best kept (default 7)")
    args = parser.parse_args()
    model = robot_model("ur5")
    oracle = ur_analytic_ik.ur5
    plan, cell, margins = program(model), cell_from_dict(CELL), Margins()
    result = check_path(model, plan, cell, margins)
    assert result.ok, result.summary()
    samples = sum(step.samples for step in result.steps)
    linear = sum(float(np.sum(np.linalg.norm(np.diff(s.tcp, axis=0), axis=1))) for s in result.steps[1:])
    calibrated = calibrated_model(model.name)
    calibrated_plan = program(calibrated)
    assert check_path(calibrated, calibrated_plan, cell, margins).ok
    names = {"ur3dq check_path (vectorised, ik_all_batch)": lambda: check_path(model, plan, cell, margins),
             "peer: per-sample loop, ur-analytic-ik inverse_kinematics_closest": lambda: peer_check(
                 model, plan, cell, margins, oracle),
             "ur3dq check_path, calibrated arm (factory table)": lambda: check_path(
                 calibrated, calibrated_plan, cell, margins)}
    poses = line_sample_poses(model, plan, margins)
    matrices = [dqarray.to_matrix(pose) for pose in poses]
    names.update({"  IK alone, same line samples: ur3dq ur_ik.ik_all_batch": lambda: ur_ik.ik_all_batch(
                      model, poses, q_ref=FIRST),
                  "  IK alone, same line samples: peer loop of ur-analytic-ik inverse_kinematics_closest":
                      lambda: peer_ik_only(matrices, FIRST, oracle)})
    best = dict.fromkeys(names, math.inf)
    for _ in range(args.passes):
        for name, run in names.items():
            start = time.process_time()
            run()
            best[name] = min(best[name], time.process_time() - start)
    print(f"program: 10 waypoints on a {model.name}, {linear:.3f} m of linear moves, {samples} samples, "
          f"{len(cell.boxes)} boxes + floor, self-collision on; CPU time, best of {args.passes}")
    for name, seconds in best.items():
        print(f"  {name}: {seconds * 1e3:.1f} ms")
    ours, peer, calibrated_seconds = list(best.values())[:3]
    print(f"  goal ≤ 50 ms: {ours * 1e3:.1f} ms ({'met' if ours <= 0.050 else 'NOT met'}); "
          f"goal ≥ 10× faster than the peer loop: {peer / ours:.1f}× ({'met' if peer / ours >= 10 else 'NOT met'}); "
          f"calibrated arm ≤ 50 ms: {calibrated_seconds * 1e3:.1f} ms "
          f"({'met' if calibrated_seconds <= 0.050 else 'NOT met'})")


def calibrated_model(name: str):
    """The ur3dq model of a controller reporting sim_ursim's factory-style table for arm ``name``."""
    table = simulator_model(name, calibration=factory_calibration(simulator_model(name).dh))
    return robot_model_from_dh(name, table.a, table.d, table.alpha, table.theta)


if __name__ == "__main__":
    main()
