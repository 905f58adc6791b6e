"""The control loop's clock and the record of its cycles: every cycle is computed and published, in order.

A controller never skips a cycle. `CycleClock` paces a loop on absolute deadlines one period apart (a steady
clock): when the host runs the loop late, the loop is late, and then runs the missed cycles back to back until it
has caught up. Each cycle covers exactly one period, so simulated time advances in whole periods and never jumps.
Only when the loop falls more than `max_lag` behind (the process was stopped, the machine suspended) does the clock
stop chasing the wall clock: it starts counting again from now, and simulated time goes on from where it was —
behind the wall clock from then on, still without a gap.

A fast clock (`REAL_TIME`, `FAST`: a test pipeline's choice, never a controller's) computes a cycle at once when
the loop has work that takes simulated time: the same cycles, one period each, in order, without waiting for their
deadlines. With nothing to do it keeps real time again, counting its deadlines from then.

`CycleRecord` keeps the snapshots of the last cycles, so that a stream (RTDE) can send every one of them in order,
late rather than never, even when its thread runs later than the control loop; it knows how far each named reader
has read, so that a fast loop never runs so far ahead that a stream would lose a cycle. `CycleInputs` holds what
clients' inputs queue for the start of the next cycle; `FrameTurn` lets a script thread in lockstep with the cycles
(a held speedj/speedl) take its turn before the next cycle, and, with a fast clock, every script thread.

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
from typing import Generic, Protocol, TypeVar

log = logging.getLogger("sim_ursim.controller")

REAL_TIME, FAST = "real-time", "fast"   # the clocks a control loop runs on (CycleClock.wait's `hurry`: FAST)
CLOCKS = (REAL_TIME, FAST)
MAX_LAG = 1.0  # s: a loop further behind than this gives up catching up (a stall, not load) and counts from now
RECORD_SECONDS = 2.0  # s of cycles kept for streams that run behind the loop (at least MAX_LAG, with margin)
HELD_TURN_TIMEOUT = 0.05  # s the loop waits at most for a script thread's next held speed command (FrameTurn)
LOCKSTEP_TIMEOUT = 1.0  # s a fast loop waits at most for a script thread's turn or a stream's reading, then goes on

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

    def wait(self, hurry: bool = False) -> float:
        """Block until the next cycle is due and return how late it starts [s] (0.0 when on time).

        A late cycle starts at once; the deadlines stay where they were, so the following cycles come back to back
        until the loop has caught up. `hurry` (a fast clock with work to do): the cycle is due now and starts at
        once; the deadlines of later cycles count from it.
        """
        now = time.monotonic()
        if hurry:
            self._deadline = now
            return 0.0
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
    """The last `size` items published once per cycle (controller snapshots), oldest first, and the cycle up to
    which each named reader has taken them. Not thread-safe: the controller appends and reads under its cycle
    condition."""

    def __init__(self, size: int):
        self._items: deque[Item] = deque(maxlen=max(1, int(size)))
        self._read: dict[str, int] = {}   # reader -> the last cycle it has taken

    @property
    def size(self) -> int:
        """How many items are kept."""
        return self._items.maxlen or 1

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

    def note_read(self, reader: str, cycle: int) -> None:
        """`reader` (a stream) has taken every item up to `cycle`."""
        self._read[reader] = cycle

    def forget_reader(self, reader: str) -> None:
        """`reader` reads no more: nobody waits for it."""
        self._read.pop(reader, None)

    def slowest_read(self) -> int | None:
        """The last cycle the slowest reader has taken (None without readers)."""
        return min(self._read.values(), default=None)


class CycleBoard(Generic[Item]):
    """The snapshot of the last cycle (`latest`), the record of the recent ones and the waits on them: the control
    loop publishes, any thread reads or waits. `cycle_of(item)` is an item's cycle number; once `stopped()` the
    waits return at once (the loop has stopped: no cycle will come)."""

    def __init__(self, first: Item, record_size: int, cycle_of: Callable[[Item], int],
                 stopped: Callable[[], bool]) -> None:
        self.latest = first
        self._record: CycleRecord[Item] = CycleRecord(record_size)
        self._cycle_of = cycle_of
        self._stopped = stopped
        self._changed = threading.Condition()
        self._awaiting_readers = False   # a fast loop waits for the readers: tell it when one reads

    def publish(self, item: Item, new_cycle: bool) -> None:
        """Make `item` the latest; a new cycle's is also recorded and wakes the waiters (a commit's, under the same
        cycle number, wakes nobody: every wait here is for a newer cycle)."""
        with self._changed:
            self.latest = item
            if new_cycle:
                self._record.append(item)
                self._changed.notify_all()

    def wake(self) -> None:
        """Wake every waiter (to see that the loop stopped)."""
        with self._changed:
            self._changed.notify_all()

    def wait_newer(self, after_cycle: int, timeout: float | None) -> Item:
        """The latest item once it is newer than `after_cycle` (or after `timeout` s, or once stopped)."""
        with self._changed:
            self._changed.wait_for(lambda: self._cycle_of(self.latest) > after_cycle or self._stopped(), timeout)
            return self.latest

    def newer(self, after_cycle: int, timeout: float | None, reader: str | None = None) -> list[Item]:
        """The recorded items newer than `after_cycle`, oldest first, once there is one ([] after `timeout` s);
        `reader` (a stream's name) has then taken them all."""
        with self._changed:
            self._changed.wait_for(lambda: self._cycle_of(self.latest) > after_cycle or self._stopped(), timeout)
            items = self._record.after(after_cycle, self._cycle_of)
            if reader is not None:
                self._record.note_read(reader, self._cycle_of(items[-1]) if items else after_cycle)
                if self._awaiting_readers:
                    self._changed.notify_all()
            return items

    def forget_reader(self, reader: str) -> None:
        """The stream `reader` takes no more items."""
        with self._changed:
            self._record.forget_reader(reader)
            self._changed.notify_all()

    def await_readers(self, timeout: float = LOCKSTEP_TIMEOUT) -> None:
        """Block until every reader is at most half the record behind the latest cycle (or `timeout` s pass), so
        that a loop which does not wait for the wall clock never makes a stream lose a cycle."""
        def caught_up() -> bool:
            slowest, latest = self._record.slowest_read(), self._cycle_of(self.latest)
            return slowest is None or slowest >= latest - self._record.size // 2 or self._stopped()

        with self._changed:
            self._awaiting_readers = True
            try:
                self._changed.wait_for(caught_up, timeout)
            finally:
                self._awaiting_readers = False


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


class TurnTaker(Protocol):
    """A script thread as FrameTurn sees it (a script_thread.ThreadContext)."""

    def owes_frame(self) -> bool:
        """True while it runs statements, or what it waited for has come and it has not run yet."""
        ...


class FrameTurn:
    """The control loop's wait, before a cycle, for script threads: on a controller the script threads run inside
    the frame, so a thread issues its next command before the next cycle is computed. Here they run on Python
    threads that the host may run late, and the loop waits for them.

    In real time the loop waits only for the thread whose held speed command (speedj/speedl with t) has moved its
    time (`await_turn`, at most `timeout`), so that a busy host makes the simulator late instead of the arm holding
    still for a cycle the program never asked for; other threads run beside the loop in real time. With a fast
    clock no thread would get any real time between two cycles: the loop waits for every thread that has
    `joined` (`await_threads`) until none owes the frame, at most `lockstep_timeout` — a thread still owing then
    (blocked outside the interpreter's waits) is not waited for again until it next starts or stops running.

    The interpreter calls `changed(thread)` whenever a thread starts or stops running statements.
    """

    def __init__(self, timeout: float = HELD_TURN_TIMEOUT, lockstep_timeout: float = LOCKSTEP_TIMEOUT):
        self.timeout = timeout
        self.lockstep_timeout = lockstep_timeout
        self._changed = threading.Condition()
        self._threads: set[TurnTaker] = set()
        self._excused: set[TurnTaker] = set()   # owed the frame for lockstep_timeout: not waited for until it changes

    def join(self, thread: TurnTaker) -> None:
        """`thread` starts: with a fast clock the loop waits for its turn in every frame."""
        with self._changed:
            self._threads.add(thread)

    def leave(self, thread: TurnTaker) -> None:
        """`thread` has ended."""
        with self._changed:
            self._threads.discard(thread)
            self._excused.discard(thread)
            self._changed.notify_all()

    def changed(self, thread: TurnTaker | None = None) -> None:
        """A script thread started or stopped running statements: wake the loop if it waits for that thread."""
        with self._changed:
            self._excused.discard(thread)
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

    def await_threads(self) -> None:
        """Block until no joined thread owes the frame (a fast clock's lockstep), at most `lockstep_timeout` s."""
        with self._changed:
            if self._changed.wait_for(lambda: not self._owing(), self.lockstep_timeout):
                return
            late = self._owing()
            self._excused.update(late)
        log.warning("fast clock: %d script thread(s) owed the frame for %.1f s; the loop goes on "
                    "without waiting for them", len(late), self.lockstep_timeout)

    def _owing(self) -> list[TurnTaker]:
        return [thread for thread in self._threads if thread not in self._excused and thread.owes_frame()]
