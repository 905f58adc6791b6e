"""`ur3dq ik`: inverse kinematics from the command line, no robot needed."""
from __future__ import annotations

import click
import numpy as np

from ur3dq.cli.app import Settings, cli, emit_json, solving_poses
from ur3dq.cli.display import (
    NARROW_WIDTH,
    Column,
    angles_text,
    distance_text,
    joint_solutions_table,
    pose_summary,
    pose_vector_text,
)
from ur3dq.cli.options import (
    NUMBERS_CONTEXT,
    Quantity,
    Typed,
    TypedValue,
    display_options,
    joints_from_input,
    joints_in_limits,
    model_for,
    pose_from_input,
    pose_vector_type,
    ur_pose_from_input,
)
from ur3dq.replay import nearest_variant
from ur3dq.robot import motion
from ur3dq.units import ANGLE, LENGTH, to_display


@cli.command(context_settings=NUMBERS_CONTEXT, short_help="Inverse kinematics: every joint solution.")
@click.argument("values", nargs=-1, type=Typed([LENGTH, ANGLE]), metavar="[X Y Z RX RY RZ | RW .. DZ]")
@click.option("--pose", "pose_name", metavar="NAME", help="Solve a pose of the store (with its TCP offset).")
@click.option("--tcp", type=pose_vector_type(), default=None, metavar="X Y Z RX RY RZ",
              help="TCP offset in the flange frame (e.g. 0 0 150mm 0 0 0; bare: m and rad, or --mm/--deg).")
@click.option("--near", type=click.Tuple([Quantity(ANGLE)] * 6), default=None, metavar="J1 .. J6",
              help="Mark the solution `ik` would pick: the closest to these joints (±2π variants in limits).")
@display_options
@click.pass_obj
def ik(settings: Settings, values: tuple[TypedValue, ...], pose_name: str | None, tcp: tuple[float, ...] | None,
       near: tuple[float, ...] | None) -> None:
    """Inverse kinematics: every joint solution of a TCP pose, each checked by forward kinematics.

    The pose is a UR pose vector (6 numbers: x y z in m, or with units such as 300mm; the rotation vector in rad,
    ° under --deg, or 180deg), dual-quaternion coefficients (8 plain numbers) or --pose NAME.
    Solutions are canonical in (-180°, 180°]; with --near (or a stored pose's recorded joints) the table
    also shows each solution's largest joint travel from there and marks the one a replay would choose.

    \b
    Examples:
      ur3dq ik 0.3 0.1 0.2 0 3.14159 0
      ur3dq ik 0.3 0.1 0.2 0 180 0 --deg --near 0 -90 90 -90 -90 0
      ur3dq ik --pose pick --json
    """
    solving_poses(1)
    model = model_for(settings)
    units = settings.units
    reference = joints_in_limits(model, joints_from_input(near, "--near"), units, "--near") if near else None
    if pose_name:
        if values:
            raise ValueError("give either pose numbers or --pose NAME, not both")
        stored = settings.store.get(pose_name)
        model = model_for(settings, stored.robot_model).with_tcp(stored.tcp_offset)
        target = stored.dq
        if reference is None and stored.joints is not None:
            reference = np.asarray(stored.joints)
    else:
        target = pose_from_input(values)
    if tcp:
        model = model.with_tcp(ur_pose_from_input(tcp, "--tcp"))
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
                      [f"{to_display(t, ANGLE, units):.1f}°" if units.angle == "deg" else f"{t:.4f}"
                       for t in travels]))
        extra.append((Column("chosen", narrow_header="◀"), ["◀" if chosen is not None and
                                                            np.allclose(q, chosen, atol=1e-9) else "" for q in sent]))
    settings.out.print(joint_solutions_table(
        f"{len(solutions)} IK solutions on the {model.name} for" + (" " if settings.out.width >= NARROW_WIDTH else "\n")
        + pose_vector_text(target.to_ur_pose(), units),
        sent if reference is not None else solutions, units, extra, settings.out.width))
    if chosen is not None:
        settings.out.print("Closest to the reference (◀, what a replay moves to):\n  "
                           f"{angles_text(chosen, units)}")
