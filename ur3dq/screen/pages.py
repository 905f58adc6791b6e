"""The open pages of one `ur3dq serve` and which of them has control of the arm.

One page at a time may move the arm (the one holding control); the others show the same cell read-only, with who
has control, and take it over only by asking explicitly. Messages to a page wait in its outbox; the live state is
a single slot (only the newest reading is worth sending), so a slow page never queues stale states. Other threads
hand messages over through the event loop (`call_soon_threadsafe`).
"""
from __future__ import annotations

import asyncio
import collections
import itertools
import json
import threading
import time
from collections.abc import Callable
from typing import Any

from ur3dq.units import Units

_numbers = itertools.count(1)
STATE_REPEAT = 1.0   # s: an unchanged state is sent again this often (the page sees the server is there)


class Page:
    """One open page: its name, the units it reads and types in, its outbox and its last heartbeat."""

    def __init__(self, address: str, loop: asyncio.AbstractEventLoop, units: Units) -> None:
        self.id = f"page-{next(_numbers)}"
        self.address = address
        self.since = time.strftime("%H:%M:%S")
        self.units = units   # until the page chooses its own
        self.last_beat = time.monotonic()
        self._loop = loop
        self._outbox: collections.deque[str] = collections.deque()
        self._state: str | None = None
        self._last_state, self._last_state_at = "", 0.0
        self._wake = asyncio.Event()
        self.closed = False

    @property
    def label(self) -> str:
        """How other pages and the log name this page: '<id> (<address>, since <time>)'."""
        return f"{self.id} ({self.address}, since {self.since})"

    def post(self, message: dict[str, Any]) -> None:
        """Queue `message` for the page (from any thread)."""
        self._loop.call_soon_threadsafe(self._put, json.dumps(message), False)

    def post_state(self, text: str) -> None:
        """Replace the page's pending live state with `text` (already JSON; from any thread). A state equal to the
        last one sent goes again only after STATE_REPEAT s: an arm at rest costs the page nothing."""
        now = time.monotonic()
        if text == self._last_state and now - self._last_state_at < STATE_REPEAT:
            return
        self._last_state, self._last_state_at = text, now
        self._loop.call_soon_threadsafe(self._put, text, True)

    def _put(self, text: str, is_state: bool) -> None:
        if is_state:
            self._state = text
        else:
            self._outbox.append(text)
        self._wake.set()

    async def next_texts(self) -> list[str]:
        """Wait for what is to be sent: the queued messages in order, then the newest state."""
        await self._wake.wait()
        self._wake.clear()
        texts = list(self._outbox)
        self._outbox.clear()
        if self._state is not None:
            texts.append(self._state)
            self._state = None
        return texts


class Pages:
    """Every open page and the holder of control."""

    def __init__(self) -> None:
        self._pages: dict[str, Page] = {}
        self._lock = threading.Lock()
        self.holder: Page | None = None

    def all(self) -> list[Page]:
        with self._lock:
            return list(self._pages.values())

    def join(self, page: Page) -> None:
        """Add `page`; it takes control when nobody has it."""
        with self._lock:
            self._pages[page.id] = page
            if self.holder is None:
                self.holder = page

    def leave(self, page: Page) -> bool:
        """Remove `page`; True if it had control (which is then free)."""
        with self._lock:
            page.closed = True
            self._pages.pop(page.id, None)
            if self.holder is page:
                self.holder = None
                return True
            return False

    def take_control(self, page: Page) -> Page | None:
        """Give `page` control; returns the page that had it (None if none, or `page` itself)."""
        with self._lock:
            previous, self.holder = self.holder, page
            return previous if previous is not page else None

    def control_of(self, page: Page) -> dict[str, bool | str | int | None]:
        """What `page` shows about control: whether it has it, and who has."""
        holder = self.holder
        return {"you": holder is page, "holder": None if holder is None else holder.label,
                "pages": len(self._pages)}

    def broadcast(self, message_for: Callable[[Page], dict[str, Any]]) -> None:
        """Post message_for(page) to every page."""
        for page in self.all():
            page.post(message_for(page))
