"""RTDE input watchdogs armed by URScript `rtde_set_watchdog(variable_name, min_frequency, action="pause")`.

UR's script manual: when the watchdog "did not receive an input update for the specified variable in the time
period specified by min_frequency (Hz), the corresponding action will be taken"; actions "ignore", "pause" (pause
the program) and "stop" (stop the program), in any letter case; "all watchdogs are removed on program stop".

A controller judges a client's silence in its own control cycles. The watchdog counts the cycles the controller
computed that were due (`controller.cycle_due`, on the host's monotonic clock) after the variable's latest input
package was read (or after the arming, or the end of a pause, when later), and takes the action once they span more
than the period. So a simulator starved of the CPU blames no client for its own pause: it computes no cycles
meanwhile, and the cycles it then catches up on back to back were due before the packages it reads late, which the
client sent in time. And a client silent for a period's worth of computed cycles is caught however late this
process runs (a wall-clock period, restarted after the simulator's own stalls, never fired on a heavily loaded
host). With the fast clock (docs/ursim.md) a cycle is due when it is computed, so silence is judged on the host's
clock: a client that writes on its own wall-clock pace stays alive however many cycles pass between two writes.
Until the reader thread has read a client's packages they wait in its socket: an expired watchdog does not fire
while input bytes of the variable's client wait unread (`unread_input`, set by the RTDE server, which takes bytes
out of the socket only once it has handled them). A client that stopped sending leaves nothing unread, so it
is still stopped. One watchdog per variable: arming it again replaces it. The RTDE server reports every input
package (`note_update`); a checker thread takes the action at most 1/`CHECK_RATE` s late (of the host's time) and
disarms a watchdog whose program has ended.

Attached to a controller without touching its class: `watchdogs_of(controller)` creates the registry on first use.
"""
import logging
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

log = logging.getLogger("sim_ursim.rtde")

ACTIONS = ("ignore", "pause", "stop")
CHECK_RATE = 200.0  # Hz at which deadlines are checked (a 500 Hz controller checks every cycle; 5 ms is close)
_ATTRIBUTE = "_rtde_input_watchdogs"
_ATTACH_LOCK = threading.Lock()


@dataclass
class _Watchdog:
    variable: str
    period: float  # s: 1 / min_frequency
    action: str
    armed_at: float  # time.monotonic() of the arming (or of its program's resumption)
    program_ended: Callable[[], bool]  # True once the arming program has stopped


class InputWatchdogs:
    """The armed watchdogs of one controller and the thread that enforces them.

    The controller gives the due time of its last computed cycle (`cycle_due`, on `clock`) and, in `state()`,
    whether the program is paused (`program_paused`); it is asked to `stop_program()` or `pause_program()`.
    """

    def __init__(self, controller: Any, clock: Callable[[], float] = time.monotonic) -> None:
        self._controller = controller
        self._clock = clock
        self._lock = threading.Lock()
        self._armed: dict[str, _Watchdog] = {}
        self._last_update: dict[str, float] = {}   # variable -> when its latest package was read
        self._thread: threading.Thread | None = None
        # True while bytes of the client writing `variable` wait unread
        self.unread_input: Callable[[str], bool] = lambda variable: False

    def arm(self, variable: str, min_frequency: float, action: str, program_ended: Callable[[], bool]) -> None:
        """Arm (or re-arm) the watchdog of input `variable`; ValueError for a bad frequency or action."""
        if str(action).lower() not in ACTIONS:
            raise ValueError(f"action must be one of {', '.join(ACTIONS)} (any case), got {action!r}")
        action = str(action).lower()
        if not min_frequency > 0:
            raise ValueError(f"min_frequency must be > 0 Hz, got {min_frequency!r}")
        with self._lock:
            self._armed[variable] = _Watchdog(variable, 1.0 / float(min_frequency), action, self._clock(),
                                              program_ended)
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._check_loop, name="rtde-watchdogs", daemon=True)
                self._thread.start()
        log.info("RTDE watchdog on %s: %.3f s, %s", variable, 1.0 / float(min_frequency), action)

    def note_update(self, names: Iterable[str]) -> None:
        """An input package carrying `names` was read now (the controller applies it at its next cycle)."""
        now = self._clock()
        with self._lock:
            for name in names:
                self._last_update[name] = now

    def armed(self) -> dict[str, str]:
        """{variable: action} of the watchdogs armed now."""
        with self._lock:
            return {name: watchdog.action for name, watchdog in self._armed.items()}

    def check(self) -> list[tuple[str, str]]:
        """Disarm watchdogs of ended programs and fire expired ones; returns the (variable, action) pairs fired."""
        # Unread input first: a package taken from the socket since was noted before it was taken.
        unread = {name for name in self.armed() if self.unread_input(name)}
        due, paused = self._controller.cycle_due, self._controller.state().program_paused
        fired = []
        with self._lock:
            for name, watchdog in list(self._armed.items()):
                if watchdog.program_ended():
                    del self._armed[name]
                    continue
                if paused:   # a paused program is not watched; the period starts again when it resumes
                    watchdog.armed_at = self._clock()
                    continue
                since = max(watchdog.armed_at, self._last_update.get(name, watchdog.armed_at))
                # the computed cycles due after `since` span more than the period
                if due - since > watchdog.period and watchdog.action != "ignore" and name not in unread:
                    watchdog.armed_at = self._clock()
                    fired.append((name, watchdog.action))
        for name, action in fired:
            log.warning("RTDE watchdog on %s expired: %s program", name, action)
            if action == "pause":
                self._controller.pause_program()
            else:
                self._controller.stop_program()
        return fired

    def _check_loop(self) -> None:
        while True:
            with self._lock:
                if not self._armed:
                    self._thread = None
                    return
            self.check()
            time.sleep(1.0 / CHECK_RATE)


def watchdogs_of(controller: Any) -> InputWatchdogs:
    """The controller's InputWatchdogs, created on first use."""
    registry = getattr(controller, _ATTRIBUTE, None)
    if registry is None:
        with _ATTACH_LOCK:
            registry = getattr(controller, _ATTRIBUTE, None)
            if registry is None:
                registry = InputWatchdogs(controller)
                setattr(controller, _ATTRIBUTE, registry)
    return registry
