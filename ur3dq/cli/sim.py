"""`ur3dq sim start/stop/status`: the embedded simulator in the background."""
from __future__ import annotations

import click

from ur3dq.cli.app import Settings, cli, emit_json
from ur3dq.cli.background_simulator import read_state, start_simulator, state_directory, stop_simulator
from ur3dq.cli.options import display_options


@cli.group(short_help="The embedded simulator: start, stop, status.")
def sim() -> None:
    """The embedded simulator (sim_ursim) in the background, for trying ur3dq without a robot.

    While it runs, robot commands use it when no --host / UR3DQ_HOST is given.

    \b
    Examples:
      ur3dq sim start           # a UR3 (CB3 3.15) on a free loopback address
      ur3dq --model ur5e sim start --address 127.0.0.3
      ur3dq sim status
      ur3dq sim stop
    """


@sim.command("start", short_help="Start the simulator in the background.")
@click.option("--address", help="Loopback address to serve on (127.x.y.z; default: a free one).")
@click.option("--version", "software_version", help="Controller software, e.g. 3.15.8 or 5.11.1.")
@click.option("--powered-off", is_flag=True,
              help="Leave the arm powered off with brakes held, as a real controller boots (default: ready to move).")
@display_options
@click.pass_obj
def sim_start(settings: Settings, address: str | None, software_version: str | None, powered_off: bool) -> None:
    """Start the simulator in the background, ready to move.

    Start the simulator in the background: the arm at zero joints, powered on with its brakes released
    (what an operator does at the pendant) unless --powered-off."""
    state = start_simulator(settings.model or "ur3", address, software_version)
    if not powered_off:
        from ur3dq.robot import connect

        try:
            with connect(state["host"]) as robot:
                robot.power_on()
                robot.brake_release()
        except BaseException:
            stop_simulator()  # a half-started simulator would only confuse the next command
            raise
    if settings.json:
        emit_json(state)
    else:
        click.echo(f"Simulated {state['model']} serving on {state['host']} (pid {state['pid']})\n  log {state['log']}")
        if state.get("address_changed_from"):
            click.echo(f"Note: {state['address_changed_from']} was taken, so the address changed: update an "
                       "exported UR3DQ_HOST.")
        click.echo("ur3dq commands use it when no --host is given; it keeps this address at the\n"
                   f"next `ur3dq sim start`. For other tools:\n  export UR3DQ_HOST={state['host']}")


@sim.command("stop", short_help="Stop the simulator.")
@display_options
@click.pass_obj
def sim_stop(settings: Settings) -> None:
    """Stop the simulator `ur3dq sim start` left running."""
    state = stop_simulator()
    if settings.json:
        emit_json({"stopped": state})
    elif state:
        click.echo(f"Stopped the simulator on {state['host']} (pid {state['pid']}).")
    else:
        click.echo("No embedded simulator was running.")


@sim.command("status", short_help="Whether the simulator runs, and where.")
@display_options
@click.pass_obj
def sim_status(settings: Settings) -> None:
    """Whether the simulator runs, and where."""
    state = read_state(state_directory())
    if settings.json:
        emit_json({"running": state is not None, **(state or {})})
    elif state:
        click.echo(f"Running: simulated {state['model']} on {state['host']} (pid {state['pid']})\n"
                   f"  since {state['started']}\n  log {state['log']}")
    else:
        click.echo("Not running (start it with `ur3dq sim start`).")
