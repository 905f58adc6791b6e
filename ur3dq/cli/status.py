"""`ur3dq status`: the robot's model, software, modes, joints, TCP pose and TCP offset."""
from __future__ import annotations

import click

from ur3dq.cli.app import Settings, cli, emit_json, robot_session
from ur3dq.cli.display import angles_text, key_value_table, pose_label, pose_vector_text
from ur3dq.cli.options import display_options
from ur3dq.units import ANGLE, unit_label


@cli.command()
@display_options
@click.pass_obj
def status(settings: Settings):
    """The robot: model, software, modes, joints, TCP pose and TCP offset.

    \b
    Examples:
      ur3dq --host 192.168.1.10 status
      ur3dq status --deg --json
    """
    with robot_session(settings) as robot:
        state = robot.state()
        version = ".".join(str(part) for part in robot.controller_version)
        if settings.json:
            emit_json({"host": robot.host, "backend": robot.backend_name, "model": robot.model_name,
                       "controller_version": version, "robot_mode": state.robot_mode_name,
                       "safety_mode": state.safety_mode_name, "program_running": state.program_running,
                       "joints": state.joints.tolist(), "tcp_pose": state.tcp_pose.tolist(),
                       "tcp_offset": robot.model.tcp.to_ur_pose().tolist(),
                       "speed_slider": state.target_speed_fraction})
            return
        settings.out.print(key_value_table(f"{robot.model_name} at {robot.host} ({robot.backend_name})", [
            ("controller software", version),
            ("robot mode", state.robot_mode_name),
            ("safety mode", state.safety_mode_name),
            ("program running", "yes" if state.program_running else "no"),
            (f"joints ({unit_label(ANGLE, settings.units)})", angles_text(state.joints, settings.units)),
            (pose_label("TCP pose", settings.units), pose_vector_text(state.tcp_pose, settings.units)),
            (pose_label("TCP offset", settings.units), pose_vector_text(robot.model.tcp.to_ur_pose(),
                                                                         settings.units)),
            ("speed slider", f"{state.target_speed_fraction * 100:.0f} %"),
        ]))
