"""Fault injection the servers honour: frozen streams, added latency, and a connection-drop generation counter.

Safety faults (protective stop, emergency stop) live on the controller itself; this object carries the
transport faults every server checks before it sends (docs/architecture.md, Contract 3).
"""
import threading
import time
from collections.abc import Callable


class Faults:
    """Transport faults shared by every server of one simulator; thread-safe."""

    def __init__(self, clock: Callable[[], float] = time.monotonic):
        self._clock = clock
        self._lock = threading.Lock()
        self._frozen_until = 0.0
        self._latency = 0.0
        self._generation = 0
        self._generation_changed = threading.Condition(self._lock)

    def freeze_streams(self, seconds: float) -> None:
        """Streams send nothing for `seconds` from now (a later call replaces the window)."""
        seconds = _non_negative(seconds, "seconds")
        with self._lock:
            self._frozen_until = self._clock() + seconds

    @property
    def streams_frozen(self) -> bool:
        """True while a freeze window is open: servers skip their sends."""
        with self._lock:
            return self._clock() < self._frozen_until

    def frozen_remaining(self) -> float:
        """Seconds left in the current freeze window (0 when not frozen)."""
        with self._lock:
            return max(0.0, self._frozen_until - self._clock())

    def add_latency(self, seconds: float) -> None:
        """Every send is delayed by `seconds` from now on (0 removes the delay)."""
        seconds = _non_negative(seconds, "seconds")
        with self._lock:
            self._latency = seconds

    @property
    def latency(self) -> float:
        """Seconds each server waits before a send."""
        with self._lock:
            return self._latency

    def drop_connections(self) -> int:
        """Ask every server to close all its current connections; returns the new generation number."""
        with self._generation_changed:
            self._generation += 1
            self._generation_changed.notify_all()
            return self._generation

    @property
    def generation(self) -> int:
        """Connection-drop generation: a connection accepted in generation g is closed once it exceeds g."""
        with self._lock:
            return self._generation

    def wait_generation(self, after: int, timeout: float | None) -> int:
        """Block until the generation exceeds `after` or `timeout` passes; returns the current generation."""
        with self._generation_changed:
            self._generation_changed.wait_for(lambda: self._generation > after, timeout)
            return self._generation

    def reset(self) -> None:
        """Clear the freeze window and the latency (the drop generation keeps counting)."""
        with self._lock:
            self._frozen_until = 0.0
            self._latency = 0.0

    def describe(self) -> str:
        """One-line summary for logs and the control channel."""
        return (f"frozen {self.frozen_remaining():.1f} s, latency {self.latency * 1000:.0f} ms, "
                f"drop generation {self.generation}")


def _non_negative(value: object, name: str) -> float:
    """`value` as a finite float ≥ 0; ValueError naming `name` otherwise."""
    try:
        number = float(value)  # type: ignore[arg-type]  # anything else raises, below
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not (number >= 0.0) or number == float("inf"):
        raise ValueError(f"{name} must be a finite number ≥ 0, got {value!r}")
    return number
