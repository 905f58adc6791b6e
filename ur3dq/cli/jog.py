"""`ur3dq jog`: move the arm with the keyboard, one bounded step per key press, on a full screen of 80×24.

Every key press that moves the arm is one jog step (ur3dq.robot.Robot.jog): a joint, or a TCP axis of the base or
tool frame, by the chosen step (0.1, 1 or 10 mm or degrees) at the chosen share of the jog's speed limit, checked
like any motion and watched to its end before the next key is read; keys typed meanwhile are dropped, so no motion
outlives its key and nothing moves without one. The joints and the TCP are shown live; `r` records the pose into
the store, `q` quits.
"""
from __future__ import annotations

import contextlib
import dataclasses
import sys
import textwrap
from collections.abc import Iterator
from typing import Any, TextIO

import click
from rich.console import Console
from rich.markup import escape

from ur3dq.cli.app import Settings, cli, emit_json, robot_session
from ur3dq.cli.display import count_text
from ur3dq.cli.operator_controls import cbreak, read_key
from ur3dq.cli.options import display_options
from ur3dq.cli.program_workflow import same_spot_as
from ur3dq.cli.run_session import replay_stop, where_text
from ur3dq.errors import MotionTimeoutError, ProgramError, RobotError, StoreError, UR3DQError, add_note
from ur3dq.pose import next_free_name
from ur3dq.replay import read_pose
from ur3dq.robot import jog_steps
from ur3dq.units import ANGLE, ANGULAR_SPEED, LENGTH, LINEAR_SPEED, Kind, Units, show, to_display

MODES = ("joint", "TCP base", "TCP tool")
STEP_SIZES = jog_steps.STEP_SIZES       # mm, or degrees
SPEED_SHARES = (0.1, 0.25, 0.5, 1.0)     # of the jog's speed limits (jog_steps.MAX_JOINT_SPEED, MAX_TCP_SPEED)
SCREEN_UNITS = Units(angle="deg", length="mm")   # the pendant's units
WIDTH, HEIGHT = 80, 24
REFRESH = 0.1   # s between two redraws while no key comes (the live joints and TCP)
PLUS_KEYS = ("+", "=", "\x1b[A", "\x1b[C")     # + (= unshifted), arrow up, arrow right
MINUS_KEYS = ("-", "_", "\x1b[B", "\x1b[D")


@dataclasses.dataclass
class JogScreen:
    """What the jog screen shows and the keys change: mode, selected axis (0-5), step size, speed share, and the
    last thing that happened."""

    mode: int = 0
    axis: int = 0
    step: int = 1
    speed: int = 1
    message: str = "Ready. 1-6 pick an axis, + or - move it one step."
    tried: int = 0                     # jog steps asked for, and of those not moved or stopped short
    failed: int = 0
    last_failure: str = ""
    moving: str | None = None          # the step running now ("J1+ by 1 °"), for where an interrupt stopped it

    @property
    def axes(self) -> tuple[str, ...]:
        return jog_steps.JOINT_AXES if self.mode == 0 else jog_steps.TCP_AXES

    def jog_step(self, direction: int) -> jog_steps.JogStep:
        """The JogStep of a + (1) or - (-1) key in the current mode, axis and step size."""
        frame = "tool" if self.mode == 2 else "base"
        return jog_steps.step_of(self.axes[self.axis], direction, STEP_SIZES[self.step], frame)

    def speed_for(self, step: jog_steps.JogStep) -> float:
        """The step's speed: the chosen share of the jog's joint (rad/s) or TCP (m/s, rad/s) speed limit."""
        return SPEED_SHARES[self.speed] * step.top_speed


def screen_lines(screen: JogScreen, title: str, joints: Any, tcp: Any, store: str) -> list[str]:
    """The 24 lines (each at most 80 columns) of the jog screen for joints (rad) and TCP pose vector (m, rad)."""
    angle = [to_display(float(value), ANGLE, SCREEN_UNITS) for value in joints]
    position = [to_display(float(value), LENGTH, SCREEN_UNITS) for value in tcp[:3]]
    rotation = [to_display(float(value), ANGLE, SCREEN_UNITS) for value in tcp[3:]]
    step = screen.jog_step(1)
    unit = "mm" if step.linear else "°"
    selected = "  ".join(f"[{name}]" if index == screen.axis else f" {name} "
                         for index, name in enumerate(screen.axes))
    lines = [
        f"ur3dq jog - {title}"[:WIDTH],
        "",
        f"Mode   {MODES[screen.mode]:<9}  m: joint / TCP base / TCP tool",
        f"Step   {STEP_SIZES[screen.step]:g} {unit:<6}  s: 0.1 / 1 / 10 mm or degrees",
        f"Speed  {SPEED_SHARES[screen.speed]:.0%} of the jog limit  < >: slower / faster "
        f"({show(screen.speed_for(step), _speed_kind(step), SCREEN_UNITS, 1)})",
        "",
        "Joints °  " + " ".join(f"J{i + 1} {value:+7.2f}" for i, value in enumerate(angle)),
        "TCP mm    " + " ".join(f"{name} {value:+8.1f}" for name, value in zip("XYZ", position, strict=True)),
        "TCP °     " + " ".join(f"{name} {value:+8.2f}" for name, value in zip(("RX", "RY", "RZ"), rotation,
                                                                              strict=True)),
        "",
        f"Axis   {selected}",
        "       1-6 pick an axis; + or up, - or down: one step (a key press, one step)",
        "",
        f"r  record this pose into {store}"[:WIDTH],
        "q  quit",
        "",
    ]
    lines += textwrap.wrap(screen.message, WIDTH)[:HEIGHT - 1 - len(lines)]   # a refusal's fix is at its end
    return [line[:WIDTH] for line in lines] + [""] * (HEIGHT - 1 - len(lines))


def _speed_kind(step: jog_steps.JogStep) -> Kind:
    return LINEAR_SPEED if step.linear else ANGULAR_SPEED


@contextlib.contextmanager
def full_screen(stream: TextIO) -> Iterator[None]:
    """The terminal's alternate screen with the cursor hidden while inside; the old screen comes back after."""
    stream.write("\x1b[?1049h\x1b[?25l")
    stream.flush()
    try:
        yield
    finally:
        stream.write("\x1b[?25h\x1b[?1049l")
        stream.flush()


def draw(stream: TextIO, lines: list[str]) -> None:
    """Redraw the screen with `lines` (home, each line cleared to its end)."""
    stream.write("\x1b[H" + "".join(f"{line}\x1b[K\r\n" for line in lines[:-1]) + lines[-1] + "\x1b[K")
    stream.flush()


@cli.command("jog", short_help="Move the arm with the keyboard, one checked step per key.")
@display_options
@click.pass_obj
def jog(settings: Settings) -> None:
    """Move the arm with the keyboard, one small checked step per key press (a terminal of 80×24 or more).

    \b
    Keys:
      m        mode: joint, TCP in the base frame, TCP in the tool frame
      1-6      the axis: J1-J6, or X Y Z RX RY RZ of the TCP
      + / -    one step along it (or arrow up / down); no key, no motion
      s        step size 0.1, 1 or 10 (mm, or degrees)
      < / >    speed: 10, 25, 50 or 100 % of the jog's limit (0.5 rad/s, 100 mm/s)
      r        record the arm's pose into the store (named pose-N)
      q        quit

    Each step is checked like any motion (joint limits, reach, singularities, the path) and runs to its end
    before the next key is read. Ctrl-C stops the arm. Without a terminal the keys are read from stdin (a script:
    `echo 2+rq | ur3dq jog`), each outcome printed as a line. To move the arm to a recorded pose: `ur3dq move-to`.
    """
    fd = sys.stdin.fileno()
    drawn = sys.stdout.isatty() and not settings.json
    recorded: list[str] = []
    with robot_session(settings) as robot:
        screen = JogScreen()
        title = f"{robot.model_name} at {robot.host}"
        keys = cbreak(fd) if sys.stdin.isatty() else contextlib.nullcontext()
        try:
            with keys, full_screen(sys.stdout) if drawn else contextlib.nullcontext():
                while True:
                    if drawn:
                        status = robot.state()
                        draw(sys.stdout, screen_lines(screen, title, status.joints, status.tcp_pose,
                                                      str(settings.store_path)))
                    key = read_key(fd, REFRESH)
                    if key in ("q", ""):
                        break
                    if key is not None:
                        _act(settings, robot, screen, key, recorded)
                        if not drawn:
                            click.echo(screen.message, err=True)
        except KeyboardInterrupt as interrupt:   # after the screen is restored: where the arm came to rest
            _say_where_it_rests(settings, robot, screen, interrupt)
            raise
    if settings.json:
        emit_json({"recorded": recorded, "store": str(settings.store_path)})
    else:
        click.echo("Jog ended." + (f" Recorded {', '.join(recorded)}." if recorded else ""))
    if screen.failed and not drawn:   # a script's steps: its exit says whether they all moved
        raise RobotError(f"{count_text(screen.failed, 'jog step')} of {screen.tried} did not move as asked; the "
                         f"last: {screen.last_failure}")


def _say_where_it_rests(settings: Settings, robot: Any, screen: JogScreen, interrupt: BaseException) -> None:
    """Ctrl-C or SIGTERM during a jog: say the step it stopped (if one was running) and where the arm came to rest,
    as run-poses does, and name the step on the error's line."""
    step = screen.moving
    stop = replay_stop(robot, screen.tried, step or "")
    err = Console(stderr=True, highlight=False)
    err.print(escape(f"Stopped during the jog step {step}." if step else "Stopped between jog steps."),
              soft_wrap=True)
    err.print(where_text(stop, settings.deg), soft_wrap=True)
    add_note(interrupt, f"(during the jog step {step})" if step else "(between jog steps)")


def _act(settings: Settings, robot: Any, screen: JogScreen, key: str, recorded: list[str]) -> None:
    """Carry out one key on `screen` and `robot` (a recorded pose's name goes into `recorded`)."""
    if key in ("1", "2", "3", "4", "5", "6"):
        screen.axis, screen.message = int(key) - 1, f"Axis {screen.axes[int(key) - 1]}."
    elif key == "m":
        screen.mode = (screen.mode + 1) % len(MODES)
        screen.message = f"Mode {MODES[screen.mode]}: axes {' '.join(screen.axes)}."
    elif key == "s":
        screen.step = (screen.step + 1) % len(STEP_SIZES)
        screen.message = f"Step {STEP_SIZES[screen.step]:g}."
    elif key in ("<", ",", ">", "."):
        change = 1 if key in (">", ".") else -1
        screen.speed = min(max(screen.speed + change, 0), len(SPEED_SHARES) - 1)
        screen.message = f"Speed {SPEED_SHARES[screen.speed]:.0%} of the jog limit."
    elif key in PLUS_KEYS or key in MINUS_KEYS:
        _step(robot, screen, 1 if key in PLUS_KEYS else -1)
    elif key == "r":
        screen.message = _record(settings, robot, recorded)
    else:
        screen.message = f"Key {key!r} does nothing here: see the keys (q quits)."


def _step(robot: Any, screen: JogScreen, direction: int) -> None:
    """One jog step, run to its end; then the keys typed meanwhile are dropped."""
    step = screen.jog_step(direction)
    unit = "mm" if step.linear else "°"
    screen.tried += 1
    screen.moving = f"{step.label} by {STEP_SIZES[screen.step]:g} {unit}"
    try:
        robot.jog(step, screen.speed_for(step))
        screen.message = f"Moved {screen.moving}."
    except (ProgramError, MotionTimeoutError) as error:   # it ran and stopped short: the same key goes on
        screen.message = f"{step.label} stopped short: {' '.join(str(error).split())}; the key again goes on"
    except (ValueError, RobotError) as error:   # refused (a limit, reach, the path) or stopped: say so, go on
        if isinstance(error, UR3DQError):
            error.shown_in(SCREEN_UNITS)   # the values of a refusal in the screen's units
        screen.message = f"{step.label} not moved: {' '.join(str(error).split())}"
    else:
        screen.moving = None
        return
    finally:
        _drop_typed_ahead(sys.stdin.fileno())
    screen.failed, screen.last_failure, screen.moving = screen.failed + 1, screen.message, None


def _record(settings: Settings, robot: Any, recorded: list[str]) -> str:
    """Record the arm's pose into the store as pose-N (its name appended to `recorded`); the line saying so, or
    why not."""
    try:
        steps = settings.store.load_program()
        pose = read_pose(robot, next_free_name("pose", [step.name for step in steps]))
        stored = settings.store.add(pose, number_if_taken=True)
    except (StoreError, ValueError, RobotError) as error:
        return f"Not recorded: {' '.join(str(error).split())}"
    recorded.append(stored.name)
    twin = same_spot_as(stored, steps)
    return f"Recorded {stored.name!r}" + (f" (the same spot as {twin!r})." if twin else ".")


def _drop_typed_ahead(fd: int) -> None:
    """Discard the keys typed while a step ran (a held key repeats): the next step waits for a new key."""
    import termios

    with contextlib.suppress(termios.error, OSError):
        termios.tcflush(fd, termios.TCIFLUSH)
