"""`ur3dq robot ...`: what the pendant's buttons do, through the dashboard server — power, brakes, protective-stop
unlock, freedrive, stop. Each runs only when typed (ur3dq never calls them by itself) and is refused, with the
reason, where the controller would refuse it."""
from __future__ import annotations

import select
import sys
from typing import TYPE_CHECKING

import click

from ur3dq.cli.app import Settings, cli, emit_json, robot_session
from ur3dq.cli.options import display_options
from ur3dq.errors import RobotError, add_note
from ur3dq.robot import interrupts

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
      ur3dq robot freedrive on     # move the arm by hand until Enter
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
    """Unlock a protective stop (the controller refuses within 5 s of the stop; inspect the cause first).

    Says so when there is no protective stop (exit 0); an emergency stop is not unlocked here: release the e-stop
    button, then `ur3dq robot power-on` (exit 6)."""
    with robot_session(settings) as robot:
        if robot.unlock_protective_stop():
            _done(settings, "unlock", robot, f"{robot.host}: protective stop unlocked.")
        else:
            _done(settings, "nothing to unlock", robot, f"{robot.host}: no protective stop to unlock.")


@robot_group.command("freedrive", short_help="Freedrive on (held while the command runs) or off.")
@click.argument("switch", type=click.Choice(["on", "off"]))
@display_options
@click.pass_obj
def freedrive(settings: Settings, switch: str) -> None:
    """Freedrive on, held while this command runs; or off.

    `on` switches freedrive on and stays in the foreground holding it until Enter, Ctrl-C or SIGTERM, or
    `ur3dq robot freedrive off` from another shell, then ends it (exit 0; 130/143 after Ctrl-C/SIGTERM): freedrive
    never outlives the command (its program stops within 0.1 s if ur3dq dies, and after an hour at the most). An
    end of stdin (a script's `... on &`) is not Enter: it holds on. `off` ends freedrive, whoever started it.
    """
    with robot_session(settings) as robot:
        if switch == "off":
            robot.teach_mode(False)
            _done(settings, "freedrive off", robot, f"{robot.host}: freedrive off.")
            return
        robot.teach_mode(True)
        click.echo(f"{robot.host}: freedrive on: move the arm by hand. Enter, Ctrl-C or `ur3dq robot freedrive off` "
                   "from another shell ends it.", err=True)
        ended_by = _hold_freedrive(robot)
        text = {"enter": "freedrive off (Enter).",
                "elsewhere": "freedrive ended by something else (`ur3dq robot freedrive off`, the pendant, another "
                             "program, or its hour ran out)."}[ended_by]
        _done(settings, f"freedrive on, ended by {ended_by}", robot, f"{robot.host}: {text}")


FREEDRIVE_POLL = 0.2   # s between two looks at stdin and at the controller while freedrive is held


def _hold_freedrive(robot: Robot) -> str:
    """Hold freedrive (the session and its heartbeat stay open) until Enter on stdin ('enter', freedrive then
    switched off) or the controller leaves freedrive by itself ('elsewhere'). Ctrl-C or SIGTERM switch it off and
    leave with their KeyboardInterrupt; so does any error."""
    reading = True
    try:
        while robot.freedrive_active():
            if not reading:
                interrupts.poll(FREEDRIVE_POLL)
                continue
            try:
                ready = select.select([sys.stdin], [], [], FREEDRIVE_POLL)[0]
                line = sys.stdin.readline() if ready else None
            except (OSError, ValueError):   # no stdin at all: hold until a signal or `off`
                ready, line = [], ""
            if line:
                robot.teach_mode(False)
                return "enter"
            reading = line is None
        return "elsewhere"
    except BaseException as error:
        try:
            robot.teach_mode(False)
        except RobotError as failure:
            add_note(error, f"(switching freedrive off also failed: {failure}; it ends within 0.1 s of this exit)")
        else:
            add_note(error, "(freedrive off)")
        raise


@robot_group.command("stop", short_help="Stop the arm (stopj) and the program.")
@display_options
@click.pass_obj
def stop(settings: Settings) -> None:
    """Decelerate the arm to rest (stopj) and end the running program."""
    with robot_session(settings) as robot:
        robot.stop()
        _done(settings, "stop", robot, f"{robot.host}: stopj sent.")
