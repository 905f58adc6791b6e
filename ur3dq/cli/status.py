"""`ur3dq status`: the robot's model, software, modes, program state, joints, TCP pose and offset, and I/O."""
from __future__ import annotations

from typing import TYPE_CHECKING

import click

from ur3dq.cli.app import Settings, cli, emit_json, robot_session
from ur3dq.cli.display import angles_text, key_value_table, pose_label, pose_vector_text
from ur3dq.cli.options import display_options
from ur3dq.errors import RobotError
from ur3dq.robot.io_state import DIGITAL_GROUPS, IOState
from ur3dq.units import ANGLE, unit_label

if TYPE_CHECKING:
    from ur3dq.robot.robot import Robot


@cli.command(short_help="Model, modes, joints, TCP, I/O, program state.")
@display_options
@click.pass_obj
def status(settings: Settings) -> None:
    """The robot: model, software, modes, program state, joints, TCP pose and offset, and the I/O (digital
    standard, configurable and tool inputs and outputs: the pins that are on; the standard analog values).

    \b
    Examples:
      ur3dq --host 192.168.1.10 status
      ur3dq status --deg --json
    """
    with robot_session(settings) as robot:
        state = robot.state()
        io = robot.io_state()
        program = _program_state(robot, io)
        version = ".".join(str(part) for part in robot.controller_version)
        if settings.json:
            emit_json({"host": robot.host, "backend": robot.backend_name, "model": robot.model_name,
                       "controller_version": version, "robot_mode": state.robot_mode_name,
                       "safety_mode": state.safety_mode_name, "program_running": state.program_running,
                       "program_state": program, "joints": state.joints.tolist(), "tcp_pose": state.tcp_pose.tolist(),
                       "tcp_offset": robot.model.tcp.to_ur_pose().tolist(),
                       "speed_slider": state.target_speed_fraction, "io": io.to_dict()})
            return
        units = settings.units
        settings.out.print(key_value_table(f"{robot.model_name} at {robot.host} ({robot.backend_name})", [
            ("controller software", version),
            ("robot / safety mode", f"{state.robot_mode_name} / {state.safety_mode_name}"),
            ("program", program),
            (f"joints ({unit_label(ANGLE, units)})", angles_text(state.joints, units)),
            (pose_label("TCP pose", units), pose_vector_text(state.tcp_pose, units)),
            (pose_label("TCP offset", units), pose_vector_text(robot.model.tcp.to_ur_pose(), units)),
            ("speed slider", f"{state.target_speed_fraction * 100:.0f} %"),
            ("digital in (on)", _pins_on(io, inputs=True)),
            ("digital out (on)", _pins_on(io, inputs=False)),
            ("analog in / out", " ".join(f"{v:.3f}" for v in io.analog_in) + " / "
             + " ".join(f"{v:.3f}" for v in io.analog_out)),
        ]))


def _pins_on(io: IOState, inputs: bool) -> str:
    """The pins that are on, per group: 'standard 2 5; tool 0' (or 'none')."""
    groups = [f"{name} {' '.join(str(pin) for pin, on in enumerate(io.pins(name, inputs)) if on)}"
              for name, _, _ in DIGITAL_GROUPS if any(io.pins(name, inputs))]
    return "; ".join(groups) or "none"


def _program_state(robot: Robot, io: IOState) -> str:
    """The dashboard's program state ('PLAYING ur3dq_program'), else the RTDE runtime state."""
    try:
        return robot.program_state()
    except RobotError:
        return io.runtime_state_name
