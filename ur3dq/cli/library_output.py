"""Keep ur_rtde's own console text off ur3dq's screen.

ur_rtde's C++ threads write diagnostics straight to the process's file descriptors 1 and 2, e.g.
`RTDEReceiveInterface boost system Exception: (asio.misc:2) End of file` when a connection drops. That text sits in
the middle of a teach session or a table, names classes the CLI user never met, and would corrupt `--json` output.
During a robot session the CLI routes descriptors 1 and 2 through a pipe read by a thread: a ur_rtde line becomes at
most one ur3dq note (chatter is dropped), any other line passes through unchanged. Python's own `sys.stdout` /
`sys.stderr` are pointed at the original descriptors meanwhile, so ur3dq's output never waits on the thread.
`UR3DQ_DEBUG=1` passes everything through as it came.
"""
from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from collections.abc import Iterator
from typing import TextIO

# ur_rtde 1.6's console lines (from the strings of librtde): what each means for the user, or None for chatter
# that needs no action (realtime-kernel hints, reconnect progress; the driver reports failed reconnects itself).
DROPPED_NOTE = "note: the connection to the controller dropped; ur3dq reconnects before its next step"
LIBRARY_LINES = (
    ("boost system Exception", DROPPED_NOTE),
    ("closed the connection", DROPPED_NOTE),
    ("Lost connection to robot", DROPPED_NOTE),
    ("write: Broken pipe", DROPPED_NOTE),   # RTDEIOInterface (the heartbeat's inputs) writing to a dropped socket
    ("Could not receive data from robot", DROPPED_NOTE),
    ("is disconnected, reconnecting", DROPPED_NOTE),
    ("Reconnecting...", None),
    ("Successfully reconnected", None),
    ("realtime", None),
    ("Warning! ", None),
    ("Error: Could not connect to: ", None),  # the driver raises RobotConnectionError with its own words
)
LIBRARY_PREFIXES = ("RTDEReceiveInterface", "RTDEControlInterface", "RTDEIOInterface", "DashboardClient", "RTDE",
                    "Reconnecting", "Warning! ", "Error: Could not connect to: ", "write: Broken pipe")
NOTE_REPEAT_PERIOD = 2.0  # one drop makes several threads print; the user needs one note


def translated(line: str) -> str | None:
    """What the user sees for one line a client library printed.

    What the user sees for one console line (without its newline): a ur_rtde line becomes its note or None
    (nothing); any other line is returned as it is."""
    if not line.startswith(LIBRARY_PREFIXES):
        return line
    for fragment, note in LIBRARY_LINES:
        if fragment in line:
            return note
    return None  # another ur_rtde line: the driver says what matters in its own errors


class _Filter:
    """A pipe in place of descriptor `fd`; a thread copies translated lines to the original descriptor."""

    def __init__(self, fd: int, last_notes: dict[str, float]) -> None:
        self.fd = fd
        self.original = os.dup(fd)
        self._last_notes = last_notes
        read_end, write_end = os.pipe()
        os.dup2(write_end, fd)
        os.close(write_end)
        self._thread = threading.Thread(target=self._copy, args=(read_end,), name=f"ur3dq-output-{fd}",
                                        daemon=True)
        self._thread.start()

    def _copy(self, read_end: int) -> None:
        pending = b""
        with os.fdopen(read_end, "rb", buffering=0) as pipe:
            while chunk := pipe.read(65536):
                pending += chunk
                *lines, pending = pending.split(b"\n")
                for line in lines:
                    self._emit(line.decode("utf-8", "replace"))
        if pending:
            self._emit(pending.decode("utf-8", "replace"))

    def _emit(self, line: str) -> None:
        text = translated(line)
        if text is None:
            return
        if text != line:  # a note: once per period, however many threads reported the same drop
            now = time.monotonic()
            if now - self._last_notes.get(text, -NOTE_REPEAT_PERIOD) < NOTE_REPEAT_PERIOD:
                return
            self._last_notes[text] = now
        try:
            os.write(self.original, (text + "\n").encode())
        except OSError:  # restored and closed while a child process still held the pipe: nobody to tell
            pass

    def restore(self) -> None:
        """Put the original descriptor back and let the thread copy what was still in the pipe."""
        os.dup2(self.original, self.fd)  # closes the pipe's last write end (unless a child process holds it)
        self._thread.join(1.0)
        os.close(self.original)


def _python_stream_on(fd: int, stream: TextIO) -> TextIO:
    """A text stream like `stream` writing to descriptor `fd` (left open: the filter owns it)."""
    return open(fd, "w", buffering=1, encoding=stream.encoding, errors=stream.errors, closefd=False)


def _real_descriptor(stream: TextIO, fd: int) -> bool:
    try:
        return stream.fileno() == fd
    except (AttributeError, OSError, ValueError):  # a test runner's capture: no descriptor of its own
        return False


@contextlib.contextmanager
def own_output() -> Iterator[None]:
    """While active, ur_rtde's console lines on descriptors 1 and 2 are translated (see the module docstring).

    Does nothing under UR3DQ_DEBUG, or when sys.stdout/sys.stderr are not the process's descriptors 1 and 2
    (click's test runner, pytest's capture): there the C-level text was never the user's screen.
    """
    if os.environ.get("UR3DQ_DEBUG") or not (_real_descriptor(sys.stdout, 1) and _real_descriptor(sys.stderr, 2)):
        yield
        return
    saved_streams = sys.stdout, sys.stderr
    for stream in saved_streams:
        stream.flush()
    last_notes: dict[str, float] = {}   # note -> time.monotonic() it was last shown
    filters = [_Filter(1, last_notes), _Filter(2, last_notes)]
    sys.stdout = _python_stream_on(filters[0].original, saved_streams[0])
    sys.stderr = _python_stream_on(filters[1].original, saved_streams[1])
    try:
        yield
    finally:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        sys.stdout, sys.stderr = saved_streams
        for output_filter in filters:
            output_filter.restore()
