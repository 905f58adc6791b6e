"""`ur3dq fk`: forward kinematics from the command line, no robot needed."""
from __future__ import annotations

import click

from ur3dq.cli.app import Settings, cli, emit_json, solving_poses
from ur3dq.cli.display import (
    angles_text,
    coefficients_text,
    key_value_table,
    pose_label,
    pose_summary,
    pose_vector_text,
)
from ur3dq.cli.options import (
    NUMBERS_CONTEXT,
    Quantity,
    display_options,
    joints_from_input,
    joints_in_limits,
    model_for,
    pose_vector_type,
    ur_pose_from_input,
)
from ur3dq.units import ANGLE, unit_label


@cli.command(context_settings=NUMBERS_CONTEXT, short_help="Forward kinematics: TCP pose of 6 joints.")
@click.argument("joints", nargs=-1, type=Quantity(ANGLE), metavar="J1 J2 J3 J4 J5 J6")
@click.option("--tcp", type=pose_vector_type(), default=None, metavar="X Y Z RX RY RZ",
              help="TCP offset in the flange frame (e.g. 0 0 150mm 0 0 0; bare: m and rad, or --mm/--deg).")
@display_options
@click.pass_obj
def fk(settings: Settings, joints: tuple[float, ...], tcp: tuple[float, ...] | None) -> None:
    """Forward kinematics: the TCP pose at joint angles J1..J6 (base, shoulder, elbow, wrist 1-3).

    An angle is a bare number (radians, degrees under --deg) or says its unit: 90deg, 1.57rad.

    \b
    Examples:
      ur3dq fk 0 -1.5708 0 -1.5708 0 0
      ur3dq fk 0 -90 0 -90 0 0 --deg
      ur3dq fk 0 -90deg 0 -90deg 0 0
      ur3dq --model ur5e fk 0 -90 90 -90 -90 0 --deg --tcp 0 0 0.15 0 0 0 --json
    """
    solving_poses(1)
    model = model_for(settings)
    units = settings.units
    q = joints_in_limits(model, joints_from_input(joints), units)
    if tcp:
        model = model.with_tcp(ur_pose_from_input(tcp, "--tcp"))
    pose = model.fk(q)
    if settings.json:
        emit_json({"model": model.name, "joints": q.tolist(), "tcp_offset": model.tcp.to_ur_pose().tolist(),
                   **pose_summary(pose)})
        return
    settings.out.print(key_value_table(f"Forward kinematics of the {model.name}", [
        (f"joints ({unit_label(ANGLE, units)})", angles_text(q, units)),
        (pose_label("TCP offset", units), pose_vector_text(model.tcp.to_ur_pose(), units)),
        (pose_label("TCP pose", units), pose_vector_text(pose.to_ur_pose(), units)),
        ("dual quaternion", coefficients_text(pose.to_array())),
        ("thesis line", pose.to_thesis_line()),
    ]))
