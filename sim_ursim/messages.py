"""Robot messages the controller emits (primary interface, port 30001), and the bus that carries them.

The URScript runtime and the controller publish; each primary-interface connection subscribes and serialises.
Field names follow the primary interface's robot-message layouts (docs/protocols.md §3.4).
"""
import queue
import threading
from dataclasses import dataclass


@dataclass(frozen=True)
class TextMessage:
    """Robot message type 0: free text (URScript `textmsg`)."""

    text: str
    source: int = -2


@dataclass(frozen=True)
class KeyMessage:
    """Robot message type 7: a key event, e.g. title PROGRAM_XXX_STARTED / PROGRAM_XXX_STOPPED, text = program name."""

    code: int
    argument: int
    title: str
    text: str
    source: int = -2


@dataclass(frozen=True)
class ErrorCodeMessage:
    """Robot message type 6: an error code (e.g. C210 script refused), with a report level (0 DEBUG … 5 CRITICAL)."""

    code: int
    argument: int
    report_level: int
    data_type: int
    data: int
    text: str
    source: int = -2


@dataclass(frozen=True)
class RuntimeExceptionMessage:
    """Robot message type 10: a URScript compile or runtime error at line/column.

    E.g. `compile_error_name_not_found:x:`.
    """

    line: int
    column: int
    text: str
    source: int = -3


@dataclass(frozen=True)
class SafetyModeMessage:
    """Robot message type 5: the safety mode changed (safety_mode_type uses the safety-mode enumeration)."""

    code: int
    argument: int
    safety_mode_type: int
    report_data_type: int = 0
    report_data: int = 0
    source: int = -2


@dataclass(frozen=True)
class PopupMessage:
    """Robot message type 2: a popup (URScript `popup`)."""

    title: str
    text: str
    warning: bool = False
    error: bool = False
    request_id: int = 0
    source: int = -2


class MessageBus:
    """Fan-out of robot messages to every subscriber; a slow subscriber loses its oldest messages, never blocks."""

    def __init__(self, queue_size=1000):
        self._queue_size = queue_size
        self._subscribers = []
        self._lock = threading.Lock()

    def subscribe(self) -> queue.Queue:
        """A new queue that receives every message published from now on."""
        subscriber: queue.Queue[object] = queue.Queue(maxsize=self._queue_size)
        with self._lock:
            self._subscribers.append(subscriber)
        return subscriber

    def unsubscribe(self, subscriber: queue.Queue) -> None:
        """Stop delivering to `subscriber` (unknown queues are ignored)."""
        with self._lock:
            if subscriber in self._subscribers:
                self._subscribers.remove(subscriber)

    def publish(self, message) -> None:
        """Deliver `message` to every subscriber, dropping a full subscriber's oldest message first."""
        with self._lock:
            subscribers = list(self._subscribers)
        for subscriber in subscribers:
            while True:
                try:
                    subscriber.put_nowait(message)
                    break
                except queue.Full:
                    try:
                        subscriber.get_nowait()
                    except queue.Empty:
                        pass
