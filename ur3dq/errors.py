"""Every exception ur3dq raises, in one hierarchy so callers can catch by kind.

Each message is meant to be shown to a person as one line: it names the thing that is wrong and why.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TypeVar

from ur3dq.units import Measured, Units, Wording, worded

AnError = TypeVar("AnError", bound="UR3DQError")


class UR3DQError(Exception):
    """Base class of every ur3dq error.

    A message that holds physical values keeps them as :class:`~ur3dq.units.Measured` placeholders (``{0}``,
    ``{1}``, ... in its text, ``units.worded``), so that a user interface can show them in its user's units
    (`shown_in`); until then, and for a program that catches the error, they read in SI (a `fine` value in mm or °).

    >>> from ur3dq.units import LENGTH, Measured, Units
    >>> error = UR3DQError("too far by {0}", measured=[Measured(0.0123, LENGTH)])
    >>> str(error), str(error.prefixed("pose 'a': ").shown_in(Units(length="mm")))
    ('too far by 0.0123 m', "pose 'a': too far by 12.3 mm")
    """

    def __init__(self, *args: object, measured: Sequence[Measured] = ()) -> None:
        super().__init__(*args)
        self.measured = tuple(measured)
        self.units = Units()

    def __str__(self) -> str:
        text = super().__str__()
        if not self.measured:
            return text
        return worded(text, self.measured, self.units)

    @classmethod
    def from_wording(cls: type[AnError], text: str, measured: Sequence[Measured]) -> AnError:
        """An error of this kind whose message is the ``units.worded`` `text` with its `measured` values (with none,
        `text`'s doubled braces read as single ones)."""
        return cls(text, measured=measured) if measured else cls(worded(text, ()))

    def wording(self) -> Wording:
        """(the message as a ``units.worded`` text, its values): to carry it into another message."""
        text = Exception.__str__(self)
        return (text if self.measured else literal(text)), self.measured

    def shown_in(self: AnError, units: Units) -> AnError:
        """This error, its values from now on read in `units`; returns it."""
        self.units = units
        return self

    def prefixed(self: AnError, prefix: str) -> AnError:
        """A new error of this kind whose message is `prefix` and then this one's (its values kept as values).

        For the kinds built from a message alone, as most are."""
        if not self.measured:
            return type(self)(prefix + Exception.__str__(self))
        return type(self)(literal(prefix) + Exception.__str__(self), measured=self.measured)


class UnreachablePoseError(UR3DQError, ValueError):
    """No joint configuration reaches the pose (too far, too close, wrist singular, outside limits)."""


class JointLimitError(UR3DQError, ValueError):
    """A joint target lies outside the model's joint limits."""


class StoreError(UR3DQError):
    """The pose store cannot be read or written; the message names file:line where it can."""


class RobotError(UR3DQError):
    """Something went wrong talking to, or moving, the robot."""


class RobotConnectionError(RobotError):
    """The controller could not be reached."""


class ConnectionLostError(RobotError):
    """The connection dropped or froze during an operation."""


class ProtectiveStopError(RobotError):
    """The controller is in (or entered) a protective stop."""


class EmergencyStopError(RobotError):
    """The controller is in (or entered) an emergency stop."""


class ProgramError(RobotError):
    """The controller reported a URScript compile or runtime error, or stopped the program."""


class MotionTimeoutError(RobotError):
    """A motion did not finish within the time derived from its own expected duration."""


class NotReachedError(RobotError):
    """A motion ended, but away from where it aimed the TCP (beyond the command's tolerance)."""


class SafetyCheckError(RobotError, ValueError):
    """A motion was refused before sending: it failed a safety check (limits, travel, FK consistency)."""


class InvalidStateError(RobotError):
    """The controller sent state that cannot be true (not finite, implausible magnitude, unknown mode)."""


# How the driver's errors tell a person to clear what blocks a motion: the command line's and Python's ways. A user
# interface with buttons of its own shows its own words instead (ur3dq.screen.views.error_text).
UNLOCK_HINT = "(`ur3dq robot unlock`; in Python robot.unlock_protective_stop())"
POWER_ON_HINT = ("(`ur3dq robot power-on`, `ur3dq robot brake-release`; in Python robot.power_on(), "
                 "robot.brake_release())")


def literal(text: str) -> str:
    """`text` (a name, a controller's message) as it must stand in the text of an error with measured values: braces
    doubled, so that it is not read as a placeholder."""
    return text.replace("{", "{{").replace("}", "}}")


def add_note(error: BaseException, note: str) -> None:
    """Attach `note` to `error` as Python 3.11's BaseException.add_note does, on Python 3.10 too (there the notes
    are kept in `__notes__` for ur3dq's own error lines, and tracebacks do not show them).

    >>> error = ValueError("bad")
    >>> add_note(error, "(during step 2)")
    >>> error.__notes__
    ['(during step 2)']
    """
    notes = getattr(error, "__notes__", None)
    if notes is None:
        notes = []
        error.__notes__ = notes   # type: ignore[attr-defined]
    notes.append(note)


#: How a note that stands on a line of its own begins: the command line prints such notes before the error's one
#: line instead of as a clause of it (ur3dq.cli.app.separate_notes).
SEPARATE_NOTE = "note: "


def add_separate_note(error: BaseException, note: str) -> None:
    """Attach `note` to `error` as a fact of its own (a further failure while handling it, say), which the command
    line prints on its own line before the error's line.

    >>> error = ValueError("the connection dropped")
    >>> add_separate_note(error, "sending stopj after this error also failed")
    >>> error.__notes__
    ['note: sending stopj after this error also failed']
    """
    add_note(error, SEPARATE_NOTE + note)
