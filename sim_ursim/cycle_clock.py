"""The control loop's clock and the record of its cycles: every cycle is computed and published, in order.

A controller never skips a cycle. `CycleClock` paces a loop on absolute deadlines one period apart (a steady
clock): when the host runs the loop late, the loop is late, and then runs the missed cycles back to back until it
has caught up. Each cycle covers exactly one period, so simulated time advances in whole periods and never jumps.
Only when the loop falls more than `max_lag` behind (the process was stopped, the machine suspended) does the clock
stop chasing the wall clock: it starts counting again from now, and simulated time goes on from where it was —
behind the wall clock from then on, still without a gap.

`CycleRecord` keeps the snapshots of the last cycles, so that a stream (RTDE) can send every one of them in order,
late rather than never, even when its thread runs later than the control loop. `CycleInputs` holds what clients'
inputs queue for the start of the next cycle; `FrameTurn` lets a script thread in lockstep with the cycles (a held
speedj/speedl) take its turn before the next cycle.

Example
-------
>>> clock = CycleClock(0.002)
>>> lateness = clock.wait()        # blocks until the first cycle is due; 0.0 when on time
>>> record = CycleRecord(3)
>>> for cycle in range(1, 6):
...     record.append(cycle)
>>> record.after(3, cycle_of=lambda item: item)
[4, 5]
"""
import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Generic, TypeVar

log = logging.getLogger("sim_ursim.controller")

MAX_LAG = 1.0  # s: a loop further behind than this gives up catching up (a stall, not load) and counts from now
RECORD_SECONDS = 2.0  # s of cycles kept for streams that run behind the loop (at least MAX_LAG, with margin)
HELD_TURN_TIMEOUT = 0.05  # s the loop waits at most for a script thread's next held speed command (FrameTurn)

Item = TypeVar("Item")


class CycleClock:
    """Deadlines of a control loop, `period` s apart on time.monotonic; late cycles run back to back."""

    def __init__(self, period: float, max_lag: float = MAX_LAG):
        self.period = period
        self.max_lag = max_lag
        self.restarts = 0  # times the loop fell more than max_lag behind and the clock counted from now again
        self._deadline: float | None = None

    @property
    def due(self) -> float | None:
        """The time.monotonic() at which the cycle wait() last started was due (None before the first)."""
        return self._deadline

    def wait(self) -> float:
        """Block until the next cycle is due and return how late it starts [s] (0.0 when on time).

        A late cycle starts at once; the deadlines stay where they were, so the following cycles come back to back
        until the loop has caught up.
        """
        now = time.monotonic()
        if self._deadline is None:
            self._deadline = now
        self._deadline += self.period
        delay = self._deadline - now
        if delay > 0:
            time.sleep(delay)
            return 0.0
        late = -delay
        if late > self.max_lag:
            self.restarts += 1
            log.warning("control loop %.2f s behind the wall clock (the process or host was stalled): it goes on "
                        "from now; simulated time continues without a gap and stays that much behind", late)
            self._deadline = now
        return late


class CycleRecord(Generic[Item]):
    """The last `size` items published once per cycle (controller snapshots), oldest first. Not thread-safe: the
    controller appends and reads under its cycle condition."""

    def __init__(self, size: int):
        self._items: deque[Item] = deque(maxlen=max(1, int(size)))

    def append(self, item: Item) -> None:
        """Record the item of a newly computed cycle (the oldest falls out once `size` are kept)."""
        self._items.append(item)

    def after(self, cycle: int, cycle_of: Callable[[Item], int]) -> list[Item]:
        """The recorded items of cycles after `cycle`, oldest first (those that fell out of the record are gone)."""
        newer: list[Item] = []
        for item in reversed(self._items):
            if cycle_of(item) <= cycle:
                break
            newer.append(item)
        newer.reverse()
        return newer


class CycleInputs:
    """Actions queued by clients' inputs (any thread) and applied together at the start of the next cycle."""

    def __init__(self) -> None:
        self._actions: deque[Callable[[], None]] = deque()  # deque append/popleft are atomic: no lock needed

    def add(self, action: Callable[[], None]) -> None:
        """Queue `action` for the start of the next cycle."""
        self._actions.append(action)

    def apply(self) -> None:
        """Run the queued actions in the order they came (a failing one is logged, the others still apply)."""
        while self._actions:
            action = self._actions.popleft()
            try:
                action()
            except Exception:  # noqa: BLE001 - one client's bad input must not stop the control cycle
                log.exception("applying a client's input failed")


class FrameTurn:
    """The control loop's wait, before a cycle, for the script thread whose held speed command (speedj/speedl with t)
    has moved its time: on a controller the script threads run inside the frame, so that thread issues its next
    command before the next cycle is computed. Here it runs on a Python thread that the host may run late; the loop
    waits for it (at most `timeout`), so that a busy host makes the simulator late instead of the arm holding still
    for a cycle the program never asked for.

    The owner is the hold owner of the held segment (an interpreter.ThreadContext, whose `owes_frame()` tells
    whether it still has its turn); the interpreter calls `changed()` whenever a thread starts or stops running
    statements.
    """

    def __init__(self, timeout: float = HELD_TURN_TIMEOUT):
        self.timeout = timeout
        self._changed = threading.Condition()

    def changed(self) -> None:
        """A script thread started or stopped running statements: wake the loop if it waits for that thread."""
        with self._changed:
            self._changed.notify_all()

    def await_turn(self, holding_owner: Callable[[], object]) -> None:
        """Block while `holding_owner()` (the owner of a held speed command that has moved its time) still owes the
        frame its next command, at most `timeout` s. Owners without `owes_frame` (tests' plain objects) are not
        waited for."""
        owner = holding_owner()
        owes_frame = getattr(owner, "owes_frame", None)
        if owes_frame is None:
            return
        with self._changed:
            self._changed.wait_for(lambda: holding_owner() is not owner or not owes_frame(), self.timeout)
