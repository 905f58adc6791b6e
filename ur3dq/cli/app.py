"""The `ur3dq` command group: global options, the shared settings, and one-line errors with documented exit codes."""
from __future__ import annotations

import contextlib
import dataclasses
import functools
import importlib
import io
import ipaddress
import json
import logging
import math
import os
import re
import shutil
import sys
import textwrap
import traceback
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import orjson

from ur3dq.cli.background_simulator import SimulatorError, running_simulator_host
from ur3dq.cli.library_output import own_output
from ur3dq.cli.signals import exit_code_for_interrupt, polite_signals_interrupt, signal_name, stacks_on_sigquit
from ur3dq.errors import (
    SEPARATE_NOTE,
    NotReachedError,
    RobotConnectionError,
    RobotError,
    SafetyCheckError,
    StoreError,
    UR3DQError,
    add_note,
)
from ur3dq.kinematics import MODEL_NAMES
from ur3dq.store import DEFAULT_STORE_PATH, PoseStore, store_file_role
from ur3dq.units import Units

if TYPE_CHECKING:
    from rich.console import Console

    from ur3dq.kinematics.models import URModel
    from ur3dq.robot import Robot

EXIT_OK = 0
EXIT_CANCELLED = 1
EXIT_USAGE = 2
EXIT_STORE = 3
EXIT_INPUT = 4
EXIT_NO_ROBOT = 5
EXIT_ROBOT = 6
EXIT_NOT_REACHED = 7
EXIT_SIMULATOR = 8
EXIT_INTERNAL = 70
EXIT_INTERRUPTED = 130

# First match wins: SafetyCheckError is both a RobotError and a ValueError, and is about the input.
ERROR_EXIT_CODES = (
    (StoreError, EXIT_STORE),
    (RobotConnectionError, EXIT_NO_ROBOT),
    (SafetyCheckError, EXIT_INPUT),
    (NotReachedError, EXIT_NOT_REACHED),
    (RobotError, EXIT_ROBOT),
    (ValueError, EXIT_INPUT),
    (OSError, EXIT_STORE),
)

EXIT_CODES_EPILOG = (
    f"Exit codes: {EXIT_OK} done, {EXIT_CANCELLED} cancelled at a question (or pass --yes), {EXIT_USAGE} bad command "
    f"line, {EXIT_STORE} store or file problem (store unchanged), {EXIT_INPUT} bad input (unreachable pose, limits, "
    f"NaN, out of range, failed path check), {EXIT_NO_ROBOT} no robot reachable, {EXIT_ROBOT} robot fault (stop, "
    f"program error, lost connection, timeout), {EXIT_NOT_REACHED} a move missed its pose (demo, move-to), "
    f"{EXIT_SIMULATOR} simulator would not start/stop, {EXIT_INTERNAL} internal error (UR3DQ_DEBUG=1 shows it), "
    f"{EXIT_INTERRUPTED} Ctrl-C (arm stopped; at a question: cancelled, nothing done), "
    "143/129 SIGTERM/SIGHUP (as Ctrl-C).")

# The top-level help lists the commands by what they are for (a command not named here is listed under "More").
COMMAND_SECTIONS = (
    ("Teach and run", ("record-pose", "poses", "run-poses", "jog", "move-to", "serve")),
    ("Check and export", ("check", "plot", "export-urscript", "export-urp", "import-urp")),
    ("Robot and simulator", ("status", "robot", "sim", "demo")),
    ("Kinematics", ("fk", "ik")),
)


class SectionedGroup(click.Group):
    """A click group whose help lists its commands in COMMAND_SECTIONS, each summary whole, and which imports a
    command's module when the command is first named (click's lazy loading of subcommands): `ur3dq serve` starts
    without the imports of the sixteen other commands. `command_modules` maps each name to the module that
    registers it on import."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.command_modules: dict[str, str] = {}

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*self.commands, *self.command_modules})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        module = self.command_modules.get(cmd_name)
        if cmd_name not in self.commands and module is not None:
            importlib.import_module(module)
        return super().get_command(ctx, cmd_name)

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except UR3DQError as error:
            # the values in an error's text stay SI until a person reads them: in the units this person chose
            if isinstance(ctx.obj, Settings):
                error.shown_in(ctx.obj.units)
            raise

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        commands = {name: command for name in self.list_commands(ctx)
                    if (command := self.get_command(ctx, name)) is not None}
        sections = [(title, [name for name in names if name in commands]) for title, names in COMMAND_SECTIONS]
        sections.append(("More", [name for name in commands if all(name not in n for _, n in COMMAND_SECTIONS)]))
        for title, names in sections:
            rows = [(name, commands[name].get_short_help_str(200)) for name in names if not commands[name].hidden]
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)

NO_ROBOT_HINT = ("no robot configured: name one with --host ADDRESS (or export UR3DQ_HOST=ADDRESS), "
                 "or start the embedded simulator with `ur3dq sim start`")


class Cancelled(UR3DQError):
    """The user answered no (or nothing) to a question; `deliberate` when the answer was no (not an error then)."""

    def __init__(self, message: str, deliberate: bool = False):
        super().__init__(message)
        self.deliberate = deliberate


class CancelledAtQuestion(KeyboardInterrupt):
    """Ctrl-C at a question: nothing was done; said as a cancel (not an error), exit 130 as for any Ctrl-C."""


@dataclasses.dataclass
class Settings:
    """What the global options chose, shared by every command through click's context object."""

    host: str | None
    backend: str
    model: str | None
    store_path: Path
    json: bool
    deg: bool
    mm: bool = False
    host_source: str = "default"   # where --host came from: 'option', 'environment' or 'default'

    @functools.cached_property
    def out(self) -> Console:
        """The console for stdout (make_console), made when a command first prints to it."""
        return make_console()

    @property
    def units(self) -> Units:
        """The units bare numbers are typed and values are shown in (--deg, --mm); JSON is always SI."""
        return Units(angle="deg" if self.deg else "rad", length="mm" if self.mm else "m")

    @property
    def store(self) -> PoseStore:
        """The pose store the options name."""
        return PoseStore(self.store_path)


def make_console() -> Console:
    """A console for stdout: the terminal's width (also when stdout is piped to `head` or `less` in a terminal),
    or a wide fixed width when no terminal is attached, so tables in files and logs stay whole."""
    from rich.console import Console  # here: a command that prints no table (`ur3dq serve`) starts without rich

    # COLUMNS set (as a terminal or `COLUMNS=80 ur3dq ...` does) is the width to fit, piped or not
    fixed = None if sys.stdout.isatty() or os.environ.get("COLUMNS", "").isdigit() else 160
    if fixed is not None and sys.stderr.isatty():
        fixed = os.get_terminal_size(sys.stderr.fileno()).columns
    return Console(width=fixed, highlight=False, soft_wrap=False)


def make_error_console() -> Console:
    """A console for a wide table on stderr (a check's margins under --json): the terminal's width, COLUMNS when set,
    else a wide fixed width, as make_console decides for stdout."""
    from rich.console import Console

    fixed = None if sys.stderr.isatty() or os.environ.get("COLUMNS", "").isdigit() else 160
    return Console(stderr=True, width=fixed, highlight=False)


#: A host name (RFC 1123 labels); its last label is not all digits, so a mistyped address is no name.
_LABEL = r"[a-z0-9]([a-z0-9-]{0,61}[a-z0-9])?"
_HOST_NAME = re.compile(rf"(?!.{{254}})({_LABEL}\.)*(?![0-9]+\.?$){_LABEL}\.?", re.IGNORECASE)


def is_host(text: str) -> bool:
    """Whether `text` names a host: an IPv4 or IPv6 address, or a host name (never a port, a path or spaces).

    >>> [is_host(text) for text in ("127.0.0.2", "ur3-cell.local", "::1", "127.0.0.99:30002", "127.0.0.1.5")]
    [True, True, True, False, False]
    """
    try:
        ipaddress.ip_address(text)
        return True
    except ValueError:
        return _HOST_NAME.fullmatch(text) is not None


class HostType(click.ParamType):  # type: ignore[type-arg, unused-ignore]  # generic only in newer click
    """--host (and UR3DQ_HOST): an address or a host name, refused as a usage error when it is neither."""

    name = "address"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> str:
        if not is_host(str(value)):
            self.fail(f"{value!r} is not an IP address or a host name: give it without a port (ur3dq uses the "
                      "controller's own ports)", param, ctx)
        return str(value)


HOST = HostType()


JSON_SCHEMA = 1   # the "schema" key of every --json document (docs/json.md); raised when a key changes meaning


def emit_json(data: dict[str, Any]) -> None:
    """Print `data`, one JSON object, on stdout (indent 2) with the "schema" key first (docs/json.md)."""
    click.echo(json.dumps({"schema": JSON_SCHEMA, **data}, indent=2, ensure_ascii=False))


def emit_json_list(head: dict[str, Any], key: str, items: Iterable[Any]) -> None:
    """Print the JSON object `head` with the list `items` under `key` on stdout, an item at a time.

    The layout is emit_json's (indent 2), without holding the whole text (a big store's list as one string would
    need hundreds of MB). orjson, not the stdlib: with an indent the stdlib encodes in pure Python, far slower
    (docs/performance.md). The values are the same; a small float may be spelt without an exponent
    (0.00008570859774087447 where the stdlib writes 8.570859774087447e-05).
    """
    opening = json.dumps({"schema": JSON_SCHEMA, **head, key: []}, indent=2, ensure_ascii=False)
    parts, count = [opening[:-len("[]\n}")] + "["], 0
    for item in items:
        text = orjson.dumps(item, option=orjson.OPT_INDENT_2 | orjson.OPT_SERIALIZE_NUMPY).decode()
        parts.append(("\n    " if count == 0 else ",\n    ") + text.replace("\n", "\n    "))
        count += 1
        if len(parts) >= 1000:  # write in blocks: one write per item costs more than the encoding
            click.echo("".join(parts), nl=False)
            parts = []
    parts.append("]\n}" if count == 0 else "\n  ]\n}")
    click.echo("".join(parts))


def report(settings: Settings, data: dict[str, Any], text: str) -> None:
    """What a command did: the JSON object `data` under --json, else the line `text`."""
    if settings.json:
        emit_json(data)
    else:
        click.echo(text)


def confirm(question: str, assume_yes: bool, default: bool = False) -> None:
    """Ask a yes/no question; raise Cancelled unless the answer is yes.

    Ask `question` unless `assume_yes` (Enter alone means `default`, No unless told: every motion question
    defaults to No); Cancelled if the answer is no or stdin has no answer."""
    if assume_yes:
        return
    try:
        answer = click.confirm(question, default=default, err=True)
    except click.Abort as abort:
        interrupt = abort.__context__   # click turns Ctrl-C (and SIGTERM, SIGHUP: signals.py) into Abort
        if isinstance(interrupt, KeyboardInterrupt):
            if not sys.stdin.isatty():   # a terminal's line discipline ends the question's line itself
                click.echo(err=True)
            if type(interrupt) is KeyboardInterrupt:
                raise CancelledAtQuestion(f"cancelled at {question!r} (Ctrl-C): nothing done.") from None
            raise interrupt from None
        answer = None
    if answer is None or not sys.stdin.isatty():
        click.echo(err=True)  # a piped or missing answer is not echoed: end the question's line
    if answer is None:
        raise Cancelled(f"no answer to {question!r}: pass --yes to answer yes in scripts")
    if not answer:
        raise Cancelled("answered no: nothing done.", deliberate=True)   # the question is right above


def refuse_store_file(settings: Settings, path: Path) -> None:
    """StoreError (exit 3) when `path` resolves to the pose store, its lock or any file the store owns
    (ur3dq.store.store_file_role: through symlinks and hard links too)."""
    role = store_file_role(settings.store_path, path)
    if role is not None:
        raise StoreError(f"{path} is {role} ({settings.store_path}); write to another file")


def prepare_output(settings: Settings, path: Path, yes: bool) -> None:
    """Make ready to write the file `path`: every command that writes a file calls this first.

    refuse_store_file (exit 3, nothing written), then, if `path` exists, the question before overwriting it
    (Cancelled unless answered yes or `yes`)."""
    refuse_store_file(settings, path)
    if path.exists():
        confirm(f"Overwrite {path}?", yes, default=False)


@click.group(
    cls=SectionedGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 80},
    epilog=EXIT_CODES_EPILOG,
)
@click.option("--host", envvar="UR3DQ_HOST", type=HOST, metavar="ADDRESS",
              help="Robot or URSim (env UR3DQ_HOST) [default: `ur3dq sim start`'s].")
@click.option("--backend", type=click.Choice(["rtde", "urx"]), default="rtde", metavar="rtde|urx",
              help="Client library for state and programs [default: rtde].")
@click.option("--model", type=click.Choice(MODEL_NAMES, case_sensitive=False), metavar="MODEL",
              help=f"{', '.join(MODEL_NAMES)}: checked against the controller [default: ur3].")
@click.option("--store", "store_path", envvar="UR3DQ_STORE", default=DEFAULT_STORE_PATH,
              type=click.Path(dir_okay=False, path_type=Path),
              help=f"The pose store (env UR3DQ_STORE) [default: {DEFAULT_STORE_PATH}].")
@click.option("--json", "as_json", is_flag=True, help="JSON on stdout, always SI (docs/json.md).")
@click.option("--deg", is_flag=True, help="Bare angles typed and shown in degrees.")
@click.option("--mm", is_flag=True, help="Bare lengths typed and shown in mm.")
@click.version_option(package_name="ur3dq")
@click.pass_context
def cli(ctx: click.Context, host: str | None, backend: str, model: str | None, store_path: Path, as_json: bool,
        deg: bool, mm: bool) -> None:
    """ur3dq: teach, check and run Universal Robots programs (dual-quaternion kinematics).

    \b
    A first job:
      ur3dq sim start                  # a simulated UR3 in the background
      ur3dq record-pose --name pick    # record the arm's pose (--teach: many)
      ur3dq poses offset above --from pick --z -50mm --before pick
      ur3dq poses set pick --move linear --speed 100mm/s
      ur3dq poses add-step --after pick tool-out 0 on
      ur3dq run-poses --cell cell.json # the plan's summary, then "Run?"

    Numbers may carry units (250mm/s, 60deg/s, -50mm, 5deg, 500ms); bare ones are SI,
    degrees under --deg, mm under --mm. Every option also works after the command.
    """
    source = ctx.get_parameter_source("host")
    ctx.obj = Settings(host=host or None, backend=backend, model=model.lower() if model else None,
                       store_path=store_path, json=as_json, deg=deg, mm=mm,
                       host_source="environment" if source == click.core.ParameterSource.ENVIRONMENT
                       else "option" if host else "default")


def one_line(error: BaseException) -> str:
    """The error's message and the notes that extend it (where a run stopped, how to go on) as one line."""
    text = str(error) or type(error).__name__
    notes = [note for note in getattr(error, "__notes__", None) or [] if not note.startswith(SEPARATE_NOTE)]
    return " ".join(" ".join([text, *notes]).split())


def separate_notes(error: BaseException) -> list[str]:
    """The error's notes that stand on lines of their own (errors.add_separate_note), each as one line."""
    return [" ".join(note.split()) for note in getattr(error, "__notes__", None) or []
            if note.startswith(SEPARATE_NOTE)]


def show_error_of(error: BaseException, prefix: str = "") -> None:
    """Print the error's separate notes, a line each, then its `Error: ...` line (the last line: scripts read
    it)."""
    for note in separate_notes(error):
        click.echo(note, err=True)
    show_error(prefix + one_line(error))


def exit_code_for(error: BaseException) -> int:
    """The documented exit code of an error raised by a command."""
    if isinstance(error, Cancelled):
        return EXIT_CANCELLED
    if isinstance(error, SimulatorError):
        return EXIT_SIMULATOR
    for kind, code in ERROR_EXIT_CODES:
        if isinstance(error, kind):
            return code
    return EXIT_INTERNAL


# urx logs a warning each time its parser retries on a 3.5+ controller's packets; with no handler of ours Python
# would print those on stderr around the one-line errors.
CLIENT_LIBRARY_LOGGERS = ("urx", "ursecmon")


def quiet_client_libraries(debug: bool) -> None:
    """Let only errors of the client libraries' loggers through, or leave their levels alone when `debug`."""
    for name in CLIENT_LIBRARY_LOGGERS:
        logging.getLogger(name).setLevel(logging.NOTSET if debug else logging.ERROR)


#: Whether this process is the `ur3dq` command itself (main() ran), not a program that calls the CLI's functions.
_OWN_PROCESS = False


#: Up to this many poses on an arm of nominal geometry, a command's kinematics kernels run as Python in the
#: `ur3dq` process (solving_poses).
FEW_POSES = 20


def python_kernels_pay(count: int, model: URModel | None = None) -> bool:
    """Whether solving or planning `count` poses on `model` costs less CPU with the kinematics kernels run as Python
    than loading numba and the compiled kernels' cache (about half a second; docs/performance.md): for one pose, and
    for up to FEW_POSES on an arm of nominal geometry. A calibrated arm's path check runs Newton steps at every
    sample, so for more than one pose it keeps the compiled kernels."""
    return count <= 1 or (count <= FEW_POSES and model is not None and model.dh.is_nominal_structure())


def solving_poses(count: int, model: URModel | None = None) -> None:
    """Say how many poses the command solves or plans, on `model`; where python_kernels_pay, in the `ur3dq` process
    itself its kinematics kernels then run as the Python they are. Call it before the command's first kinematics
    call: it uses numba's own switch, NUMBA_DISABLE_JIT, which the kernels read when their modules are first
    imported (NUMBA_DISABLE_JIT=0 keeps them compiled). A program that calls the CLI in its own process keeps what
    it has."""
    if _OWN_PROCESS and python_kernels_pay(count, model) and "numba" not in sys.modules:
        os.environ.setdefault("NUMBA_DISABLE_JIT", "1")


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of the `ur3dq` command: run the CLI; any error becomes `Error: ...` on stderr and an exit code."""
    global _OWN_PROCESS
    _OWN_PROCESS = True
    quiet_client_libraries(bool(os.environ.get("UR3DQ_DEBUG")))
    stacks_on_sigquit()
    try:
        with polite_signals_interrupt():
            code = cli.main(args=argv, prog_name="ur3dq", standalone_mode=False)
    except click.ClickException as error:
        show_click_error(error)
        code = error.exit_code
    except click.Abort as error:  # click turns Ctrl-C and end-of-input into Abort
        if isinstance(error.__cause__, KeyboardInterrupt):
            code = _report_interrupt(error.__cause__)
        else:
            click.echo("Error: cancelled (no answer on stdin: pass --yes in scripts)", err=True)
            code = EXIT_CANCELLED
    except KeyboardInterrupt as interrupt:
        code = _report_interrupt(interrupt)
    except Cancelled as cancelled:
        # a deliberate "no" is the user's choice, not an error: said plainly; a missing answer stays an error
        if cancelled.deliberate:
            click.echo(str(cancelled)[0].upper() + str(cancelled)[1:], err=True)
        else:
            show_error_of(cancelled)
        code = EXIT_CANCELLED
    except (UR3DQError, ValueError, OSError) as error:
        show_error_of(error)
        code = exit_code_for(error)
    except Exception as error:  # a bug: still one line, the traceback on request
        if os.environ.get("UR3DQ_DEBUG"):
            raise
        add_note(error, "(set UR3DQ_DEBUG=1 for the traceback)")
        show_error_of(error, prefix=f"internal error ({type(error).__name__}): ")
        code = EXIT_INTERNAL
    sys.exit(code if isinstance(code, int) else EXIT_OK)


def show_error(text: str) -> None:
    """Print `Error: text` on stderr: one line for scripts and logs; on a terminal, wrapped between words to its
    width (a terminal would cut a long line anywhere, mid-word)."""
    line = f"Error: {text}"
    if sys.stderr.isatty():
        width = shutil.get_terminal_size().columns
        line = textwrap.fill(line, width=max(40, width - 1), subsequent_indent="  ", break_long_words=False,
                             break_on_hyphens=False)
    click.echo(line, err=True)


def show_click_error(error: click.ClickException) -> None:
    """Print a usage or option error as click does (usage, help hint), its `Error: ...` line as show_error does."""
    shown = io.StringIO()
    error.show(file=shown)
    text, last = shown.getvalue(), f"Error: {error.format_message()}\n"
    if text.endswith(last):
        head = text[:-len(last)]
        if head:
            click.echo(head, err=True, nl=False)
        show_error(error.format_message())
    else:   # a ClickException subclass that shows itself its own way
        click.echo(text, err=True, nl=False)


def _report_interrupt(interrupt: BaseException) -> int:
    """Print the one-line interruption error (with its notes: the step a run was in, how to go on); its exit code
    (130 for Ctrl-C, 128 + n for signal n)."""
    if os.environ.get("UR3DQ_DEBUG"):   # where the interrupt landed
        traceback.print_exception(interrupt)
    if isinstance(interrupt, CancelledAtQuestion):   # the user's choice, said plainly as a "no" is
        click.echo(str(interrupt)[0].upper() + str(interrupt)[1:], err=True)
        return exit_code_for_interrupt(interrupt)
    name = signal_name(interrupt)
    text = f"interrupted by {name}" if name else str(interrupt) or "interrupted"
    for note in separate_notes(interrupt):
        click.echo(note, err=True)
    notes = [note for note in getattr(interrupt, "__notes__", None) or [] if not note.startswith(SEPARATE_NOTE)]
    show_error(" ".join(" ".join([text, *notes]).split()))
    return exit_code_for_interrupt(interrupt)


@contextlib.contextmanager
def robot_session(settings: Settings, max_joint_travel: float = math.pi) -> Iterator[Robot]:
    """A connected Robot for the command, closed when the block ends.

    A connected Robot for the host the options (or the running embedded simulator) name; closed afterwards.
    `max_joint_travel` (rad, the driver's default bound unless given) goes to the driver's connect."""
    from ur3dq.robot import connect  # the driver loads both client libraries: only for robot commands

    simulator = running_simulator_host()
    host = settings.host or simulator
    if not host:
        raise RobotConnectionError(NO_ROBOT_HINT)
    with own_output():
        try:
            robot = connect(host, backend=settings.backend, model=settings.model, max_joint_travel=max_joint_travel)
        except (OSError, RobotConnectionError) as error:
            reason = (error.strerror or str(error)) if isinstance(error, OSError) else str(error)
            raise RobotConnectionError(f"{reason.rstrip('.')}; {unreachable_hint(settings, host, simulator)}"
                                       ) from None
        with robot:
            yield robot


def unreachable_hint(settings: Settings, host: str, simulator: str | None) -> str:
    """What to do when `host` refuses: whether ur3dq's own simulator runs, and where, and how to point at it."""
    given = {"environment": "UR3DQ_HOST", "option": "--host"}.get(settings.host_source)
    if simulator and simulator != host:
        fix = "`unset UR3DQ_HOST`" if given == "UR3DQ_HOST" else "leave out --host"
        return (f"{given or 'the host'} names {host}, but `ur3dq sim start`'s simulator runs on {simulator}: "
                f"{fix} (or export UR3DQ_HOST={simulator})")
    if simulator == host:
        return (f"the ur3dq simulator recorded on {host} does not answer: `ur3dq sim stop`, then `ur3dq sim start`")
    return (f"no ur3dq simulator is running: check {given or '--host or UR3DQ_HOST'} and that the robot is on, or "
            "start the simulator with `ur3dq sim start`")
