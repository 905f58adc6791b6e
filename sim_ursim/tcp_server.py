"""The one TCP server base of the simulator: every port (dashboard, primary/secondary/realtime, RTDE, the control
channel) is a `TCPServer` subclass that only says what a connection does.

Written once here: bind/listen/accept, the connection set, stop/join, the drop-generation watcher (a new
`controller.faults` generation closes every connection accepted before it) and the fault hooks subclasses use
(`hold_while_frozen`, `due_time`). This is the only module of sim_ursim that listens and accepts.

Connections are non-blocking sockets, each served by its own thread (`serve`). A port serves at most
`max_connections` clients at once: beyond that a new connection is accepted and reset at once (logged at most once
a second per port with the count), so a flood of clients costs neither threads nor the accept loop's pace — the
loop takes every connection waiting in the listen backlog each time it wakes. Reading never depends on a writer:
`read_chunks` yields what the client sent until its end of stream (or a reset), and only the reader, a deliberate
drop or `stop()` closes the socket; a writer that finds the client gone calls `stop_sending()`. The kernel keeps
what a client sent before closing readable, so data received before a close is always processed.
"""
import logging
import select
import socket
import struct
import threading
import time
from collections.abc import Iterator

log = logging.getLogger("sim_ursim.server")

POLL_INTERVAL = 0.1  # s: how often idle threads look at the stop flag
RECEIVE_SIZE = 65536
JOIN_TIMEOUT = 2.0
# Clients one port serves at once. UR does not publish its controller's limit; client libraries open one to three
# connections per port (ur_rtde: receive, control and I/O on 30004), so this leaves room for many clients while a
# flood (hundreds of connections) costs a bounded number of threads.
MAX_CONNECTIONS = 32
REFUSAL_LOG_INTERVAL = 1.0  # s: at most one log line per port this often while connections are refused
_RESET_ON_CLOSE = struct.pack("ii", 1, 0)  # SO_LINGER on, 0 s: close() resets the connection at once


class Connection:
    """One accepted client socket (non-blocking), its peer address and the drop generation it belongs to."""

    def __init__(self, sock: socket.socket, peer: tuple, generation: int):
        self.sock = sock
        self.peer = peer
        self.generation = generation
        self.closed = threading.Event()
        self.sending_ended = threading.Event()

    def __repr__(self) -> str:
        return f"{self.peer[0]}:{self.peer[1]}"

    def stop_sending(self) -> None:
        """The client no longer takes data (it closed or reset): writers stop; reading goes on to the end."""
        self.sending_ended.set()

    @property
    def can_send(self) -> bool:
        """False once the connection is closed or a writer gave up on it."""
        return not (self.closed.is_set() or self.sending_ended.is_set())

    def close(self) -> None:
        """Close the socket once (threads blocked on it wake up; `closed` tells them why)."""
        if self.closed.is_set():
            return
        self.closed.set()
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.sock.close()

    def send_all(self, data: bytes, timeout: float) -> bool:
        """Write all of `data`, waiting at most `timeout` s for the client to take it. False when it cannot: after a
        send error (the client went away: `stop_sending`) or the timeout (the client does not read: dropped)."""
        view = memoryview(data)
        deadline = time.monotonic() + timeout
        while view:
            if not self.can_send:
                return False
            try:
                view = view[self.sock.send(view):]
                continue
            except BlockingIOError:
                pass
            except OSError:  # the client closed or reset: what it sent before is still read by the reader
                self.stop_sending()
                return False
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                log.info("%s did not read for %.1f s: disconnected", self, timeout)
                self.close()
                return False
            try:
                select.select([], [self.sock], [], min(remaining, POLL_INTERVAL))
            except (OSError, ValueError):
                self.stop_sending()
                return False
        return True


class TCPServer:
    """A listening port for `controller` on host:port (port 0 picks a free one; `port` is then the bound port).

    Subclasses override `serve(connection)` (runs in the connection's own thread; the connection is closed and
    forgotten when it returns), and optionally `configure(sock)` (socket options), `on_start()` (extra threads,
    via `spawn`). `follows_faults = False` exempts a port from the drop generations (the control channel).
    """

    follows_faults = True
    listen_backlog = 128  # connections the kernel holds until the accept loop takes them (a burst is not dropped)
    max_connections = MAX_CONNECTIONS

    def __init__(self, controller, host: str, port: int):
        self.controller = controller
        self.host = host
        self.port = port
        self._listener: socket.socket | None = None
        self._stopping = threading.Event()
        self._connections: set[Connection] = set()
        self._lock = threading.Lock()
        self._connected = threading.Condition(self._lock)  # notified when a connection is added
        self._threads: list[threading.Thread] = []
        self._refused = 0  # connections refused since the last log line about them
        self._refusals_logged_at = 0.0

    # ------------------------------------------------------------------------------------------------ lifecycle
    def start(self):
        """Bind host:port (SO_REUSEADDR, so a restarted simulator binds at once) and start serving."""
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            listener.bind((self.host, self.port))
            listener.listen(self.listen_backlog)
        except OSError:
            listener.close()
            raise
        listener.setblocking(False)
        self.port = listener.getsockname()[1]
        self._listener = listener
        self._stopping.clear()
        self.spawn(self._accept_loop, "accept")
        if self.follows_faults:
            self.spawn(self._watch_drops, "drops")
        self.on_start()
        log.info("%s listening on %s:%d", type(self).__name__, self.host, self.port)
        return self

    def stop(self) -> None:
        """Stop accepting, close every connection and join the server's threads."""
        self.begin_stop()
        self.join()

    def begin_stop(self) -> None:
        """Stop accepting and close every connection, without waiting for the threads (each ends within its poll
        interval): a simulator stops all its servers this way, then joins them, instead of one poll each in turn."""
        self._stopping.set()
        if self._listener is not None:
            self._listener.close()
        self.drop_connections()

    def join(self) -> None:
        """Wait for the server's threads to end (after begin_stop)."""
        for thread in list(self._threads):
            if thread is not threading.current_thread():
                thread.join(timeout=JOIN_TIMEOUT)

    @property
    def stopping(self) -> bool:
        """True once stop() was called."""
        return self._stopping.is_set()

    def drop_connections(self) -> None:
        """Close every current connection (clients see the connection reset, as when the controller restarts)."""
        with self._lock:
            connections = list(self._connections)
            self._connections.clear()
        for connection in connections:
            connection.close()

    def connections(self) -> list[Connection]:
        """The open connections (a snapshot)."""
        with self._lock:
            return list(self._connections)

    def wait_for_clients(self, timeout: float = POLL_INTERVAL) -> bool:
        """Block until a connection is open, at most `timeout` s; True when one is. A streamer with nobody to send
        to waits here instead of waking every control cycle."""
        with self._connected:
            return self._connected.wait_for(lambda: bool(self._connections) or self._stopping.is_set(), timeout) \
                and bool(self._connections)

    def spawn(self, target, role: str, *args) -> threading.Thread:
        """Start a daemon thread of this server (joined by stop())."""
        thread = threading.Thread(target=target, args=args, name=f"{type(self).__name__}:{self.port}:{role}",
                                  daemon=True)
        with self._lock:
            self._threads = [t for t in self._threads if t.is_alive()]
            self._threads.append(thread)
        thread.start()
        return thread

    # ------------------------------------------------------------------------------------------------ subclass hooks
    def configure(self, sock: socket.socket) -> None:
        """Socket options of this port's connections (TCP_NODELAY is always set)."""

    def on_start(self) -> None:
        """Start this port's own threads (streamers)."""

    def serve(self, connection: Connection) -> None:
        """What a connection does; returns when it is over."""
        raise NotImplementedError

    # ------------------------------------------------------------------------------------------------ helpers
    def read_chunks(self, connection: Connection, keep_until_handled: bool = False) -> Iterator[bytes]:
        """What the client sends, chunk by chunk, until its end of stream or reset, a close or the server's stop.

        With `keep_until_handled` a chunk stays in the socket until the caller asks for the next one (it is peeked,
        then taken): a look at the socket from another thread sees every byte not yet handled."""
        flags = socket.MSG_PEEK if keep_until_handled else 0
        while not connection.closed.is_set() and not self._stopping.is_set():
            try:
                readable, _, _ = select.select([connection.sock], [], [], POLL_INTERVAL)
            except (OSError, ValueError):
                return
            if not readable:
                continue
            try:
                data = connection.sock.recv(RECEIVE_SIZE, flags)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                return
            if not data:
                return
            yield data
            if keep_until_handled and not _take(connection.sock, len(data)):
                return

    def hold_while_frozen(self) -> None:
        """Block while the fault channel freezes the streams (a frozen controller answers late, not never)."""
        faults = self.controller.faults
        while faults.streams_frozen and not self._stopping.is_set():
            self._stopping.wait(min(POLL_INTERVAL, faults.frozen_remaining()) or 0.001)

    def due_time(self) -> float:
        """Monotonic time at which data produced now may be sent (now + the injected latency)."""
        return time.monotonic() + self.controller.faults.latency

    # ------------------------------------------------------------------------------------------------ threads
    def _accept_loop(self) -> None:
        listener = self._listener
        while listener is not None and not self._stopping.is_set():
            try:
                readable, _, _ = select.select([listener], [], [], POLL_INTERVAL)
            except (OSError, ValueError):
                return
            if readable and not self._accept_waiting(listener):
                return
            self._log_refusals(idle=not readable)

    def _accept_waiting(self, listener: socket.socket) -> bool:
        """Take every connection waiting in the listen backlog; False once the listener is closed."""
        while True:
            try:
                sock, peer = listener.accept()
            except (BlockingIOError, InterruptedError):
                return True
            except OSError:
                return False
            with self._lock:
                full = len(self._connections) >= self.max_connections
            if full:
                self._refuse(sock)
                continue
            connection = Connection(sock, peer, self.controller.faults.generation)
            try:
                sock.setblocking(False)
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self.configure(sock)
            except OSError:  # the client already went away
                connection.close()
                continue
            with self._connected:
                self._connections.add(connection)
                self._connected.notify_all()
            self.spawn(self._serve_then_forget, f"client-{peer[1]}", connection)

    def _refuse(self, sock: socket.socket) -> None:
        """Reset a connection beyond max_connections at once (no thread, no reading), counted for the log."""
        self._refused += 1
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, _RESET_ON_CLOSE)
        except OSError:
            pass
        sock.close()
        self._log_refusals(idle=False)

    def _log_refusals(self, idle: bool) -> None:
        """One line for the refusals not yet logged: at most once per REFUSAL_LOG_INTERVAL, or when the port idles."""
        now = time.monotonic()
        if not self._refused or (not idle and now - self._refusals_logged_at < REFUSAL_LOG_INTERVAL):
            return
        log.warning("%s:%d refused %d connection(s): %d clients are connected, the most one port serves",
                    type(self).__name__, self.port, self._refused, self.max_connections)
        self._refused = 0
        self._refusals_logged_at = now

    def _serve_then_forget(self, connection: Connection) -> None:
        try:
            self.serve(connection)
        except Exception:  # noqa: BLE001 - a bug serving one client must not take the port down; log it
            log.exception("%s: serving %s failed", type(self).__name__, connection)
        finally:
            self._forget(connection)

    def _forget(self, connection: Connection) -> None:
        connection.close()
        with self._lock:
            self._connections.discard(connection)
        self.on_disconnect(connection)

    def on_disconnect(self, connection: Connection) -> None:
        """Called once a connection is closed and forgotten (per-connection bookkeeping of subclasses)."""

    def _watch_drops(self) -> None:
        faults = self.controller.faults
        seen = faults.generation
        while not self._stopping.is_set():
            current = faults.wait_generation(seen, timeout=POLL_INTERVAL)
            if current > seen:
                seen = current
                with self._lock:
                    stale = [c for c in self._connections if c.generation < current]
                    self._connections.difference_update(stale)
                for connection in stale:
                    connection.close()


def _take(sock: socket.socket, size: int) -> bool:
    """Take `size` bytes already peeked out of `sock`; False when the connection failed meanwhile."""
    while size > 0:
        try:
            taken = len(sock.recv(size))
        except (BlockingIOError, InterruptedError):
            select.select([sock], [], [], POLL_INTERVAL)
            continue
        except OSError:
            return False
        if not taken:
            return False
        size -= taken
    return True
