"""Ctrl-C taken where the driver polls, never inside a lock.

Python raises KeyboardInterrupt in the main thread between two bytecodes, and that may be inside the Python-level
`__enter__` of a queue's or a condition's lock, just after the lock was taken: the lock then stays taken for good,
and the next thread that wants it waits forever (a `run-poses` stopped by Ctrl-C hung in its clean-up, draining the
queue the primary interface's reader fills). While a driver call waits on the controller, the signals that raise
(SIGINT, and SIGTERM or SIGHUP where the program has turned them into exceptions, as the CLI does) are only
recorded; the call raises them at its next `poll()`, where it holds no lock: within the backend's poll period (1 or
5 ms) while a motion is watched, within 0.1 s in the other waits (a reconnection's back-off: after its delay).

Use `taken_at_polls` around a method whose loop polls with `poll` (or `check`)::

    @interrupts.taken_at_polls
    def wait_until_done(robot):
        while not done(robot.state()):
            interrupts.poll(0.01)   # sleeps; raises the KeyboardInterrupt that came meanwhile

A signal that comes while such a call already fails (its exception on its way out, the arm being stopped) is
dropped: that exception is the one the caller sees. Outside the main thread (which alone receives signals), and
inside a call that already defers them, both do no more than the loop would.
"""
from __future__ import annotations

import contextlib
import functools
import signal
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any, ParamSpec, TypeVar

#: The signals taken at polls when their handler raises (a Python handler): SIGINT always, SIGTERM and SIGHUP
#: when the program installed one (ur3dq.cli.signals).
SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))

P = ParamSpec("P")
R = TypeVar("R")


class _Deferral:
    """The handlers replaced while signals are taken at polls, and the signals that came meanwhile."""

    active = False
    previous: dict[int, Callable[[int, FrameType | None], Any]] = {}
    pending: list[int] = []


def _record(signum: int, _frame: FrameType | None) -> None:
    _Deferral.pending.append(signum)


@contextlib.contextmanager
def at_polls() -> Iterator[None]:
    """Inside the block, SIGINT (and SIGTERM, SIGHUP when they raise) are raised only by `poll` and `check`."""
    if threading.current_thread() is not threading.main_thread() or _Deferral.active:
        yield
        return
    _Deferral.previous = {signum: handler for signum in SIGNALS if callable(handler := signal.getsignal(signum))}
    _Deferral.pending = []
    _Deferral.active = True
    for signum in _Deferral.previous:
        signal.signal(signum, _record)
    failed = True
    try:
        yield
        failed = False
    finally:
        _Deferral.active = False
        for signum, handler in _Deferral.previous.items():
            signal.signal(signum, handler)
        if not failed:
            _raise_pending()


def taken_at_polls(function: Callable[P, R]) -> Callable[P, R]:
    """`function` run inside `at_polls()`: a decorator for driver methods whose loops poll."""
    @functools.wraps(function)
    def deferring(*args: P.args, **kwargs: P.kwargs) -> R:
        with at_polls():
            return function(*args, **kwargs)
    return deferring


def check() -> None:
    """Raise the first signal that came since the block began (as its own handler raises it), if one did."""
    if _Deferral.active:
        _raise_pending()


def poll(seconds: float) -> None:
    """Sleep `seconds`, then raise a signal that came meanwhile or before (`check`)."""
    check()
    time.sleep(seconds)
    check()


def _raise_pending() -> None:
    if _Deferral.pending:
        signum = _Deferral.pending[0]
        _Deferral.pending = []
        handler = _Deferral.previous.get(signum)
        if handler is not None:
            handler(signum, None)
