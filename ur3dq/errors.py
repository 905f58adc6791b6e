"""Every exception ur3dq raises, in one hierarchy so callers can catch by kind.

Each message is meant to be shown to a person as one line: it names the thing that is wrong and why.
"""


class UR3DQError(Exception):
    """Base class of every ur3dq error."""


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


class SafetyCheckError(RobotError, ValueError):
    """A motion was refused before sending: it failed a safety check (limits, travel, FK consistency)."""


class InvalidStateError(RobotError):
    """The controller sent state that cannot be true (not finite, implausible magnitude, unknown mode)."""


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
