"""`ur3dq fk` and `ur3dq ik`: the kinematics core from the command line, no robot needed."""
from __future__ import annotations

import math

import click
import numpy as np

from ur3dq.cli.app import Settings, cli, emit_json
from ur3dq.cli.display import (
    NARROW_WIDTH, Column, angles_text, coefficients_text, distance_text, joint_solutions_table, key_value_table, pose_vector_text,
)
from ur3dq.cli.options import NUMBERS_CONTEXT, display_options, ur_pose_from_input
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.replay import nearest_variant
from ur3dq.robot import motion

DEFAULT_MODEL = "ur3"


def model_for(settings: Settings, fallback: str | None = None):
    """The kinematic model the options name (else `fallback`, else the UR3)."""
    return robot_model(settings.model or fallback or DEFAULT_MODEL)


def joints_from_input(values, deg: bool, name: str = "joints") -> np.ndarray:
    """Six joint angles typed by the user (degrees when `deg`) as radians; ValueError naming `name`."""
    if len(values) != 6:
        raise ValueError(f"{name}: expected 6 joint angles, got {len(values)}")
    q = np.radians(values) if deg else np.asarray(values, dtype=float)
    if not np.all(np.isfinite(q)):
        raise ValueError(f"{name}: every joint angle must be finite, got {list(values)}")
    return q


def joints_in_limits(model, q: np.ndarray, deg: bool, name: str = "joints") -> np.ndarray:
    """`q` if inside `model`'s joint limits, else ValueError naming the joint (with a --deg hint when the values
    were read as radians: `fk 0 -90 0 -90 0 0` is almost always meant in degrees)."""
    outside = (q < model.joint_lower) | (q > model.joint_upper)
    if outside.any():
        i = int(np.argmax(outside))
        hint = "" if deg else "; did you mean --deg?"
        shown = f"{math.degrees(q[i]):g}°" if deg else f"{q[i]:g} rad"
        raise ValueError(f"{name}: joint {i + 1} = {shown} is outside the {model.name}'s limits "
                         f"[{model.joint_lower[i]:g}, {model.joint_upper[i]:g}] rad{hint}")
    return q


def pose_from_input(values, deg: bool) -> DualQuaternion:
    """The target of `ik`: 6 numbers are a UR pose vector, 8 are dual-quaternion coefficients [r | d]."""
    if len(values) == 8:
        return DualQuaternion.from_array(values)
    if len(values) == 6:
        return DualQuaternion.from_ur_pose(ur_pose_from_input(values, deg))
    raise ValueError(f"pose: give 6 numbers (x y z rx ry rz) or 8 (dual-quaternion coefficients), got {len(values)}")


def pose_summary(pose: DualQuaternion) -> dict:
    """The JSON description of a pose: UR pose vector, dual-quaternion coefficients, thesis line (SI units)."""
    return {"ur_pose": pose.to_ur_pose().tolist(), "dual_quaternion": pose.to_array().tolist(),
            "thesis_line": pose.to_thesis_line()}


@cli.command(context_settings=NUMBERS_CONTEXT)
@click.argument("joints", nargs=-1, type=float, metavar="J1 J2 J3 J4 J5 J6")
@click.option("--tcp", nargs=6, type=float, metavar="X Y Z RX RY RZ",
              help="TCP offset in the flange frame (metres, rotation vector; degrees with --deg).")
@display_options
@click.pass_obj
def fk(settings: Settings, joints, tcp):
    """Forward kinematics: the TCP pose at joint angles J1..J6 (base, shoulder, elbow, wrist 1-3).

    \b
    Examples:
      ur3dq fk 0 -1.5708 0 -1.5708 0 0
      ur3dq fk 0 -90 0 -90 0 0 --deg
      ur3dq --model ur5e fk 0 -90 90 -90 -90 0 --deg --tcp 0 0 0.15 0 0 0 --json
    """
    model = model_for(settings)
    q = joints_in_limits(model, joints_from_input(joints, settings.deg), settings.deg)
    if tcp:
        model = model.with_tcp(ur_pose_from_input(tcp, settings.deg, "--tcp"))
    pose = model.fk(q)
    if settings.json:
        emit_json({"model": model.name, "joints": q.tolist(), "tcp_offset": model.tcp.to_ur_pose().tolist(),
                   **pose_summary(pose)})
        return
    settings.out.print(key_value_table(f"Forward kinematics of the {model.name}", [
        ("joints", angles_text(q, settings.deg)),
        ("TCP offset", pose_vector_text(model.tcp.to_ur_pose(), settings.deg)),
        ("TCP pose", pose_vector_text(pose.to_ur_pose(), settings.deg)),
        ("dual quaternion", coefficients_text(pose.to_array())),
        ("thesis line", pose.to_thesis_line()),
    ]))


@cli.command(context_settings=NUMBERS_CONTEXT)
@click.argument("values", nargs=-1, type=float, metavar="[X Y Z RX RY RZ | RW RX RY RZ DW DX DY DZ]")
@click.option("--pose", "pose_name", metavar="NAME", help="Solve a pose of the store (with its TCP offset).")
@click.option("--tcp", nargs=6, type=float, metavar="X Y Z RX RY RZ",
              help="TCP offset in the flange frame (metres, rotation vector; degrees with --deg).")
@click.option("--near", nargs=6, type=float, metavar="J1 .. J6",
              help="Mark the solution `ik` would pick: the closest to these joints (±2π variants in limits).")
@display_options
@click.pass_obj
def ik(settings: Settings, values, pose_name, tcp, near):
    """Inverse kinematics: every joint solution of a TCP pose, each checked by forward kinematics.

    The pose is a UR pose vector (6 numbers), dual-quaternion coefficients (8 numbers) or --pose NAME.
    Solutions are canonical in (-180°, 180°]; with --near (or a stored pose's recorded joints) the table
    also shows each solution's largest joint travel from there and marks the one a replay would choose.

    \b
    Examples:
      ur3dq ik 0.3 0.1 0.2 0 3.14159 0
      ur3dq ik 0.3 0.1 0.2 0 180 0 --deg --near 0 -90 90 -90 -90 0
      ur3dq ik --pose pick --json
    """
    model = model_for(settings)
    reference = joints_in_limits(model, joints_from_input(near, settings.deg, "--near"), settings.deg, "--near") \
        if near else None
    if pose_name:
        if values:
            raise ValueError("give either pose numbers or --pose NAME, not both")
        stored = settings.store.get(pose_name)
        model = model_for(settings, stored.robot_model).with_tcp(stored.tcp_offset)
        target = stored.dq
        if reference is None and stored.joints is not None:
            reference = np.asarray(stored.joints)
    else:
        target = pose_from_input(values, settings.deg)
    if tcp:
        model = model.with_tcp(ur_pose_from_input(tcp, settings.deg, "--tcp"))
    solutions = model.ik_all(target)
    errors = [model.fk(q).distance(target) for q in solutions]
    chosen = model.ik(target, reference) if reference is not None else None
    if settings.json:
        emit_json({"model": model.name, "tcp_offset": model.tcp.to_ur_pose().tolist(), **pose_summary(target),
                   "solutions": [q.tolist() for q in solutions],
                   "fk_errors": [{"metres": m, "radians": r} for m, r in errors],
                   "reference": None if reference is None else reference.tolist(),
                   "chosen": None if chosen is None else chosen.tolist()})
        return
    extra = [(Column("FK error", justify="right", drop_order=1), [distance_text(m, r) for m, r in errors])]
    sent = solutions
    if reference is not None:
        # the travel of what would really be sent: each solution's ±2π variant nearest the reference
        sent = [nearest_variant(model, [q], reference) if np.all(np.isfinite(q)) else q for q in solutions]
        travels = [motion.leading_travel(reference, q) for q in sent]
        extra.append((Column("travel from ref", narrow_header="travel", justify="right", drop_order=2),
                      [f"{math.degrees(t):.1f}°" if settings.deg else f"{t:.4f}" for t in travels]))
        extra.append((Column("chosen", narrow_header="◀"), ["◀" if chosen is not None and
                                                            np.allclose(q, chosen, atol=1e-9) else "" for q in sent]))
    settings.out.print(joint_solutions_table(
        f"{len(solutions)} IK solutions on the {model.name} for" + (" " if settings.out.width >= NARROW_WIDTH else "\n")
        + pose_vector_text(target.to_ur_pose(), settings.deg),
        sent if reference is not None else solutions, settings.deg, extra, settings.out.width))
    if chosen is not None:
        settings.out.print(f"Closest to the reference (◀, what a replay moves to):\n  {angles_text(chosen, settings.deg)}")
