"""Transport of the primary (30001), secondary (30002) and realtime (30003) interfaces.

Bytes come from the pure serialisers (`packets`, `realtime`); URScript received on any of the three ports is cut
into programs by `script_intake` and handed to the controller's program runner (a new program replaces the running
one).  Every server honours `controller.faults`: frozen streams send nothing, latency delays each send, and a new
drop generation closes every connection accepted before it.

Listening, accepting, connections and drops: tcp_server.TCPServer. Each connection has a reader thread (URScript
intake). Primary/secondary connections have a writer thread each (version message, 10 Hz robot state, robot
messages on 30001) that gives up on a client that has not taken its data for SEND_TIMEOUT seconds. The realtime
server has one writer for all clients that sends every cycle, in order (`controller.cycles_after`), and never
waits for a client (a package a slow client has no room for is skipped for that client): a client that stops
reading stops receiving ("Sending discontinued", as the controller logs) but its connection stays open for
scripts — ur_rtde's control interface connects to 30003, never reads, and uploads its script there.
"""
import collections
import logging
import math
import queue
import socket
import threading
import time

from sim_ursim.messages import SafetyModeMessage
from sim_ursim.models import build_date
from sim_ursim.primary import commands as primary_commands
from sim_ursim.primary import packets, realtime
from sim_ursim.primary.script_intake import IntakeOverflow, ScriptAssembler
from sim_ursim.tcp_server import POLL_INTERVAL, Connection, TCPServer
from sim_ursim.vocabulary import CommandRefused

log = logging.getLogger(__name__)

STATE_PERIOD = 0.1  # 10 Hz robot state on 30001/30002
SEND_TIMEOUT = 2.0  # a primary client that takes nothing for this long is disconnected
REALTIME_STALL_LIMIT = 1.0  # a realtime client whose unsent bytes have not drained for this long is discontinued
PRIMARY_SEND_BUFFER = 64 * 1024  # kernel send buffer of a 30001/30002 connection: several seconds of state
REALTIME_SEND_BUFFER = 64 * 1024  # kernel send buffer of a 30003 connection: about half a second of packages


class _InterfaceServer(TCPServer):
    """URScript intake shared by the three ports; a subclass names its `origin` (passed with each program) and says
    what a new client is sent (`_on_connect`)."""

    origin: str

    def serve(self, connection: Connection) -> None:
        self._on_connect(connection)
        self._read_scripts(connection)

    def _read_scripts(self, connection: Connection) -> None:
        """Read the client's URScript to its end of stream, whatever the writer does, and run each program.

        A client that sends more than the intake holds without completing a program is dropped with a logged reason
        (script_intake.IntakeOverflow).
        """
        assembler = ScriptAssembler()
        for data in self.read_chunks(connection):
            try:
                programs = assembler.feed(data)
            except IntakeOverflow as overflow:
                log.warning("port %s: %s dropped: %s", self.port, connection, overflow)
                return
            for program in programs:
                self._submit(program)

    def _submit(self, program: str) -> None:
        if self.origin != "realtime" and primary_commands.execute(program, self.controller):
            return
        try:
            self.controller.run_program(program, self.origin)
        except CommandRefused as refusal:
            log.warning("port %s: URScript not run: %s", self.port, refusal)
        except Exception:  # noqa: BLE001 - an interpreter bug must not cut the client's connection; log it
            log.exception("port %s: running the received URScript failed", self.port)

    def _on_connect(self, connection: Connection) -> None:
        """Start whatever this port sends to a new client."""
        raise NotImplementedError


class DelayLine:
    """Outgoing data with the time each may be sent (the fault channel's added latency delays data, not the rate)."""

    def __init__(self):
        self._items: collections.deque[tuple[float, bytes]] = collections.deque()   # (due, data)

    def put(self, data: bytes, due: float) -> None:
        """Queue `data` for sending at monotonic time `due` (items keep their order)."""
        self._items.append((due, data))

    def take_due(self, now: float) -> list[bytes]:
        """Remove and return, in order, every item due at `now`."""
        due = []
        while self._items and self._items[0][0] <= now:
            due.append(self._items.popleft()[1])
        return due

    @property
    def next_due(self) -> float:
        """Monotonic time the oldest item is due (infinity when empty)."""
        return self._items[0][0] if self._items else math.inf


class PrimaryServer(_InterfaceServer):
    """Port 30001 (robot_messages=True: also text, key, error, runtime-exception, safety-mode and popup messages
    from the controller's message bus) or 30002 (robot_messages=False: version message and robot state only)."""

    def __init__(self, controller, host, port, robot_messages=True):
        super().__init__(controller, host, port)
        self.robot_messages = robot_messages
        self.origin = "primary" if robot_messages else "secondary"

    def configure(self, sock: socket.socket) -> None:
        # Bounded kernel buffering (Linux would grow it to megabytes): a client that stops reading fills it within
        # seconds of robot state and is then disconnected after SEND_TIMEOUT.
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, PRIMARY_SEND_BUFFER)

    def _on_connect(self, connection):
        self.spawn(self._stream, "writer", connection)

    def _stream(self, connection: Connection) -> None:
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
            while not self._stopping.is_set() and connection.can_send:
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
                    if not connection.send_all(data, SEND_TIMEOUT):
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
            connection.stop_sending()  # the reader closes the connection once it has read everything

    def _timestamp_ms(self) -> int:
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
        self.stalled_since: float | None = None
        self.discontinued = False

    def offer(self, package: bytes, now: float) -> None:
        """Send `package` without waiting; while earlier bytes are still unsent, this package is skipped (as the
        controller skips packages); a client stalled for REALTIME_STALL_LIMIT s is discontinued."""
        if self.discontinued or not self.connection.can_send:
            return
        if self.unsent:
            self.unsent = self._send(self.unsent)
            if self.unsent:
                if self.stalled_since is not None and now - self.stalled_since > REALTIME_STALL_LIMIT:
                    self.discontinued = True
                    log.info("realtime client %s does not read: sending discontinued", self.connection.peer)
                return
        self.unsent = self._send(package)
        self.stalled_since = now if self.unsent else None

    def _send(self, data: bytes) -> bytes:
        """Bytes of `data` the kernel did not accept."""
        try:
            sent = self.connection.sock.send(data)
        except BlockingIOError:
            return data
        except OSError:  # the client went away; its reader still takes what it sent
            self.connection.stop_sending()
            return b""
        return data[sent:]


class RealtimeServer(_InterfaceServer):
    """Port 30003: the realtime package of the emulated version every control cycle (125 Hz CB3, 500 Hz e-series)."""

    origin = "realtime"

    def __init__(self, controller, host, port):
        super().__init__(controller, host, port)
        self._clients = []
        self._clients_lock = threading.Lock()

    def on_start(self) -> None:
        self.spawn(self._broadcast, "broadcast")

    def configure(self, sock: socket.socket) -> None:
        # A modest kernel send buffer, so a client that stops reading is noticed within a second or two, while a
        # reading client still has its own receive buffer as slack.
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, REALTIME_SEND_BUFFER)

    def _on_connect(self, connection):
        with self._clients_lock:
            self._clients.append(_RealtimeClient(connection))

    def discontinued_count(self) -> int:
        """Connected clients the stream has given up on (they still may send scripts)."""
        with self._clients_lock:
            return sum(1 for c in self._clients if c.discontinued and not c.connection.closed.is_set())

    def _broadcast(self) -> None:
        try:
            self._broadcast_cycles()
        finally:
            self.controller.forget_reader("realtime")

    def _broadcast_cycles(self) -> None:
        controller = self.controller
        version = tuple(controller.version)
        faults = controller.faults
        delayed = DelayLine()
        cycle = controller.state().cycle
        while not self._stopping.is_set():
            if not self.connections():  # nobody to send to: wait for a client, not for every cycle
                controller.forget_reader("realtime")  # nor make a fast clock wait for this idle stream
                self.wait_for_clients()
                cycle = controller.state().cycle
                continue
            states = controller.cycles_after(cycle, timeout=POLL_INTERVAL, reader="realtime")
            if not states:  # no new cycle: timed out, or the control loop has stopped
                self._stopping.wait(controller.period)
                continue
            cycle = states[-1].cycle
            with self._clients_lock:
                self._clients = [c for c in self._clients if not c.connection.closed.is_set()]
                clients = list(self._clients)
            if not clients or faults.streams_frozen:
                continue
            now = time.monotonic()
            for state in states:  # every cycle, in order, late rather than never (as the RTDE stream)
                delayed.put(realtime.realtime_package(version, realtime.realtime_values(state)), now + faults.latency)
            for package in delayed.take_due(now):
                for client in clients:
                    client.offer(package, now)
