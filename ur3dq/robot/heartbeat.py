"""The heartbeat that stops the arm when ur3dq no longer can: killed, crashed, hung or cut off.

Ctrl-C, SIGTERM and SIGHUP reach ur3dq, which sends `stopj`; kill -9, a crash or a hang do not. For those the
controller itself must stop: every motion program ur3dq sends first arms the controller's RTDE input watchdog
(URScript `rtde_set_watchdog(variable, min_frequency, "stop")`, UR script manual) on HEARTBEAT_REGISTER, and the
thread here writes a new value to that register every PERIOD over RTDE (ur3dq.robot.rtde_inputs). When the
values stop coming, the controller stops the program, and with it the arm, 1/WATCHDOG_FREQUENCY s after the
last one. The watchdog is removed when the program ends, so nothing changes between motions.

The driver starts the heartbeat with the first program it sends (a motion, freedrive, a jog step) on this client's
RTDE inputs (ur3dq.robot.rtde_inputs: HEARTBEAT_REGISTER and the digital outputs); another RTDE client
holding them (a second ur3dq moving the same arm, a user's own RTDEIOInterface) makes the controller refuse them,
and the program is refused with a line that says so.
"""
from __future__ import annotations

import threading
import time

from ur3dq.errors import RobotConnectionError
from ur3dq.robot.rtde_inputs import RTDEInputs
from ur3dq.urscript import first_statement_added, rtde_set_watchdog_statement

#: The RTDE input integer register the heartbeat counts on (in ur_rtde's lower range, 18–22: a user's
#: RTDEIOInterface on the same arm is refused while ur3dq holds it, and the other way round).
HEARTBEAT_REGISTER = 20
#: The controller stops a motion program this long (1/frequency) after the last heartbeat: 100 ms. The thread is
#: Python, so anything holding the GIL longer than that stops the arm: ur_rtde's RTDEReceiveInterface destructor
#: holds it for 0.5 s, which is why the driver destroys that interface itself when it closes (rtde_backend.close).
#: A motion stopped this way says so in its ProgramError (Heartbeat.longest_gap). The gaps seen under load are in
#: docs/performance.md.
WATCHDOG_FREQUENCY = 10.0
#: Seconds between heartbeats: twenty per watchdog period, so a loaded machine that delays a few is not a stop.
PERIOD = 0.01


def watchdog_statement() -> str:
    """The URScript statement that arms the heartbeat watchdog: a motion program's first line."""
    return rtde_set_watchdog_statement(f"input_int_register_{HEARTBEAT_REGISTER}", WATCHDOG_FREQUENCY, "stop")


def armed(program: str, name: str) -> str:
    """`program` (URScript text holding `def name():`) with the watchdog armed as its first statement."""
    return first_statement_added(program, name, watchdog_statement())


class Heartbeat:
    """A thread writing a counter to HEARTBEAT_REGISTER of the RTDE `inputs` every PERIOD s until `close()`.

    `alive` turns False when a write fails (the connection dropped): a program must not start then, since nothing
    would stop it if ur3dq died. Closing the heartbeat closes `inputs`. `silence()` is how ur3dq stops a program it
    has lost sight of: no more beats, so the controller's watchdog stops the program at the controller's own stop.
    """

    def __init__(self, inputs: RTDEInputs) -> None:
        self.inputs = inputs
        self.host = inputs.host
        self._last_write: float | None = None   # monotonic time of the last write that went through
        self._watched_from = 0.0     # see watch_gaps
        self._longest_gap = 0.0
        self._silenced = False
        self._start()

    def _start(self) -> None:
        self._stop = threading.Event()
        self._failed = threading.Event()
        written = threading.Event()
        self._thread = threading.Thread(target=self._beat, args=(self._stop, self._failed, written),
                                        name="ur3dq-heartbeat", daemon=True)
        self._thread.start()
        # The first value is on the wire before any program can arm the watchdog on it.
        written.wait(1.0)

    def restart(self) -> None:
        """Reconnect after a failed write (the stream dropped) and beat again; RobotConnectionError if refused."""
        self._halt()
        if not self.inputs.reconnect():
            raise RobotConnectionError(f"the heartbeat to {self.host}:30004 cannot reconnect")
        self._silenced = False
        self._start()

    def silence(self) -> None:
        """Stop the beats and disconnect, so that the controller's watchdog stops the program armed on them.

        The controller stops that program 1/WATCHDOG_FREQUENCY s after the last beat, at its own stop, whether or
        not this connection still reached it: how ur3dq stops a program once it has lost a connection to the
        controller. `silenced` stays True until restart(), which must not come while that program may still run
        (a new beat would keep it going)."""
        self._silenced = True
        self.close()

    @property
    def silenced(self) -> bool:
        """True from silence() to the next restart()."""
        return self._silenced

    def watch_gaps(self) -> None:
        """From now on, measure the longest time without a write (longest_gap): call it when a motion is sent."""
        self._watched_from, self._longest_gap = time.monotonic(), 0.0

    def longest_gap(self) -> float:
        """The longest time (s) without a heartbeat since watch_gaps.

        The longest time (s) since watch_gaps without a write, the time since the last write included. At
        1/WATCHDOG_FREQUENCY or more the controller's watchdog may have stopped the program: the beat thread was
        held back (a starved CPU, or another thread holding the GIL) or the connection broke."""
        since = max(self._last_write or 0.0, self._watched_from)
        return max(self._longest_gap, time.monotonic() - since)

    @property
    def alive(self) -> bool:
        """True while the thread runs and its last write went through."""
        return self._thread.is_alive() and not self._failed.is_set()

    def _beat(self, stop: threading.Event, failed: threading.Event, written: threading.Event) -> None:
        count = 0
        while True:
            count = (count + 1) % 2 ** 31
            if not self.inputs.set_int_register(HEARTBEAT_REGISTER, count):
                failed.set()
                return
            now = time.monotonic()
            self._longest_gap = max(self._longest_gap, now - max(self._last_write or now, self._watched_from))
            self._last_write = now
            written.set()
            if stop.wait(PERIOD):
                return

    def _halt(self) -> None:
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(1.0)

    def close(self) -> None:
        """Stop the beats and disconnect (idempotent). A running program armed on them then stops by itself."""
        self._halt()
        self.inputs.close()
