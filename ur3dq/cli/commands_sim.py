"""`ur3dq sim start/stop/status` (the embedded simulator in the background) and `ur3dq demo` (the whole job)."""
from __future__ import annotations

import contextlib
import math
import tempfile
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.markup import escape

from ur3dq.cli.app import EXIT_NOT_REACHED, Settings, cli, emit_json
from ur3dq.cli.background_simulator import SimulatorError, read_state, start_simulator, state_directory, stop_simulator
from ur3dq.cli.demo_program import run_pick_and_place
from ur3dq.cli.display import angles_text, plan_table, pose_vector_text, progress_bar, reached_table
from ur3dq.cli.library_output import own_output
from ur3dq.cli.options import angular_option, display_options, speed_and_acceleration
from ur3dq.replay import execute_plan, plan_replay, read_pose
from ur3dq.store import PoseStore

# Where the demo parks the arm and the places it records (rad): distinct, comfortably reachable, away from the
# wrist singularity (wrist 2 ≠ 0, π), and each within π of the last so no move is refused for its travel.
DEMO_PARK = (0.0, -math.pi / 2, 0.0, -math.pi / 2, 0.0, 0.0)
DEMO_SPEED = 1.5         # rad/s: brisk enough for a demo, slow enough to watch
DEMO_ACCELERATION = 3.0  # rad/s²
DEMO_PLACES = (
    (0.0, -1.2, 1.0, -1.4, -1.57, 0.0),
    (0.8, -1.0, 1.3, -1.9, -1.57, 0.5),
    (-0.7, -1.6, 1.6, -1.6, -1.57, -0.3),
    (0.3, -0.8, 0.7, -1.5, -1.2, 1.0),
)


@cli.group()
def sim():
    """The embedded simulator (sim_ursim) in the background, for trying ur3dq without a robot.

    While it runs, robot commands use it when no --host / UR3DQ_HOST is given.

    \b
    Examples:
      ur3dq sim start           # a UR3 (CB3 3.15) on a free loopback address
      ur3dq --model ur5e sim start --address 127.0.0.3
      ur3dq sim status
      ur3dq sim stop
    """


@sim.command("start")
@click.option("--address", help="Loopback address to serve on (127.x.y.z; default: a free one).")
@click.option("--version", "software_version", help="Controller software, e.g. 3.15.8 or 5.11.1.")
@click.option("--powered-off", is_flag=True,
              help="Leave the arm powered off with brakes held, as a real controller boots (default: ready to move).")
@display_options
@click.pass_obj
def sim_start(settings: Settings, address, software_version, powered_off):
    """Start the simulator in the background: the arm at zero joints, powered on with its brakes released
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
        click.echo(f"Robot commands now use it. For other tools, copy:\n  export UR3DQ_HOST={state['host']}")


@sim.command("stop")
@display_options
@click.pass_obj
def sim_stop(settings: Settings):
    """Stop the simulator `ur3dq sim start` left running."""
    state = stop_simulator()
    if settings.json:
        emit_json({"stopped": state})
    elif state:
        click.echo(f"Stopped the simulator on {state['host']} (pid {state['pid']}).")
    else:
        click.echo("No embedded simulator was running.")


@sim.command("status")
@display_options
@click.pass_obj
def sim_status(settings: Settings):
    """Whether the simulator runs, and where."""
    state = read_state(state_directory())
    if settings.json:
        emit_json({"running": state is not None, **(state or {})})
    elif state:
        click.echo(f"Running: simulated {state['model']} on {state['host']} (pid {state['pid']})\n"
                   f"  since {state['started']}\n  log {state['log']}")
    else:
        click.echo("Not running (start it with `ur3dq sim start`).")


@cli.command()
@click.option("--save", type=click.Path(dir_okay=False, path_type=Path),
              help="Keep the demo's pose store in this file (default: a temporary one, removed afterwards).")
@click.option("--speed", type=float, default=None, help="movej speed, rad/s (°/s with --deg) [default: 1.5 rad/s].")
@click.option("--acceleration", type=float, default=None,
              help="movej acceleration, rad/s² (°/s² with --deg) [default: 3 rad/s²].")
@click.option("--tolerance-mm", type=float, default=0.5, show_default=True,
              help="A replayed pose counts as reached within this distance.")
@click.option("--tolerance-deg", type=float, default=0.1, show_default=True,
              help="... and within this rotation.")
@display_options
@click.pass_obj
def demo(settings: Settings, save, speed, acceleration, tolerance_mm, tolerance_deg):
    """The whole job against a simulator it starts itself: power on, release the brakes, move the arm to a few
    places and record each into a pose store, park the arm, replay the store (IK nearest the recorded joints,
    as run-poses does), and show where the arm ended vs where each pose was recorded.

    Exits 0 only if every replayed pose was reached within tolerance (else 7).

    \b
    Examples:
      ur3dq demo
      ur3dq --model ur5e demo --save demo-poses.json
    """
    from sim_ursim.launch import simulator_process
    from ur3dq.robot import connect

    # with --json the story goes to stderr, so stdout carries only the JSON result
    say = Console(stderr=True, highlight=False).print if settings.json else settings.out.print
    model_name = settings.model or "ur3"
    with tempfile.TemporaryDirectory(prefix="ur3dq-demo-") as scratch, contextlib.ExitStack() as stack:
        store = PoseStore(save or Path(scratch) / "demo-poses.json")
        say(f"[bold]1.[/bold] Starting the embedded simulator (sim_ursim, {model_name}) ...")
        try:
            simulator = stack.enter_context(simulator_process(model=model_name))
        except (RuntimeError, TimeoutError) as error:
            raise SimulatorError(f"the embedded simulator did not start: {error}") from None
        stack.enter_context(own_output())
        with connect(simulator.host, model=model_name) as robot:
            say(f"   serving on {simulator.host}; powering on and releasing the brakes")
            robot.power_on()
            robot.brake_release()
            a, v = speed_and_acceleration(robot.model, angular_option(speed, DEMO_SPEED, settings.deg),
                                          angular_option(acceleration, DEMO_ACCELERATION, settings.deg),
                                          Console(stderr=True))
            say(f"[bold]2.[/bold] Moving the arm to {len(DEMO_PLACES)} places and recording each into "
                f"{escape(str(store.path))}")
            recorded = []
            for index, place in enumerate(DEMO_PLACES, start=1):
                robot.movej(np.array(place), a=a, v=v)
                stored = store.add(read_pose(robot, f"demo-{index}", note="recorded by ur3dq demo"),
                                   number_if_taken=True)
                recorded.append(stored.name)
                say(f"   recorded {stored.name} at TCP {pose_vector_text(stored.ur_pose, settings.deg)}")
            say(f"[bold]3.[/bold] Parking the arm at {angles_text(DEMO_PARK, settings.deg)}")
            robot.movej(np.array(DEMO_PARK), a=a, v=v)
            say("[bold]4.[/bold] Replaying the store as run-poses does (IK of each dual quaternion, FK-checked)")
            steps = plan_replay(robot.model, store.select(recorded), robot.joints(), a, v)
            say(plan_table(steps, settings.deg, "Plan", settings.out.width))
            with progress_bar(Console(stderr=True)) as progress:
                results = execute_plan(robot, steps, a, v, 0.0, 1, progress)
            say("[bold]5.[/bold] A cell program from the same store: approach, linear descent, gripper output, "
                "wait, linear retract, place")
            program_store = PoseStore(store.path.with_name(store.path.stem + "-program.json"))
            say(escape(f"   written to {program_store.path} (run it again with `ur3dq --store {program_store.path} "
                       "run-poses`)"))
            run_pick_and_place(robot, store, program_store, recorded[0], recorded[1], say)
    missed = [r for r in results
              if r.error_m * 1000 > tolerance_mm or math.degrees(r.error_rad) > tolerance_deg]
    if settings.json:
        emit_json({"reached": [{"pose": r.step.pose.name, "error_m": r.error_m, "error_rad": r.error_rad}
                               for r in results], "missed": [r.step.pose.name for r in missed]})
    else:
        say(reached_table(results, "6. Where the arm ended vs where each pose was recorded", settings.out.width))
    if missed:
        click.echo(f"Error: {len(missed)} of {len(results)} poses missed the tolerance of {tolerance_mm} mm / "
                   f"{tolerance_deg}°: {', '.join(r.step.pose.name for r in missed)}", err=True)
        click.get_current_context().exit(EXIT_NOT_REACHED)
    if not settings.json:
        say(f"[green]Every pose reached within {tolerance_mm} mm / {tolerance_deg}°.[/green]"
            + (escape(f" The poses are in {save}.") if save else ""))
