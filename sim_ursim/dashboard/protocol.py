"""Dashboard server protocol (port 29999): command lines in, reply lines out — no sockets here.

Reply strings are the real controller's (protocols.md §2.3, cross-checked with URCL's command list and ur_rtde).
Commands the emulated software version does not have get the same answer as unknown ones.
"""
import logging
import os
from dataclasses import dataclass

from ..vocabulary import CommandRefused, RobotMode, SafetyMode, UnlockTooEarly
from ..models import build_date

log = logging.getLogger("sim_ursim.dashboard")

GREETING = "Connected: Universal Robots Dashboard Server"
UNLOCK_TOO_EARLY = ("Cannot unlock protective stop until 5s after occurrence. "
                    "Always inspect cause of protective stop before unlocking")


@dataclass(frozen=True)
class Reply:
    """One reply line, and what the server must do after sending it."""

    text: str
    close: bool = False
    shutdown: bool = False


def parse_command(line):
    """(command, argument) of a request line: the command lower-cased with single spaces, the argument verbatim.

    The longest known command that prefixes the line wins, so `load installation x` is not `load`.
    """
    text = line.strip("\r\n").strip()
    lowered = " ".join(text.lower().split())
    for command in _COMMANDS_LONGEST_FIRST:
        if lowered == command:
            return command, ""
        if lowered.startswith(command + " ") and command in _TAKES_ARGUMENT:
            # Keep the argument's own spelling (paths and messages are case-sensitive).
            return command, text.split(None, len(command.split()))[-1]
    return None, text


def unknown(text):
    """The reply to a command the controller does not know."""
    return Reply(f"could not understand: '{text}'")


def handle(line, controller):
    """The Reply to one request `line` for `controller` (which it may command)."""
    command, argument = parse_command(line)
    if command is None:
        return unknown(argument)
    minimum = _MINIMUM_VERSION.get(command)
    if minimum is not None and not controller.version.at_least(*minimum):
        return unknown(line.strip())
    return _HANDLERS[command](controller, argument)


def robot_mode_reply(mode):
    """`Robotmode: <NAME>` for a robot mode number."""
    return f"Robotmode: {RobotMode.NAMES[mode]}"


def safety_mode_reply(mode, word="Safetymode"):
    """`Safetymode: <NAME>` (or `Safetystatus: <NAME>`) for a safety mode number."""
    return f"{word}: {SafetyMode.NAMES[mode]}"


def polyscope_version_reply(version):
    """`URSoftware M.m.b.build (date)` as PolyscopeVersion answers."""
    return f"URSoftware {version} ({build_date(version)})"


def program_name(path):
    """The loaded program's name as programState prints it (`<unnamed>` when nothing is loaded)."""
    return os.path.basename(path) if path else "<unnamed>"


def program_state_reply(state, loaded_program):
    """`<STOPPED|PLAYING|PAUSED> <program name>` for a controller snapshot."""
    if not state.program_running:
        word = "STOPPED"
    else:
        word = "PAUSED" if state.program_paused else "PLAYING"
    return f"{word} {program_name(loaded_program)}"


def resolve_program_path(argument, programs_directory):
    """Absolute path of a `load` argument: absolute stays, relative joins the programs directory (default cwd)."""
    if os.path.isabs(argument):
        return argument
    return os.path.join(programs_directory or os.getcwd(), argument)


# ----------------------------------------------------------------------------------------------- handlers
def _power_on(controller, argument):
    _try(controller.power_on, "power on")
    return Reply("Powering on")


def _power_off(controller, argument):
    controller.power_off()
    return Reply("Powering off")


def _brake_release(controller, argument):
    _try(controller.brake_release, "brake release")
    return Reply("Brake releasing")


def _try(action, name):
    """Run a command whose reply the controller prints regardless of the outcome; log a refusal."""
    try:
        action()
    except CommandRefused as refusal:
        log.warning("%s: %s", name, refusal)


def _load(controller, argument):
    if not argument:
        return unknown("load")
    path = resolve_program_path(argument, controller.programs_directory)
    if not os.path.isfile(path):
        return Reply(f"File not found: {argument}")
    try:
        with open(path, encoding="utf-8") as program:
            source = program.read()
    except (OSError, UnicodeDecodeError) as error:
        log.warning("load %s: %s", path, error)
        return Reply(f"Error while loading program: {argument}")
    if controller.state().program_running:
        controller.stop_program()
    controller.loaded_program = path
    controller.loaded_program_source = source
    return Reply(f"Loading program: {argument}")


def _play(controller, argument):
    state = controller.state()
    if state.program_running and state.program_paused:
        controller.resume_program()
        return Reply("Starting program")
    runnable = (controller.loaded_program_source is not None and controller.program_runner is not None
                and state.robot_mode == RobotMode.RUNNING and state.safety_mode == SafetyMode.NORMAL
                and not state.program_running)
    if not runnable:
        return Reply("Failed to execute: play")
    try:
        started = controller.run_program(controller.loaded_program_source, "dashboard")
    except (CommandRefused, ValueError) as error:
        log.warning("play: %s", error)
        return Reply("Failed to execute: play")
    return Reply("Failed to execute: play" if started is False else "Starting program")


def _stop(controller, argument):
    if not controller.state().program_running:
        return Reply("Failed to execute: stop")
    controller.stop_program()
    return Reply("Stopped")


def _pause(controller, argument):
    state = controller.state()
    if not state.program_running or state.program_paused:
        return Reply("Failed to execute: pause")
    controller.pause_program()
    return Reply("Pausing program")


def _unlock(controller, argument):
    try:
        controller.unlock_protective_stop()
    except UnlockTooEarly:
        return Reply(UNLOCK_TOO_EARLY)
    except CommandRefused as refusal:
        log.info("unlock protective stop: %s", refusal)
    return Reply("Protective stop releasing")


def _restart_safety(controller, argument):
    # A safety restart clears a protective stop and leaves the arm powered off, as on the real controller.
    controller.power_off()
    try:
        controller.unlock_protective_stop()
    except CommandRefused:
        pass
    return Reply("Restarting safety")


def _reply(text):
    return lambda controller, argument: Reply(text)


def _quit(controller, argument):
    return Reply("Disconnected", close=True)


def _shutdown(controller, argument):
    return Reply("Shutting down", close=True, shutdown=True)


def _add_to_log(controller, argument):
    log.info("log message from a dashboard client: %s", argument)
    return Reply("Added log message")


def _loaded_program(controller, argument):
    if controller.loaded_program is None:
        return Reply("No program loaded")
    return Reply(f"Loaded program: {controller.loaded_program}")


_HANDLERS = {
    "power on": _power_on,
    "power off": _power_off,
    "brake release": _brake_release,
    "load": _load,
    "play": _play,
    "stop": _stop,
    "pause": _pause,
    "unlock protective stop": _unlock,
    "restart safety": _restart_safety,
    "robotmode": lambda c, a: Reply(robot_mode_reply(c.state().robot_mode)),
    "safetymode": lambda c, a: Reply(safety_mode_reply(c.state().safety_mode)),
    "safetystatus": lambda c, a: Reply(safety_mode_reply(c.state().safety_status, "Safetystatus")),
    "programstate": lambda c, a: Reply(program_state_reply(c.state(), c.loaded_program)),
    "running": lambda c, a: Reply(f"Program running: {'true' if c.state().program_running else 'false'}"),
    "close safety popup": _reply("closing safety popup"),
    "close popup": _reply("closing popup"),
    "popup": _reply("showing popup"),
    "polyscopeversion": lambda c, a: Reply(polyscope_version_reply(c.version)),
    "version": lambda c, a: Reply(str(c.version)),
    "get serial number": lambda c, a: Reply(c.model.serial_number),
    "get robot model": lambda c, a: Reply(c.model.display_name),
    "is in remote control": _reply("true"),
    "get operational mode": _reply("NONE"),
    "getuserrole": _reply("PROGRAMMER"),
    "setuserrole": lambda c, a: Reply(f"Setting user role: {a}"),
    "get loaded program": _loaded_program,
    "isprogramsaved": lambda c, a: Reply(f"true {program_name(c.loaded_program)}"),
    "addtolog": _add_to_log,
    "savelog": _reply("Log saved to disk"),
    "load installation": lambda c, a: Reply(f"Loading installation: {a}"),
    "quit": _quit,
    "shutdown": _shutdown,
}
_TAKES_ARGUMENT = {"load", "popup", "addtolog", "setuserrole", "load installation"}
_COMMANDS_LONGEST_FIRST = sorted(_HANDLERS, key=len, reverse=True)

# Commands that only exist from a given software version on (protocols.md §2.3; e-series-only ones need 5.x).
_MINIMUM_VERSION = {
    "safetystatus": (5, 4, 0),
    "get serial number": (5, 6, 0),
    "is in remote control": (5, 6, 0),
    "get operational mode": (5, 6, 0),
    "restart safety": (3, 7, 0),
}
