"""RTDE input watchdogs armed by URScript `rtde_set_watchdog(variable_name, min_frequency, action="pause")`.

UR's script manual: when the watchdog "did not receive an input update for the specified variable in the time
period specified by min_frequency (Hz), the corresponding action will be taken"; actions "ignore", "pause" (pause
the program) and "stop" (stop the program), in any letter case; "all watchdogs are removed on program stop".

The period is counted from the latest of the arming, the variable's last update and the end of a pause, so a
program that arms a watchdog gets one full period for its client's first package, and a paused program is not
watched until it resumes. A controller is real-time and reads its inputs every cycle; this process can be starved
of the CPU or the GIL, and then the input packages a client kept sending are read late. So the period also starts
again after the simulator itself stalled (its checks more than `STALL` s apart), and an expired watchdog does not
fire while input bytes of the variable's client wait unread in its socket (`unread_input`, set by the RTDE
server): the checker can run on time while the thread reading that client is held back (seen in loaded test runs:
a client writing every 10-20 ms, nothing read for 101 ms, the program stopped). A client that stopped sending
leaves nothing unread, so it is still stopped one period after its last package. One watchdog per variable:
arming it again replaces it. The RTDE server reports every input package (`note_update`); a checker thread takes
the action at most 1/`CHECK_RATE` s late and disarms a watchdog whose program has ended.

Attached to a controller without touching its class: `watchdogs_of(controller)` creates the registry on first use.
"""
import logging
import threading
import time
from dataclasses import dataclass

log = logging.getLogger("sim_ursim.rtde")

ACTIONS = ("ignore", "pause", "stop")
CHECK_RATE = 200.0  # Hz at which deadlines are checked (a 500 Hz controller checks every cycle; 5 ms is close)
STALL = 0.05  # s between two checks beyond which the simulator stalled (ten check periods)
_ATTRIBUTE = "_rtde_input_watchdogs"
_ATTACH_LOCK = threading.Lock()


@dataclass
class _Watchdog:
    variable: str
    period: float  # s: 1 / min_frequency
    action: str
    armed_at: float
    program_ended: object  # callable() -> bool: True once the arming program has stopped


class InputWatchdogs:
    """The armed watchdogs of one controller and the thread that enforces them."""

    def __init__(self, controller, clock=time.monotonic):
        self._controller = controller
        self._clock = clock
        self._lock = threading.Lock()
        self._armed = {}
        self._last_update = {}
        self._last_check = None
        self._thread = None
        self.unread_input = lambda variable: False   # True while bytes of the client writing `variable` wait unread

    def arm(self, variable, min_frequency, action, program_ended):
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

    def note_update(self, names):
        """An input package carrying `names` arrived now."""
        now = self._clock()
        with self._lock:
            for name in names:
                self._last_update[name] = now

    def armed(self):
        """{variable: action} of the watchdogs armed now."""
        with self._lock:
            return {name: watchdog.action for name, watchdog in self._armed.items()}

    def check(self):
        """Disarm watchdogs of ended programs and fire expired ones; returns the (variable, action) pairs fired."""
        now = self._clock()
        paused = self._controller.state().program_paused
        fired = []
        with self._lock:
            stalled = self._last_check is not None and now - self._last_check > STALL
            self._last_check = now
            for name, watchdog in list(self._armed.items()):
                if watchdog.program_ended():
                    del self._armed[name]
                    continue
                if paused or stalled:
                    # A paused program is not watched; the period starts again when it resumes. After a stall of
                    # the simulator the packages that arrived meanwhile may not have been read yet.
                    watchdog.armed_at = now
                    continue
                since = max(watchdog.armed_at, self._last_update.get(name, watchdog.armed_at))
                if now - since > watchdog.period and watchdog.action != "ignore" and not self.unread_input(name):
                    watchdog.armed_at = now
                    fired.append((name, watchdog.action))
        for name, action in fired:
            log.warning("RTDE watchdog on %s expired: %s program", name, action)
            if action == "pause":
                self._controller.pause_program()
            else:
                self._controller.stop_program()
        return fired

    def _check_loop(self):
        while True:
            with self._lock:
                if not self._armed:
                    self._thread = None
                    return
            self.check()
            time.sleep(1.0 / CHECK_RATE)


def watchdogs_of(controller):
    """The controller's InputWatchdogs, created on first use."""
    registry = getattr(controller, _ATTRIBUTE, None)
    if registry is None:
        with _ATTACH_LOCK:
            registry = getattr(controller, _ATTRIBUTE, None)
            if registry is None:
                registry = InputWatchdogs(controller)
                setattr(controller, _ATTRIBUTE, registry)
    return registry
