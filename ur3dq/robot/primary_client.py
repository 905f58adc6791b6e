"""Transport for the primary interface (port 30001): a reader thread that keeps the latest robot state and
fans robot messages (program started/stopped, runtime exceptions, errors) out to watchers. Parsing is in primary.py.
"""
from __future__ import annotations

import queue
import socket
import threading
import time
from collections.abc import Callable

from ur3dq.errors import ConnectionLostError, RobotConnectionError
from ur3dq.robot import interrupts, primary

PRIMARY_PORT = 30001
SECONDARY_PORT = 30002


class PrimaryClient:
    """A connection to port 30001 read by a daemon thread; `close()` ends it."""

    def __init__(self, host: str, port: int = PRIMARY_PORT, connect_timeout: float = 2.0) -> None:
        try:
            self._socket = socket.create_connection((host, port), timeout=connect_timeout)
        except OSError as error:
            raise RobotConnectionError(f"cannot reach the primary interface at {host}:{port}: {error}") from None
        self._socket.settimeout(0.2)  # lets the reader notice close() without waiting for data
        self._socket.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.host, self.port = host, port
        self._lock = threading.Lock()
        self._send_lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self._watchers: list[queue.Queue[object]] = []
        self._closing = False
        # What the controller sent last (None until it has): Robot waits for the first four before it connects.
        self.version: primary.VersionMessage | None = None
        self.robot_mode: primary.RobotModeData | None = None
        self.safety_mode: int | None = None
        self.cartesian: primary.CartesianInfo | None = None
        self.kinematics: primary.KinematicsInfo | None = None
        self.configuration: primary.ConfigurationData | None = None
        self.board_io: primary.BoardIO | None = None   # the masterboard's I/O in the last robot state
        self.last_state_time: float | None = None  # time.monotonic() of the last robot-state message
        self.error: str | None = None  # why the reader stopped, once it has
        self._thread = threading.Thread(target=self._read_forever, name=f"ur3dq-primary-{host}", daemon=True)
        self._thread.start()

    @property
    def alive(self) -> bool:
        """True while the reader thread runs (connection open and in step)."""
        return self._thread.is_alive()

    @property
    def control_mode(self) -> int | None:
        """The controlMode of the last Robot Mode Data (1 TEACH: freedrive, 0 POSITION), or None before one came."""
        robot_mode = self.robot_mode
        return None if robot_mode is None else robot_mode.control_mode

    @interrupts.taken_at_polls
    def wait_for(self, predicate: Callable[[PrimaryClient], bool], timeout: float) -> bool:
        """Block until predicate(self) is true (re-checked on every message) or `timeout` s pass; returns it."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while not predicate(self):
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not self.alive:
                    return predicate(self)
                self._changed.wait(min(remaining, 0.1))
                interrupts.check()   # a Ctrl-C inside the condition's own lock would leave it taken
            return True

    def watch(self) -> queue.Queue[object]:
        """A queue receiving every robot message parsed from now on; pass it to `unwatch` when done."""
        watcher: queue.Queue[object] = queue.Queue()
        with self._lock:
            self._watchers.append(watcher)
        return watcher

    def unwatch(self, watcher: queue.Queue[object]) -> None:
        """Stop delivering messages to `watcher`."""
        with self._lock:
            if watcher in self._watchers:
                self._watchers.remove(watcher)

    def send_script(self, script: str) -> None:
        """Send URScript on this connection (30001 runs it at once); ConnectionLostError if the socket fails."""
        if not self.alive:
            raise ConnectionLostError(f"the primary connection to {self.host} is closed ({self.error}); not sent")
        with self._send_lock:
            try:
                self._socket.sendall(_script_bytes(script))
            except OSError as error:
                raise ConnectionLostError(f"sending a program to {self.host}:{self.port} failed: {error}") from None

    def close(self) -> None:
        """Stop the reader and close the socket (idempotent)."""
        self._closing = True
        self._thread.join(timeout=2.0)
        try:
            self._socket.close()
        except OSError:
            pass

    def _read_forever(self) -> None:
        """Reader thread body: receive, split, parse, publish — until close() or the stream breaks."""
        buffer = b""
        try:
            while not self._closing:
                try:
                    chunk = self._socket.recv(65536)
                except TimeoutError:
                    continue
                if not chunk:
                    raise ConnectionError("the controller closed the primary connection")
                messages, buffer = primary.split_messages(buffer + chunk)
                for message_type, body in messages:
                    self._handle(message_type, body)
        except (OSError, ConnectionError, primary.PrimaryParseError) as error:
            self.error = str(error)
        finally:
            with self._changed:
                self._changed.notify_all()

    def _handle(self, message_type: int, body: bytes) -> None:
        """Store a robot state or publish a robot message."""
        if message_type == primary.ROBOT_STATE:
            state = primary.parse_robot_state(body)
            with self._changed:
                if state.robot_mode is not None:
                    self.robot_mode = state.robot_mode
                if state.safety_mode is not None:
                    self.safety_mode = state.safety_mode
                if state.cartesian is not None:
                    self.cartesian = state.cartesian
                if state.kinematics is not None:
                    self.kinematics = state.kinematics
                if state.configuration is not None:
                    self.configuration = state.configuration
                if state.board_io is not None:
                    self.board_io = state.board_io
                self.last_state_time = time.monotonic()
                self._changed.notify_all()
        elif message_type == primary.ROBOT_MESSAGE:
            message = primary.parse_robot_message(body)
            if message is None:
                return
            with self._changed:
                if isinstance(message, primary.VersionMessage):
                    self.version = message
                for watcher in self._watchers:
                    watcher.put(message)
                self._changed.notify_all()


def send_script(host: str, script: str, port: int = SECONDARY_PORT, timeout: float = 1.0) -> None:
    """Send URScript on a connection of its own and wait until it is read.

    Send URScript on a connection of its own (for when the main one is gone), half-close it, and wait (≤ timeout)
    for the controller to close its side, so the script is known to be read before the socket goes away."""
    try:
        with socket.create_connection((host, port), timeout=timeout) as connection:
            connection.sendall(_script_bytes(script))
            connection.shutdown(socket.SHUT_WR)
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline and connection.recv(65536):
                pass  # state messages the controller streams meanwhile
    except TimeoutError:
        pass  # sent; the controller just keeps the connection open
    except OSError as error:
        raise RobotConnectionError(f"cannot send a program to {host}:{port}: {error}") from None


def _script_bytes(script: str) -> bytes:
    """URScript text as the bytes a controller expects: ASCII, ending with a newline."""
    return (script if script.endswith("\n") else script + "\n").encode("ascii")
