"""RTDE server (port 30004): sockets, one session per client, and one streamer paced by the control cycle.

Transport only; the bytes come from `protocol`, names and values from `variables` and `inputs`; listening,
accepting, the connection set and fault drops are tcp_server.TCPServer's.
Threads: an acceptor, a reader per connection (setup requests and input packages), and ONE streamer that takes
every control cycle's snapshot in order (`controller.cycles_after`), packs every distinct output recipe once per
cycle and queues it on every started session: a stream carries every cycle (at its decimation), late rather than
never, as a controller's does. Input packages are applied at the start of the next control cycle
(`controller.at_cycle_start`), all those received meanwhile together. Sends are non-blocking into a bounded
per-session buffer, so a client that stops reading never stalls the others; like the real controller, the server
closes a client whose backlog overflows. A recipe whose reply would not fit one package is refused (recipe id 0, no
types) with one short log line.
"""
import logging
import socket
import threading
import time
from collections import deque
from collections.abc import Callable, Collection
from typing import Any

from ..tcp_server import Connection, TCPServer
from ..vocabulary import ControllerState
from . import inputs, protocol, variables
from .protocol import PackageType
from .watchdog import watchdogs_of

log = logging.getLogger("sim_ursim.rtde")

DEFAULT_PORT = 30004
# A stalled client is dropped once this much output waits for it beyond the kernel's send buffer, itself fixed
# (no autotuning to megabytes) so that a client which stopped reading is noticed within seconds, not minutes.
DEFAULT_BACKLOG_LIMIT = 1024 * 1024
DEFAULT_SEND_BUFFER = 512 * 1024
MAX_RECIPE_ID = 255  # recipe ids travel as uint8
OUTPUT_RECIPE_ID = 1  # the controller supports one output recipe per connection; URCL's fake server also answers 1
_WAIT_TIMEOUT = 0.5


class OutputRecipe:
    """A validated output recipe: names, precompiled struct, readers, decimation and the id sent in U packages."""

    def __init__(self, names, types, recipe_id, decimation, protocol_version):
        self.names = tuple(names)
        self.types = tuple(types)
        self.struct = protocol.recipe_struct(types)
        self.readers = variables.output_readers(names)
        self.decimation = decimation
        # Protocol 1 data packages carry no recipe id (URCL data_package.cpp parses it only for protocol 2).
        self.wire_recipe_id = recipe_id if protocol_version >= 2 else None
        self.header = protocol.data_package_header(self.wire_recipe_id, self.struct.size)
        self.cache_key = (self.names, self.wire_recipe_id)

    def pack(self, state):
        """The U package of this recipe for one controller state."""
        return self.header + self.struct.pack(*variables.read_flat_values(self.readers, state))


class InputRecipe:
    """A validated input recipe: names, types and the struct of its data packages."""

    def __init__(self, recipe_id, names, types):
        self.recipe_id = recipe_id
        self.names = tuple(names)
        self.types = tuple(types)
        self.struct = protocol.recipe_struct(types)


class Session:
    """One client connection: its negotiated protocol, recipes, input values and outgoing byte backlog."""

    def __init__(self, connection: Connection, number: int, backlog_limit: int):
        self.connection = connection
        self.sock = connection.sock
        self.peer = connection.peer
        self.number = number
        self.backlog_limit = backlog_limit
        self.protocol_version = 1
        self.output_recipe: OutputRecipe | None = None
        self.output_recipe_requested = False
        self.input_recipes: dict[int, Any] = {}
        self.next_input_recipe_id = 1
        self.input_values: dict[str, Any] = {}
        self.streaming = False
        self.next_cycle = 0
        self.closed = False
        self.close_reason = None
        self._lock = threading.Lock()
        self._pending = bytearray()
        self._delayed: deque[tuple[float, bytes]] = deque()  # (due monotonic time, package) while latency is injected

    def __repr__(self) -> str:
        return f"RTDE client #{self.number} {self.peer[0]}:{self.peer[1]}"

    def send(self, data: bytes, due: float | None = None) -> None:
        """Queue bytes (after `due` when latency is injected) and push what the socket takes without blocking."""
        with self._lock:
            if self.closed:
                return
            if due is None and not self._delayed:
                self._pending += data
            else:
                self._delayed.append((due or 0.0, data))
            self._flush_locked()

    def flush(self) -> None:
        """Move due delayed packages to the backlog and push the backlog without blocking."""
        with self._lock:
            if not self.closed and (self._pending or self._delayed):
                self._flush_locked()

    def _flush_locked(self):
        now = time.monotonic()
        while self._delayed and self._delayed[0][0] <= now:
            self._pending += self._delayed.popleft()[1]
        while self._pending:
            try:
                sent = self.sock.send(self._pending, socket.MSG_DONTWAIT)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as error:
                self._close_locked(f"send failed: {error}")
                return
            del self._pending[:sent]
        if len(self._pending) > self.backlog_limit:
            self._close_locked(f"client does not read its data ({len(self._pending)} bytes waiting)")

    def has_unread_input(self) -> bool:
        """True while bytes the client sent wait in the socket, not yet handled by the reader thread."""
        try:
            return bool(self.sock.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT))
        except OSError:   # nothing waiting (BlockingIOError), or the connection is gone
            return False

    def close(self, reason: str) -> None:
        """Close the connection once (the reader thread wakes up with EOF and exits)."""
        with self._lock:
            self._close_locked(reason)

    def _close_locked(self, reason):
        if self.closed:
            return
        self.closed = True
        self.streaming = False
        self.close_reason = reason
        self._pending.clear()
        self._delayed.clear()
        self.connection.close()


class RTDEServer(TCPServer):
    """RTDE interface of one simulated controller, listening on (host, port)."""

    def __init__(self, controller, host="127.0.0.1", port=DEFAULT_PORT, backlog_limit=DEFAULT_BACKLOG_LIMIT,
                 send_buffer=DEFAULT_SEND_BUFFER):
        super().__init__(controller, host, port)
        self.backlog_limit = backlog_limit
        self.send_buffer = send_buffer
        self._version = tuple(controller.version)[:4]
        self._control_rate = 1.0 / controller.period
        self._sessions_lock = threading.Lock()
        self._sessions = []
        self._session_count = 0
        self._input_owners = {}  # input name -> Session that controls it (only one client per variable)

    # --- life cycle ---------------------------------------------------------------------------------------------

    def on_start(self) -> None:
        watchdogs_of(self.controller).unread_input = self._unread_input
        self.spawn(self._stream_loop, "stream")
        log.info("RTDE version %s, control rate %.0f Hz", ".".join(map(str, self._version)), self._control_rate)

    def configure(self, sock: socket.socket) -> None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.send_buffer)

    def sessions(self) -> list[Session]:
        """The open sessions (a snapshot)."""
        with self._sessions_lock:
            return list(self._sessions)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()

    # --- connections --------------------------------------------------------------------------------------------

    def serve(self, connection: Connection) -> None:
        with self._sessions_lock:
            self._session_count += 1
            session = Session(connection, self._session_count, self.backlog_limit)
            self._sessions.append(session)
        log.info("%s connected", session)
        buffer = bytearray()
        try:
            # Each chunk stays in the socket until handled: the input watchdogs' look at it (has_unread_input) then
            # never misses a package that was read but not yet noted.
            for chunk in self.read_chunks(connection, keep_until_handled=True):
                buffer += chunk
                while not session.closed:
                    package = protocol.split_package(buffer)
                    if package is None:
                        break
                    package_type, payload, consumed = package
                    del buffer[:consumed]
                    self._handle(session, package_type, payload)
                if session.closed:
                    break
        except protocol.ProtocolError as error:
            log.warning("%s sent a malformed package: %s", session, error)
        finally:
            reason = session.close_reason or ("connections dropped by fault injection or stop"
                                              if connection.closed.is_set() else "client closed the connection")
            session.close(reason)
            self._forget_session(session)
            log.info("%s disconnected (%s)", session, session.close_reason)

    def _unread_input(self, name: str) -> bool:
        """True while the client that controls input `name` has bytes waiting unread (see rtde.watchdog)."""
        with self._sessions_lock:
            owner = self._input_owners.get(name)
        return owner is not None and owner.has_unread_input()

    def _forget_session(self, session: Session) -> None:
        with self._sessions_lock:
            if session in self._sessions:
                self._sessions.remove(session)
            for name in [name for name, owner in self._input_owners.items() if owner is session]:
                del self._input_owners[name]

    def _reply(self, session: Session, data: bytes) -> None:
        latency = self.controller.faults.latency
        session.send(data, due=time.monotonic() + latency if latency > 0 else None)

    # --- requests -----------------------------------------------------------------------------------------------

    def _handle(self, session: Session, package_type: int, payload: bytes) -> None:
        handler = self._handlers.get(package_type)
        if handler is None:
            log.warning("%s sent unknown package type %d (%d bytes); ignored", session, package_type, len(payload))
            return
        handler(self, session, payload)

    def _on_protocol_version(self, session: Session, payload: bytes) -> None:
        requested = protocol.parse_protocol_version_request(payload)
        accepted = requested in protocol.SUPPORTED_PROTOCOL_VERSIONS
        if accepted:
            session.protocol_version = requested
        log.debug("%s asks protocol %d: %s", session, requested, "accepted" if accepted else "refused")
        self._reply(session, protocol.pack_accepted_reply(PackageType.REQUEST_PROTOCOL_VERSION, accepted))

    def _on_controller_version(self, session: Session, payload: bytes) -> None:
        self._reply(session, protocol.pack_controller_version_reply(*self._version))

    def _on_setup_outputs(self, session: Session, payload: bytes) -> None:
        frequency, names = protocol.parse_setup_outputs_request(payload, session.protocol_version)
        types = [variables.output_type(name, self._version) for name in names]
        # Protocol 1 has no frequency field: it streams every control cycle.
        rate = self._control_rate if frequency is None else frequency
        fits = protocol.setup_reply_fits(types)
        valid = bool(names) and fits and protocol.NOT_FOUND not in types and protocol.is_valid_frequency(rate)
        recipe_id = OUTPUT_RECIPE_ID if valid else 0
        session.output_recipe_requested = True
        session.output_recipe = None
        if valid:
            decimation = protocol.output_decimation(rate, self._control_rate)
            session.output_recipe = OutputRecipe(names, types, recipe_id, decimation, session.protocol_version)
            log.info("%s output recipe: %d variables at %.1f Hz", session, len(names),
                     self._control_rate / decimation)
        elif not fits:
            log.warning("%s output recipe refused: %s", session, protocol.oversized_reply_reason(types))
            types = []
        else:
            missing = [name for name, kind in zip(names, types, strict=True) if kind == protocol.NOT_FOUND]
            log.warning("%s output recipe refused (frequency %r, not found: %s)", session, frequency,
                        protocol.abbreviated(missing))
        self._reply(session, protocol.pack_setup_outputs_reply(recipe_id, types, session.protocol_version))

    def _on_setup_inputs(self, session: Session, payload: bytes) -> None:
        names = protocol.parse_setup_inputs_request(payload)
        with self._sessions_lock:
            types = []
            for name in names:
                kind = variables.input_type(name, self._version)
                owner = self._input_owners.get(name)
                if kind != protocol.NOT_FOUND and owner is not None and owner is not session:
                    kind = protocol.IN_USE
                types.append(kind)
            fits = protocol.setup_reply_fits(types)
            valid = bool(names) and fits and protocol.NOT_FOUND not in types and protocol.IN_USE not in types
            if valid:
                for name in names:
                    self._input_owners[name] = session
        if valid and session.next_input_recipe_id > MAX_RECIPE_ID:
            valid = False
            log.warning("%s has used all %d input recipe ids", session, MAX_RECIPE_ID)
        if valid:
            recipe_id = session.next_input_recipe_id
            session.next_input_recipe_id += 1
            session.input_recipes[recipe_id] = InputRecipe(recipe_id, names, types)
        elif not fits:
            recipe_id = 0
            log.warning("%s input recipe refused: %s", session, protocol.oversized_reply_reason(types))
            types = []
        else:
            recipe_id = 0
            log.warning("%s input recipe refused: %s", session, protocol.abbreviated(
                [f"{n}={t}" for n, t in zip(names, types, strict=True) if t in (protocol.NOT_FOUND, protocol.IN_USE)]))
        self._reply(session, protocol.pack_setup_inputs_reply(recipe_id, types))

    def _on_start(self, session: Session, payload: bytes) -> None:
        accepted = session.output_recipe is not None or not session.output_recipe_requested
        if accepted:
            # The reply is queued before streaming is switched on, so no data package can overtake it.
            self._reply(session, protocol.pack_accepted_reply(PackageType.CONTROL_PACKAGE_START, True))
            session.next_cycle = self.controller.state().cycle + 1  # the first cycle after the reply
            session.streaming = session.output_recipe is not None
            log.info("%s started", session)
        else:
            self._reply(session, protocol.pack_accepted_reply(PackageType.CONTROL_PACKAGE_START, False))
            log.warning("%s start refused: its output recipe is invalid", session)

    def _on_pause(self, session: Session, payload: bytes) -> None:
        session.streaming = False
        self._reply(session, protocol.pack_accepted_reply(PackageType.CONTROL_PACKAGE_PAUSE, True))
        log.info("%s paused", session)

    def _on_data(self, session: Session, payload: bytes) -> None:
        recipe_id = protocol.data_package_recipe_id(payload)
        recipe = session.input_recipes.get(recipe_id)
        if recipe is None:
            self._complain(session, f"data package for unknown input recipe {recipe_id}")
            return
        try:
            _, flat = protocol.parse_data_package(payload, recipe.struct)
        except protocol.ProtocolError as error:
            self._complain(session, f"input recipe {recipe_id}: {error}")
            return
        received = dict(zip(recipe.names, protocol.group_values(recipe.types, flat)))
        watchdogs_of(self.controller).note_update(received)
        session.input_values.update(received)
        values = dict(session.input_values)  # the client's inputs as of this package, applied at the next cycle
        self.controller.at_cycle_start(lambda: self._apply_inputs(session, recipe_id, values, received.keys()))

    def _apply_inputs(self, session: Session, recipe_id: int, values: dict[str, Any],
                      changed: Collection[str]) -> None:
        """Apply one input package at the start of a control cycle (a refused value is reported to its client)."""
        try:
            inputs.apply_inputs(self.controller, values, changed)
        except ValueError as error:
            self._complain(session, f"input recipe {recipe_id}: {error}")

    def _on_text_message(self, session: Session, payload: bytes) -> None:
        try:
            message, source, level = protocol.parse_text_message(payload)
        except protocol.ProtocolError as error:
            log.warning("%s sent a malformed text message: %s", session, error)
            return
        log.info("%s message from %r (level %d): %s", session, source, level, message)

    def _complain(self, session: Session, text: str) -> None:
        """Log a client error; tell the client too, but only while streaming (never during setup, see §1.3)."""
        log.warning("%s: %s", session, text)
        if session.streaming:
            self._reply(session, protocol.pack_text_message(text, "RTDE", protocol.MessageLevel.ERROR,
                                                            session.protocol_version))

    _handlers: dict[int, Callable[["RTDEServer", Session, bytes], None]] = {
        PackageType.REQUEST_PROTOCOL_VERSION: _on_protocol_version,
        PackageType.GET_URCONTROL_VERSION: _on_controller_version,
        PackageType.CONTROL_PACKAGE_SETUP_OUTPUTS: _on_setup_outputs,
        PackageType.CONTROL_PACKAGE_SETUP_INPUTS: _on_setup_inputs,
        PackageType.CONTROL_PACKAGE_START: _on_start,
        PackageType.CONTROL_PACKAGE_PAUSE: _on_pause,
        PackageType.DATA_PACKAGE: _on_data,
        PackageType.TEXT_MESSAGE: _on_text_message,
    }

    # --- streaming ----------------------------------------------------------------------------------------------

    def _stream_loop(self) -> None:
        try:
            self._stream_cycles()
        finally:
            self.controller.forget_reader("rtde")

    def _stream_cycles(self) -> None:
        controller = self.controller
        last_cycle = controller.state().cycle
        while not self.stopping:
            if not self.connections():  # nobody to send to: wait for a client, not for every cycle
                controller.forget_reader("rtde")  # nor make a fast clock wait for this idle stream
                self.wait_for_clients()
                last_cycle = self._first_cycle_to_send(controller.state().cycle)
                continue
            states = controller.cycles_after(last_cycle, _WAIT_TIMEOUT, reader="rtde")
            if not states:
                if not controller.running:
                    # cycles_after returns at once while the control loop is stopped: do not spin meanwhile.
                    self._stopping.wait(_WAIT_TIMEOUT)
                continue
            if states[0].cycle > last_cycle + 1:
                log.warning("RTDE stream fell %d cycles behind the control loop: cycles %d-%d not sent",
                            states[0].cycle - last_cycle - 1, last_cycle + 1, states[0].cycle - 1)
            last_cycle = states[-1].cycle
            if controller.faults.streams_frozen:
                continue
            sessions = [session for session in self.sessions() if not session.connection.closed.is_set()]
            for state in states:  # every cycle, in order: a late frame is sent late, never dropped
                self._send_cycle(state, sessions)

    def _first_cycle_to_send(self, current: int) -> int:
        """The cycle to stream after, once clients are back: the present one, or earlier if a session that started
        meanwhile wants an earlier one."""
        return min([current, *(session.next_cycle - 1 for session in self.sessions() if session.streaming)])

    def _send_cycle(self, state: ControllerState, sessions: list[Session]) -> None:
        """Queue one cycle's data package on every started session whose decimation takes this cycle."""
        latency = self.controller.faults.latency
        due = time.monotonic() + latency if latency > 0 else None
        packed: dict[Any, bytes] = {}
        for session in sessions:
            recipe = session.output_recipe
            if not session.streaming or recipe is None or state.cycle < session.next_cycle:
                session.flush()
                continue
            session.next_cycle = state.cycle + recipe.decimation
            package = packed.get(recipe.cache_key)
            if package is None:
                try:
                    package = recipe.pack(state)
                except Exception:  # noqa: BLE001 - one bad recipe must not kill the stream of every client
                    log.exception("%s: packing its output recipe failed; closing it", session)
                    session.close("output recipe could not be packed")
                    continue
                packed[recipe.cache_key] = package
            session.send(package, due)

