"""`ur3dq fk`: forward kinematics from the command line, no robot needed."""
from __future__ import annotations

import click

from ur3dq.cli.app import Settings, cli, emit_json
from ur3dq.cli.display import angles_text, coefficients_text, key_value_table, pose_summary, pose_vector_text
from ur3dq.cli.options import (
    NUMBERS_CONTEXT,
    display_options,
    joints_from_input,
    joints_in_limits,
    model_for,
    ur_pose_from_input,
)


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
