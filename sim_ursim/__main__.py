"""`sim-ursim` / `python -m sim_ursim`: run a simulated UR controller, or inject a fault into a running one."""
import json
import logging
import signal
import sys

import click

from .calibration import factory_calibration
from .control_channel import CONTROL_PORT, FAULT_COMMANDS, send_request
from .cycle_clock import CLOCKS, REAL_TIME
from .models import MODEL_NAMES, robot_model


def parse_joint_list(text):
    """Six joint values (rad) from "a,b,c,d,e,f" or "a b c d e f"; ValueError otherwise."""
    parts = text.replace(",", " ").split()
    try:
        values = [float(part) for part in parts]
    except ValueError:
        raise ValueError(f"joints must be 6 numbers, got {text!r}") from None
    if len(values) != 6:
        raise ValueError(f"joints must be 6 numbers, got {len(values)} in {text!r}")
    return values


def load_calibration(path, model):
    """DH deltas {a, d, alpha, theta: 6 numbers each} from a JSON file, or generated for ``factory[:SEED]``."""
    if path == "factory" or path.startswith("factory:"):
        seed = path.partition(":")[2] or "0"
        if not seed.isdigit():
            raise ValueError(f"--calibration {path}: the seed after 'factory:' must be a whole number")
        return factory_calibration(robot_model(model).dh, int(seed))
    with open(path, encoding="utf-8") as calibration_file:
        calibration = json.load(calibration_file)
    if not isinstance(calibration, dict):
        raise ValueError(f"{path}: calibration must be a JSON object of DH deltas (a, d, alpha, theta)")
    return calibration


@click.group(invoke_without_command=True, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--model", type=click.Choice(MODEL_NAMES), default="ur3", show_default=True, help="Arm to emulate.")
@click.option("--version", "software_version", default=None,
              help="Controller software version, e.g. 3.15.8 or 5.11.1 (default: 3.15.8 CB3, 5.11.1 e-series).")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Loopback address to bind the robot's ports on (e.g. 127.0.0.2 for a second simulator).")
@click.option("--initial-q", default=None, help="Initial joints in rad: 'a,b,c,d,e,f'.")
@click.option("--frequency", type=float, default=None, help="Control frequency in Hz (default 125 CB3, 500 e-series).")
@click.option("--calibration", default=None,
              help="JSON file of DH deltas {a, d, alpha, theta: 6 numbers each}: a calibrated arm; or "
                   "'factory[:SEED]': a slightly imperfect arm whose Kinematics Info is a factory-style table "
                   "(huge cancelling offsets on the parallel joints, as real controllers report).")
@click.option("--programs-dir", type=click.Path(file_okay=False), default=None,
              help="Where dashboard `load` finds programs (.urp or URScript), sub-directories included "
                   "(default: current directory).")
@click.option("--external-control-host", default=None,
              help="Where the External Control URCap node of a played .urp fetches its program (the remote PC of "
                   "the URCap's settings; a loopback address). Default: the simulator's own --host.")
@click.option("--external-control-port", type=click.IntRange(1, 65535), default=50002, show_default=True,
              help="The External Control URCap's port.")
@click.option("--remote-control", type=click.Choice(["on", "off"]), default="on", show_default=True,
              help="What the dashboard's `is in remote control` answers (e-series 5.6+): on, as a robot in remote "
                   "control (ur_rtde's control interface needs it); off, as URSim by default (URCL's tests expect "
                   "it). Dashboard commands are accepted either way.")
@click.option("--clock", type=click.Choice(CLOCKS), default=REAL_TIME, show_default=True,
              help="real-time: one control cycle per period of wall time, as a controller. fast (test pipelines "
                   "only): while a program runs or the arm moves, cycles are computed back to back, each one "
                   "period of simulated time, script threads in lockstep; at rest it keeps real time. RTDE "
                   "timestamps, sleep() and waits follow simulated time (docs/ursim.md).")
@click.option("--log-level", type=click.Choice(["DEBUG", "INFO", "WARNING"]), default="INFO", show_default=True)
@click.pass_context
def main(ctx, model, software_version, host, initial_q, frequency, calibration, programs_dir,
         external_control_host, external_control_port, remote_control, clock, log_level):
    """Run a protocol-level UR controller simulator (dashboard 29999, primary 30001, secondary 30002,
    real-time 30003, RTDE 30004, fault control 29998) until Ctrl-C, SIGTERM or the dashboard's `shutdown`."""
    if ctx.invoked_subcommand is not None:
        return
    logging.basicConfig(level=log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    from .simulator import Simulator

    try:
        simulator = Simulator(model=model, version=software_version, host=host,
                              initial_q=parse_joint_list(initial_q) if initial_q else None,
                              calibration=load_calibration(calibration, model) if calibration else None,
                              frequency=frequency, programs_directory=programs_dir,
                              external_control_host=external_control_host,
                              external_control_port=external_control_port,
                              remote_control=remote_control == "on", clock=clock)
    except (ValueError, OSError) as error:   # OSError: a --calibration file that cannot be read
        raise click.BadParameter(str(error)) from None
    try:
        simulator.start()
    except OSError as error:
        raise click.ClickException(f"cannot bind the robot's ports on {host}: {error}") from None
    signal.signal(signal.SIGTERM, lambda *_: simulator.request_stop())
    try:
        while not simulator.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        simulator.stop()


#: The way on when no simulator answers: it usually runs on another loopback address.
ELSEWHERE_HINT = ("; is the simulator on another address? Pass --host ADDRESS (or export UR3DQ_HOST); "
                  "`ur3dq sim status` names the one `ur3dq sim start` runs")


@main.command()
@click.argument("kind", type=click.Choice(FAULT_COMMANDS))
@click.option("--host", default="127.0.0.1", show_default=True, help="Address of the running simulator.")
@click.option("--port", default=CONTROL_PORT, show_default=True, help="Its fault-control port.")
@click.option("--seconds", type=float, default=None, help="Duration for freeze, delay for latency.")
@click.option("--reason", default="injected fault", show_default=True, help="Reason logged for a protective stop.")
def fault(kind, host, port, seconds, reason):
    """Inject a fault into (or query) a running simulator through its control channel."""
    arguments = {}
    if kind in ("freeze", "latency"):
        if seconds is None:
            raise click.UsageError(f"{kind} needs --seconds")
        arguments["seconds"] = seconds
    if kind == "protective-stop":
        arguments["reason"] = reason
    try:
        reply = send_request(host, kind, port=port, **arguments)
    except OSError as error:
        raise click.ClickException(f"no simulator control channel on {host}:{port}: {error}{ELSEWHERE_HINT}") from None
    if not reply.get("ok"):
        raise click.ClickException(reply.get("error", "refused"))
    click.echo(reply["message"])


#: Where `move-by-hand` finds the simulator when --host is not given: the address ur3dq's tools use.
HOST_VARIABLES = ("SIM_URSIM_HOST", "UR3DQ_HOST")


@main.command(name="move-by-hand", context_settings={"ignore_unknown_options": True})
@click.argument("joints", nargs=-1, required=True)
@click.option("--host", envvar=list(HOST_VARIABLES), default="127.0.0.1", show_default=True,
              help="Address of the running simulator (env SIM_URSIM_HOST, else UR3DQ_HOST).")
@click.option("--port", default=CONTROL_PORT, show_default=True, help="Its fault-control port.")
def move_by_hand(joints, host, port):
    """Push the simulated arm by hand to JOINTS (six values in rad: 'a,b,c,d,e,f' or a b c d e f; negative values
    need no `--`), as an operator in freedrive would. When freedrive is already on (a `record-pose --teach` is
    running) it stays on; otherwise it is switched on for the push and off again. For people, `ur3dq jog` moves the
    arm with the keyboard (simulator or robot alike)."""
    try:
        q = parse_joint_list(" ".join(joints))
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="JOINTS") from None
    freedrive_was_on = bool(_control(host, port, "status")["state"].get("freedrive"))
    requests = [("move-by-hand", {"q": q})]
    if not freedrive_was_on:
        requests = [("freedrive", {"on": True}), *requests, ("freedrive", {"on": False})]
    for command, arguments in requests:
        _control(host, port, command, **arguments)
    click.echo(f"arm moved by hand to {q}" + (" (freedrive stays on)" if freedrive_was_on else ""))


def _control(host, port, command, **arguments):
    """The reply of one control-channel request; ClickException naming the problem when it fails."""
    try:
        reply = send_request(host, command, port=port, **arguments)
    except OSError as error:
        raise click.ClickException(f"no simulator control channel on {host}:{port}: {error}{ELSEWHERE_HINT}") from None
    if not reply.get("ok"):
        raise click.ClickException(reply.get("error", "refused"))
    return reply


if __name__ == "__main__":
    sys.exit(main())
