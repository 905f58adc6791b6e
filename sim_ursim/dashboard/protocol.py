"""Dashboard server protocol (port 29999): command lines in, reply lines out — no sockets here.

Reply strings are the real controller's (docs/protocols.md §2, cross-checked with URCL's command list and ur_rtde).
Commands the emulated software version does not have get the same answer as unknown ones.
"""
import logging
import os
import threading
import time
import zipfile
from dataclasses import dataclass
from typing import Any

from ..models import build_date
from ..polyscope.program_tab import ProgramTab
from ..vocabulary import CommandRefused, RobotMode, SafetyMode, UnlockTooEarly

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


def handle(line, controller, programs=None):
    """The Reply to one request `line` for `controller` (which it may command); `programs` is the ProgramTab that
    loads and plays programs (a default one, External Control on 127.0.0.1, when None)."""
    command, argument = parse_command(line)
    if command is None:
        return unknown(argument)
    if not available(command, controller.version):
        return unknown(line.strip())
    if command in _PROGRAM_HANDLERS:
        return _PROGRAM_HANDLERS[command](programs or ProgramTab(controller), argument)
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


def _load(programs, argument):
    """Load a program (sim_ursim.polyscope.program_tab): a `.urp`'s tree, any other file as URScript."""
    if not argument:
        return unknown("load")
    return Reply(programs.load(argument))


def _play(programs, argument):
    """Resume a paused program, or start the loaded one (a `.urp`'s script is generated now, as PolyScope does)."""
    controller = programs.controller
    state = controller.state()
    if state.program_running and state.program_paused:
        controller.resume_program()
        return Reply("Starting program")
    runnable = (controller.loaded_program_source is not None and controller.program_runner is not None
                and state.robot_mode == RobotMode.RUNNING and state.safety_mode == SafetyMode.NORMAL
                and not state.program_running)
    source = programs.script_for_play() if runnable else None
    if source is None:
        return Reply("Failed to execute: play")
    try:
        started = controller.run_program(source, "dashboard")
    except (CommandRefused, ValueError) as error:
        log.warning("play: %s", error)
        return Reply("Failed to execute: play")
    return Reply("Failed to execute: play" if started is False else "Starting program")


def _stop(controller, argument):
    # "Stopped" also when nothing runs: the state asked for holds.  ur_rtde's RTDEControlInterface sends `stop`
    # right after ending a crashed client's script and raises on any other reply; URCL's commandStop expects
    # "Stopped" and then only checks that programState says STOPPED.
    if controller.state().program_running:
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


def _restart_safety(controller: Any, argument: str) -> Reply:
    # A safety restart clears a protective stop and leaves the arm powered off, as on the real controller; within
    # 5 s of the stop it is refused with the unlock rule's text, and nothing changes (the stop stays latched).
    try:
        controller.unlock_protective_stop()
    except UnlockTooEarly:
        return Reply(UNLOCK_TOO_EARLY)
    except CommandRefused:
        pass  # not protective-stopped: the restart only powers off
    controller.power_off()
    return Reply("Restarting safety")


def _load_installation(controller: Any, argument: str) -> Reply:
    """PolyScope's replies (UR's dashboard server manual): a missing file is `File not found: X`, an unreadable one
    `Failed to load installation: X`. The simulator has no installation settings to apply: a file that reads loads."""
    path = ProgramTab(controller).resolve(argument)  # where `load` finds files: the programs directory
    if not os.path.isfile(path):
        return Reply(f"File not found: {argument}")
    try:
        with open(path, "rb"):
            pass
    except OSError as error:
        log.warning("load installation %s: %s", path, error)
        return Reply(f"Failed to load installation: {argument}")
    return Reply(f"Loading installation: {argument}")


def _reply(text):
    return lambda controller, argument: Reply(text)


def _quit(controller, argument):
    return Reply("Disconnected", close=True)


def _shutdown(controller, argument):
    return Reply("Shutting down", close=True, shutdown=True)


def _add_to_log(controller, argument):
    log.info("log message from a dashboard client: %s", argument)
    return Reply("Added log message")


class PendantSettings:
    """What dashboard commands store on a controller: user role (CB3), operational mode (e-series), and whether the
    robot is in remote control (e-series 5.6+: `is in remote control`).

    `remote_control` True is a robot switched to remote control, which ur_rtde's RTDEControlInterface requires on
    5.6+; False is URSim's default (remote control not enabled; dashboard commands are accepted all the same), which
    URCL's integration tests expect (`sim-ursim --remote-control off`).
    """

    def __init__(self) -> None:
        self.user_role = "PROGRAMMER"
        self.operational_mode = "NONE"  # NONE while no client controls it (no mode password configured)
        self.remote_control = True


_SETTINGS_LOCK = threading.Lock()
USER_ROLES = ("programmer", "operator", "none", "locked", "restricted")
OPERATIONAL_MODES = ("manual", "automatic")
FLIGHT_REPORT_TYPES = ("controller", "software", "system")


def pendant_settings(controller) -> PendantSettings:
    """The PendantSettings the dashboard keeps for `controller` (created on first use)."""
    with _SETTINGS_LOCK:
        settings = getattr(controller, "_dashboard_settings", None)
        if settings is None:
            settings = PendantSettings()
            controller._dashboard_settings = settings
        return settings


def _set_user_role(controller, argument):
    role = argument.strip().lower()
    if role not in USER_ROLES:
        return Reply(f"Failed setting user role: {argument}")
    pendant_settings(controller).user_role = role.upper()
    return Reply(f"Setting user role: {argument}")


def _set_operational_mode(controller, argument):
    mode = argument.strip().lower()
    if mode not in OPERATIONAL_MODES:
        return Reply(f"Failed setting operational mode: {argument}")
    pendant_settings(controller).operational_mode = mode.upper()
    # The mode as the client wrote it: URCL matches "(?:Operational mode ).*(?:AUTOMATIC).*", case-sensitive.
    return Reply(f"Operational mode '{argument.strip()}' is set")


def _clear_operational_mode(controller, argument):
    # The mode stays in effect on the robot, but no client controls it any more: `get operational mode` answers NONE
    # again (URCL's DashboardClientTestG5.operational_mode expects so).
    settings = pendant_settings(controller)
    mode, settings.operational_mode = settings.operational_mode.lower(), "NONE"
    return Reply(f"No longer controlling the operational mode. Current operational mode: '{mode}'.")


def _flight_report(controller, argument):
    kind = (argument.strip() or "controller").lower()
    if kind not in FLIGHT_REPORT_TYPES:
        return Reply(f"Error: unknown report type: {argument}")
    report_id = f"{int(time.time() * 1000) & 0xFFFFFFFF:08x}"
    log.info("flight report (%s) requested: id %s", kind, report_id)
    return Reply(f"Flight Report generated with id: {report_id}")


def _support_file(controller, argument):
    """Write a small support archive (software version, model, serial, state) into the given directory."""
    directory = resolve_program_path(argument.strip(), controller.programs_directory) if argument.strip() else None
    if directory is None or not os.path.isdir(directory):
        return Reply(f"Error: no such directory: {argument}")
    state = controller.state()
    name = f"ur_{controller.model.serial_number}_{time.strftime('%Y-%m-%d_%H-%M-%S')}.zip"
    try:
        with zipfile.ZipFile(os.path.join(directory, name), "w") as archive:
            archive.writestr("version.txt", f"{polyscope_version_reply(controller.version)}\n")
            archive.writestr("robot.txt", f"{controller.model.display_name} {controller.model.serial_number}\n"
                                          f"{robot_mode_reply(state.robot_mode)}\n"
                                          f"{safety_mode_reply(state.safety_mode)}\n")
    except OSError as error:
        return Reply(f"Error: {error}")
    return Reply(f"Completed successfully: {name}")


def _loaded_program(controller, argument):
    if controller.loaded_program is None:
        return Reply("No program loaded")
    return Reply(f"Loaded program: {controller.loaded_program}")


_PROGRAM_HANDLERS = {"load": _load, "play": _play}
_HANDLERS = {
    "power on": _power_on,
    "power off": _power_off,
    "brake release": _brake_release,
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
    "is in remote control": lambda c, a: Reply("true" if pendant_settings(c).remote_control else "false"),
    "get operational mode": lambda c, a: Reply(pendant_settings(c).operational_mode),
    "set operational mode": _set_operational_mode,
    "clear operational mode": _clear_operational_mode,
    "getuserrole": lambda c, a: Reply(pendant_settings(c).user_role),
    "setuserrole": _set_user_role,
    "generate flight report": _flight_report,
    "generate support file": _support_file,
    "get loaded program": _loaded_program,
    "isprogramsaved": lambda c, a: Reply(f"true {program_name(c.loaded_program)}"),
    "addtolog": _add_to_log,
    "savelog": _reply("Log saved to disk"),
    "load installation": _load_installation,
    "quit": _quit,
    "shutdown": _shutdown,
}
_TAKES_ARGUMENT = {"load", "popup", "addtolog", "setuserrole", "load installation", "set operational mode",
                   "generate flight report", "generate support file"}
_COMMANDS_LONGEST_FIRST = sorted([*_HANDLERS, *_PROGRAM_HANDLERS], key=len, reverse=True)

# Commands that exist only from a given software version on, as (CB3, e-series) minimums; None: never on that
# platform.  URCL's dashboard command table (src/ur/dashboard_client_implementation_g5.cpp) and docs/protocols.md §2.
_MINIMUM_VERSION = {
    "safetystatus": (None, (5, 4, 0)),
    "get serial number": ((3, 12, 0), (5, 6, 0)),
    "get robot model": ((3, 12, 0), (5, 6, 0)),
    "is in remote control": (None, (5, 6, 0)),
    "get operational mode": (None, (5, 6, 0)),
    "set operational mode": (None, (5, 0, 0)),
    "clear operational mode": (None, (5, 0, 0)),
    "restart safety": ((3, 7, 0), (5, 1, 0)),
    "generate flight report": ((3, 13, 0), (5, 8, 0)),
    "generate support file": ((3, 13, 0), (5, 8, 0)),
    "savelog": ((3, 13, 0), (5, 8, 0)),
    "setuserrole": ((3, 1, 0), None),  # user roles are CB3-only (URCL: up to 5.99 excluded for e-series)
    "getuserrole": ((3, 1, 0), None),
}


def available(command, version):
    """True when the controller software `version` has dashboard `command`."""
    minimums = _MINIMUM_VERSION.get(command)
    if minimums is None:
        return True
    minimum = minimums[1] if version.is_e_series else minimums[0]
    return minimum is not None and version.at_least(*minimum)
