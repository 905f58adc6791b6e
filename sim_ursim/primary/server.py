"""Transport of the primary (30001), secondary (30002) and realtime (30003) interfaces.

Bytes come from the pure serialisers (`packets`, `realtime`); URScript received on any of the three ports is cut
into programs by `script_intake` and handed to the controller's program runner (a new program replaces the running
one).  Every server honours `controller.faults`: frozen streams send nothing, latency delays each send, and a new
drop generation closes every connection accepted before it.

Sockets are non-blocking; each connection has a reader thread (URScript intake).  Primary/secondary connections
have a writer thread each (version message, 10 Hz robot state, robot messages on 30001) that gives up on a client
that has not taken its data for SEND_TIMEOUT seconds.  The realtime server has one writer for all clients, paced by
`controller.wait_cycle`, that never waits for a client: a client that stops reading stops receiving ("Sending
discontinued", as the controller logs) but its connection stays open for scripts — ur_rtde's control interface
connects to 30003, never reads, and uploads its script there.
"""
import collections
import logging
import math
import queue
import select
import socket
import threading
import time

from sim_ursim.controller import CommandRefused
from sim_ursim.messages import SafetyModeMessage
from sim_ursim.models import build_date
from sim_ursim.primary import packets, realtime
from sim_ursim.primary import commands as primary_commands
from sim_ursim.primary.script_intake import ScriptAssembler

log = logging.getLogger(__name__)

STATE_PERIOD = 0.1  # 10 Hz robot state on 30001/30002
SEND_TIMEOUT = 2.0  # a primary client that takes nothing for this long is disconnected
REALTIME_STALL_LIMIT = 1.0  # a realtime client whose unsent bytes have not drained for this long is discontinued
PRIMARY_SEND_BUFFER = 64 * 1024  # kernel send buffer of a 30001/30002 connection: several seconds of state
REALTIME_SEND_BUFFER = 64 * 1024  # kernel send buffer of a 30003 connection: about half a second of packages
POLL_INTERVAL = 0.2  # how often idle threads look at the stop flag
RECEIVE_SIZE = 65536


class _Connection:
    """One accepted client socket (non-blocking) and the drop generation it belongs to."""

    def __init__(self, sock, peer, generation):
        self.sock = sock
        self.peer = peer
        self.generation = generation
        self.closed = threading.Event()

    def close(self):
        """Close the socket once; both directions' threads notice through `closed`."""
        if self.closed.is_set():
            return
        self.closed.set()
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.sock.close()


def send_all(connection, data, timeout):
    """Write all of `data` to a non-blocking socket, waiting at most `timeout` s for the client to take it;
    False (the connection is closed) when it does not."""
    view = memoryview(data)
    deadline = time.monotonic() + timeout
    while view:
        if connection.closed.is_set():
            return False
        try:
            sent = connection.sock.send(view)
            view = view[sent:]
            continue
        except BlockingIOError:
            pass
        except OSError:
            connection.close()
            return False
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            log.info("%s did not read for %.1f s: disconnected", connection.peer, timeout)
            connection.close()
            return False
        try:
            select.select([], [connection.sock], [], min(remaining, POLL_INTERVAL))
        except (OSError, ValueError):
            connection.close()
            return False
    return True


class _InterfaceServer:
    """Listening socket, accept loop, drop-generation watcher and URScript intake shared by the three ports; a
    subclass names its `origin` (passed with each program) and says what a new client is sent."""

    def __init__(self, controller, host, port):
        self.controller = controller
        self.host = host
        self.port = port
        self._listener = None
        self._stopping = threading.Event()
        self._connections = set()
        self._lock = threading.Lock()
        self._threads = []

    # lifecycle ---------------------------------------------------------------------------------------------------
    def start(self):
        """Bind host:port and start serving (SO_REUSEADDR, so a restarted simulator can bind at once)."""
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            listener.bind((self.host, self.port))
            listener.listen(16)
        except OSError:
            listener.close()
            raise
        listener.setblocking(False)
        self.port = listener.getsockname()[1]  # the port the OS chose when asked for port 0
        self._listener = listener
        self._spawn(self._accept_loop, "accept")
        self._spawn(self._watch_drops, "drops")

    def stop(self):
        """Stop accepting, close every connection and join the server's threads."""
        self._stopping.set()
        if self._listener is not None:
            self._listener.close()
        self.drop_connections()
        for thread in list(self._threads):
            if thread is not threading.current_thread():
                thread.join(timeout=2.0)

    def drop_connections(self):
        """Close every current connection (clients see the connection reset, as when the controller restarts)."""
        with self._lock:
            connections = list(self._connections)
            self._connections.clear()
        for connection in connections:
            connection.close()

    # threads ------------------------------------------------------------------------------------------------------
    def _spawn(self, target, role, *args):
        thread = threading.Thread(target=target, args=args, name=f"{type(self).__name__}:{self.port}:{role}",
                                  daemon=True)
        self._threads = [t for t in self._threads if t.is_alive()]
        self._threads.append(thread)
        thread.start()
        return thread

    def _accept_loop(self):
        while not self._stopping.is_set():
            try:
                readable, _, _ = select.select([self._listener], [], [], POLL_INTERVAL)
            except (OSError, ValueError):
                return
            if not readable:
                continue
            try:
                sock, peer = self._listener.accept()
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                return
            connection = _Connection(sock, peer, self.controller.faults.generation)
            try:
                sock.setblocking(False)
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._configure(sock)
            except OSError:  # the client already went away
                connection.close()
                continue
            with self._lock:
                self._connections.add(connection)
            self._on_connect(connection)
            self._spawn(self._read_scripts, "reader", connection)

    def _watch_drops(self):
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

    def _forget(self, connection):
        connection.close()
        with self._lock:
            self._connections.discard(connection)

    def _read_scripts(self, connection):
        assembler = ScriptAssembler()
        while not connection.closed.is_set() and not self._stopping.is_set():
            try:
                readable, _, _ = select.select([connection.sock], [], [], POLL_INTERVAL)
            except (OSError, ValueError):
                break
            if not readable:
                continue
            try:
                data = connection.sock.recv(RECEIVE_SIZE)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                break
            if not data:
                break
            for program in assembler.feed(data):
                self._submit(program)
        self._forget(connection)

    def _submit(self, program):
        if self.origin != "realtime" and primary_commands.execute(program, self.controller):
            return
        try:
            self.controller.run_program(program, self.origin)
        except CommandRefused as refusal:
            log.warning("port %s: URScript not run: %s", self.port, refusal)
        except Exception:  # noqa: BLE001 - an interpreter bug must not cut the client's connection; log it
            log.exception("port %s: running the received URScript failed", self.port)

    def _configure(self, sock):
        """Socket options of this port's connections (none beyond TCP_NODELAY by default)."""

    def _on_connect(self, connection):
        """Start whatever this port sends to a new client."""
        raise NotImplementedError


class DelayLine:
    """Outgoing data with the time each may be sent (the fault channel's added latency delays data, not the rate)."""

    def __init__(self):
        self._items = collections.deque()

    def put(self, data, due):
        """Queue `data` for sending at monotonic time `due` (items keep their order)."""
        self._items.append((due, data))

    def take_due(self, now):
        """Remove and return, in order, every item due at `now`."""
        due = []
        while self._items and self._items[0][0] <= now:
            due.append(self._items.popleft()[1])
        return due

    @property
    def next_due(self):
        """Monotonic time the oldest item is due (infinity when empty)."""
        return self._items[0][0] if self._items else math.inf


class PrimaryServer(_InterfaceServer):
    """Port 30001 (robot_messages=True: also text, key, error, runtime-exception, safety-mode and popup messages
    from the controller's message bus) or 30002 (robot_messages=False: version message and robot state only)."""

    def __init__(self, controller, host, port, robot_messages=True):
        super().__init__(controller, host, port)
        self.robot_messages = robot_messages
        self.origin = "primary" if robot_messages else "secondary"

    def _configure(self, sock):
        # Bounded kernel buffering (Linux would grow it to megabytes): a client that stops reading fills it within
        # seconds of robot state and is then disconnected after SEND_TIMEOUT.
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, PRIMARY_SEND_BUFFER)

    def _on_connect(self, connection):
        self._spawn(self._stream, "writer", connection)

    def _stream(self, connection):
        controller = self.controller
        faults = controller.faults
        version = tuple(controller.version)
        arm = packets.arm_description(controller.model)
        subscription = controller.messages.subscribe() if self.robot_messages else None
        delayed = DelayLine()
        try:
            greeting = packets.version_message(
                version, packets.primary_build_date(build_date(controller.version)), self._timestamp_ms()
            )
            delayed.put(greeting, time.monotonic() + faults.latency)
            next_state = time.monotonic()
            while not self._stopping.is_set() and not connection.closed.is_set():
                now = time.monotonic()
                if faults.streams_frozen:
                    # Nothing is produced or sent; robot messages wait in the subscription queue.
                    if connection.closed.wait(min(faults.frozen_remaining(), POLL_INTERVAL)):
                        return
                    next_state = time.monotonic()
                    continue
                if now >= next_state:
                    delayed.put(packets.robot_state_message(controller.state(), arm, version), now + faults.latency)
                    next_state = max(next_state + STATE_PERIOD, now)
                for data in delayed.take_due(now):
                    if not send_all(connection, data, SEND_TIMEOUT):
                        return
                wait = max(0.0, min(next_state, delayed.next_due) - time.monotonic())
                if subscription is None:
                    if connection.closed.wait(wait):
                        return
                    continue
                try:
                    message = subscription.get(timeout=wait)
                except queue.Empty:
                    continue
                if isinstance(message, SafetyModeMessage):
                    # A controller's robot-mode data and safety-mode message describe the same instant: send the
                    # state that already shows the new safety mode right before the message, not up to 100 ms later.
                    state = _state_showing_safety_mode(controller, message.safety_mode_type)
                    delayed.put(packets.robot_state_message(state, arm, version), time.monotonic() + faults.latency)
                    next_state = time.monotonic() + STATE_PERIOD
                data = packets.encode_robot_message(message, version, self._timestamp_ms())
                delayed.put(data, time.monotonic() + faults.latency)
        finally:
            if subscription is not None:
                controller.messages.unsubscribe(subscription)
            self._forget(connection)

    def _timestamp_ms(self):
        return int(self.controller.state().timestamp * 1000)


def _state_showing_safety_mode(controller, safety_mode, cycles=5):
    """The first snapshot whose safety mode is `safety_mode` (the message is published just before the snapshot
    that carries it), or the newest one after `cycles` control cycles."""
    state = controller.state()
    for _ in range(cycles):
        if state.safety_mode == safety_mode:
            break
        state = controller.wait_cycle(state.cycle, timeout=STATE_PERIOD)
    return state


class SecondaryServer(PrimaryServer):
    """Port 30002: the primary interface without robot messages."""

    def __init__(self, controller, host, port):
        super().__init__(controller, host, port, robot_messages=False)


class _RealtimeClient:
    """Per-client send state of the realtime stream: bytes a slow client has not taken yet, and whether the server
    has given up sending to it."""

    def __init__(self, connection):
        self.connection = connection
        self.unsent = b""
        self.stalled_since = None
        self.discontinued = False

    def offer(self, package, now):
        """Send `package` without waiting; while earlier bytes are still unsent, this package is skipped (as the
        controller skips packages); a client stalled for REALTIME_STALL_LIMIT s is discontinued."""
        if self.discontinued or self.connection.closed.is_set():
            return
        if self.unsent:
            self.unsent = self._send(self.unsent)
            if self.unsent:
                if now - self.stalled_since > REALTIME_STALL_LIMIT:
                    self.discontinued = True
                    log.info("realtime client %s does not read: sending discontinued", self.connection.peer)
                return
        self.unsent = self._send(package)
        self.stalled_since = now if self.unsent else None

    def _send(self, data):
        """Bytes of `data` the kernel did not accept."""
        try:
            sent = self.connection.sock.send(data)
        except BlockingIOError:
            return data
        except OSError:
            self.connection.close()
            return b""
        return data[sent:]


class RealtimeServer(_InterfaceServer):
    """Port 30003: the realtime package of the emulated version every control cycle (125 Hz CB3, 500 Hz e-series)."""

    origin = "realtime"

    def __init__(self, controller, host, port):
        super().__init__(controller, host, port)
        self._clients = []
        self._clients_lock = threading.Lock()

    def start(self):
        super().start()
        self._spawn(self._broadcast, "broadcast")

    def _configure(self, sock):
        # A modest kernel send buffer, so a client that stops reading is noticed within a second or two, while a
        # reading client still has its own receive buffer as slack.
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, REALTIME_SEND_BUFFER)

    def _on_connect(self, connection):
        with self._clients_lock:
            self._clients.append(_RealtimeClient(connection))

    def discontinued_count(self):
        """Connected clients the stream has given up on (they still may send scripts)."""
        with self._clients_lock:
            return sum(1 for c in self._clients if c.discontinued and not c.connection.closed.is_set())

    def _broadcast(self):
        controller = self.controller
        version = tuple(controller.version)
        faults = controller.faults
        delayed = DelayLine()
        cycle = controller.state().cycle
        while not self._stopping.is_set():
            state = controller.wait_cycle(cycle, timeout=POLL_INTERVAL)
            if state.cycle == cycle:  # no new cycle: timed out, or the control loop has stopped
                self._stopping.wait(controller.period)
                continue
            cycle = state.cycle
            with self._clients_lock:
                self._clients = [c for c in self._clients if not c.connection.closed.is_set()]
                clients = list(self._clients)
            if not clients or faults.streams_frozen:
                continue
            now = time.monotonic()
            delayed.put(realtime.realtime_package(version, realtime.realtime_values(state)), now + faults.latency)
            for package in delayed.take_due(now):
                for client in clients:
                    client.offer(package, now)
