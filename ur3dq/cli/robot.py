"""`ur3dq robot ...`: what the pendant's buttons do, through the dashboard server — power, brakes, protective-stop
unlock, freedrive, stop. Each runs only when typed (ur3dq never calls them by itself) and is refused, with the
reason, where the controller would refuse it."""
from __future__ import annotations

from typing import TYPE_CHECKING

import click

from ur3dq.cli.app import Settings, cli, emit_json, robot_session
from ur3dq.cli.options import display_options

if TYPE_CHECKING:
    from ur3dq.robot import Robot


def _done(settings: Settings, action: str, robot: Robot, text: str) -> None:
    """Report a finished controller action: one line, or JSON with the robot's modes afterwards."""
    if settings.json:
        status = robot.state()
        emit_json({"action": action, "host": robot.host, "robot_mode": status.robot_mode_name,
                   "safety_mode": status.safety_mode_name})
    else:
        click.echo(text)


@cli.group("robot", short_help="Power, brakes, unlock, freedrive, stop.")
def robot_group() -> None:
    """Power, brakes, protective-stop unlock, freedrive and stop, as at the pendant (dashboard server).

    \b
    Examples:
      ur3dq robot power-on && ur3dq robot brake-release
      ur3dq robot unlock           # after finding why a protective stop came
      ur3dq robot freedrive on     # move the arm by hand; `... off` ends it
      ur3dq robot stop             # decelerate the arm to rest (stopj)
    """


@robot_group.command("power-on", short_help="Power the arm on (brakes held).")
@display_options
@click.pass_obj
def power_on(settings: Settings) -> None:
    """Power the arm on (brakes still held); waits until the controller reports IDLE."""
    with robot_session(settings) as robot:
        robot.power_on()
        _done(settings, "power-on", robot, f"{robot.host}: powered on (brakes held: `ur3dq robot brake-release`).")


@robot_group.command("power-off", short_help="Power the arm off.")
@display_options
@click.pass_obj
def power_off(settings: Settings) -> None:
    """Power the arm off (the brakes engage); waits until the controller reports POWER_OFF."""
    with robot_session(settings) as robot:
        robot.power_off()
        _done(settings, "power-off", robot, f"{robot.host}: powered off.")


@robot_group.command("brake-release", short_help="Release the brakes.")
@display_options
@click.pass_obj
def brake_release(settings: Settings) -> None:
    """Release the brakes of a powered-on arm; waits until the controller reports RUNNING."""
    with robot_session(settings) as robot:
        robot.brake_release()
        _done(settings, "brake-release", robot, f"{robot.host}: brakes released, the arm is RUNNING.")


@robot_group.command("unlock", short_help="Unlock a protective stop.")
@display_options
@click.pass_obj
def unlock(settings: Settings) -> None:
    """Unlock a protective stop (the controller refuses within 5 s of the stop; inspect the cause first)."""
    with robot_session(settings) as robot:
        robot.unlock_protective_stop()
        _done(settings, "unlock", robot, f"{robot.host}: protective stop unlocked.")


@robot_group.command("freedrive", short_help="Freedrive on or off.")
@click.argument("switch", type=click.Choice(["on", "off"]))
@display_options
@click.pass_obj
def freedrive(settings: Settings, switch: str) -> None:
    """Freedrive on (a program on the controller holds it for up to an hour) or off."""
    with robot_session(settings) as robot:
        robot.teach_mode(switch == "on")
        _done(settings, f"freedrive {switch}", robot, f"{robot.host}: freedrive {switch}.")


@robot_group.command("stop", short_help="Stop the arm (stopj) and the program.")
@display_options
@click.pass_obj
def stop(settings: Settings) -> None:
    """Decelerate the arm to rest (stopj) and end the running program."""
    with robot_session(settings) as robot:
        robot.stop()
        _done(settings, "stop", robot, f"{robot.host}: stopj sent.")
