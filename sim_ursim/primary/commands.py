"""Controller commands a client writes to the primary/secondary ports instead of URScript.

A controller reading 30001/30002 executes a few plain-text lines itself rather than compiling them as a program;
URCL's `PrimaryClient` relies on exactly these (src/primary/primary_client.cpp: commandPowerOn … commandStop):

    power on                      power off                     brake release
    set robotmode run             set unlock protective stop    stop program

`set robotmode run` is URCL's brake release (the arm ends RUNNING, powered on first if it was off).  A chunk of
text is treated as commands only when *every* non-blank line is one; anything else is URScript for the runner.
Refusals (an emergency stop, nothing to unlock) are logged and published as a text message, never raised.

`set unlock protective stop` clears a protective stop at once, also within 5 s of the stop: the 5 s rule ("Cannot
unlock protective stop until 5s after occurrence") is PolyScope's, the pendant's and the dashboard server's, and
the primary interface talks to the controller itself. URCL's PrimaryClientTest, which passes against URSim 3.14
and 5.9 in URCL's CI, sends this command right after a `protective_stop()` or an unreachable movel and expects
the stop cleared within its 5 s wait; the dashboard's `unlock protective stop` keeps the rule.
"""
import logging

from ..messages import TextMessage
from ..vocabulary import CommandRefused

log = logging.getLogger("sim_ursim.primary")


def _unlock(controller):
    controller.unlock_protective_stop(enforce_delay=False)


def _stop_program(controller):
    if controller.state().program_running:
        controller.stop_program()


# command line (lower-cased, single spaces) -> what the controller does
_COMMANDS = {
    "power on": lambda controller: controller.power_on(),
    "power off": lambda controller: controller.power_off(),
    "brake release": lambda controller: controller.brake_release(),
    "set robotmode run": lambda controller: controller.brake_release(),
    "set unlock protective stop": _unlock,
    "stop program": _stop_program,
}


def _normalised(line):
    return " ".join(line.strip().lower().split())


def parse_commands(text):
    """The command names in a received chunk when every non-blank line is a primary command, else None."""
    lines = [_normalised(line) for line in text.splitlines()]
    lines = [line for line in lines if line]
    if not lines or any(line not in _COMMANDS for line in lines):
        return None
    return lines


def execute(text, controller):
    """Execute `text` as primary commands if it is nothing else; True when it was (the runner must not see it)."""
    commands = parse_commands(text)
    if commands is None:
        return False
    for command in commands:
        log.info("primary command: %s", command)
        try:
            _COMMANDS[command](controller)
        except CommandRefused as refusal:
            log.warning("primary command %r refused: %s", command, refusal)
            controller.messages.publish(TextMessage(text=f"{command}: {refusal}"))
    return True
