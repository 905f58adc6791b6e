"""SIGTERM and SIGHUP handled like Ctrl-C: they raise `Terminated` (a KeyboardInterrupt) in the main thread, so the
driver's interrupt path sends stopj to a moving arm and the store's atomic writes roll back, exactly as for Ctrl-C.

SIGINT itself is taken back when the process started with it ignored: a shell script that starts ur3dq with `&`
(no job control) passes SIGINT on as ignored, and Python then never raises KeyboardInterrupt, so Ctrl-C in that
terminal or `kill -INT` would leave the arm moving. Stopping is the safe side, so ur3dq always stops on SIGINT.

The exit code follows the shell convention 128 + signal number: 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP.

SIGQUIT (Ctrl-\\) prints the stack of every thread on stderr and ur3dq goes on: what a bug report about a command
that hangs needs (`kill -QUIT <pid>`), where the default would end the process without stopping the arm.
"""
from __future__ import annotations

import contextlib
import faulthandler
import io
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType

# The signals a supervisor, `kill`, or a closed terminal send to end a process politely.
POLITE_SIGNALS = tuple(sig for sig in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if sig)


class Terminated(KeyboardInterrupt):
    """A polite termination signal (SIGTERM, SIGHUP) arrived; `signum` is its number."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"terminated by {signal.Signals(signum).name}")
        self.signum = signum


def exit_code_for_interrupt(interrupt: BaseException) -> int:
    """128 + the signal number of a KeyboardInterrupt (SIGINT = 2 unless it is a Terminated)."""
    return 128 + getattr(interrupt, "signum", signal.SIGINT)


def signal_name(interrupt: BaseException) -> str | None:
    """'SIGTERM' / 'SIGHUP' for a Terminated, None for a plain Ctrl-C."""
    signum = getattr(interrupt, "signum", None)
    return signal.Signals(signum).name if signum is not None else None


def _raise_terminated(signum: int, _frame: FrameType | None) -> None:
    raise Terminated(signum)


@contextlib.contextmanager
def polite_signals_interrupt() -> Iterator[None]:
    """Turn SIGTERM, SIGHUP and SIGINT into exceptions inside the block.

    While inside, SIGTERM and SIGHUP raise Terminated and SIGINT raises KeyboardInterrupt (even if it was
    ignored) in the main thread; the old handlers come back after. Does nothing outside the main thread (Python
    only delivers signals there)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, _raise_terminated) for sig in POLITE_SIGNALS}
    previous[signal.SIGINT] = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def stacks_on_sigquit() -> None:
    """From now on SIGQUIT prints every thread's stack on stderr (where stderr is a descriptor) and nothing else."""
    if hasattr(signal, "SIGQUIT"):
        with contextlib.suppress(AttributeError, ValueError, io.UnsupportedOperation):
            faulthandler.register(signal.SIGQUIT, file=sys.stderr, all_threads=True)
