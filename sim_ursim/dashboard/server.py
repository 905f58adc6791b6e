"""Dashboard server sockets: greeting, one reply line per command line, several clients at once.

Honours controller.faults: added latency delays every reply, a frozen window holds replies until it ends, and a
new drop generation closes every connection.
"""
import logging
import socket
import threading
import time

from . import protocol

log = logging.getLogger("sim_ursim.dashboard")

POLL_INTERVAL = 0.1  # s between checks of the stop flag and the drop generation while a client is silent
MAX_LINE = 64 * 1024


class DashboardServer:
    """Serves the dashboard protocol for `controller` on host:port (29999 by default)."""

    def __init__(self, controller, host="127.0.0.1", port=29999, on_shutdown=None):
        self.controller = controller
        self.host = host
        self.port = port
        self.on_shutdown = on_shutdown  # called after a `shutdown` command has been answered; must not block
        self._listener = None
        self._accept_thread = None
        self._stopping = threading.Event()
        self._connections = set()
        self._lock = threading.Lock()

    def start(self):
        """Bind and start accepting (returns once the port is listening)."""
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind((self.host, self.port))
        listener.listen(16)
        listener.settimeout(POLL_INTERVAL)
        self.port = listener.getsockname()[1]
        self._listener = listener
        self._stopping.clear()
        self._accept_thread = threading.Thread(target=self._accept_loop, name=f"dashboard-{self.port}", daemon=True)
        self._accept_thread.start()
        log.info("dashboard server listening on %s:%d", self.host, self.port)

    def stop(self):
        """Stop accepting, close every connection, and wait for the threads."""
        self._stopping.set()
        if self._accept_thread is not None:
            self._accept_thread.join(timeout=2.0)
            self._accept_thread = None
        if self._listener is not None:
            self._listener.close()
            self._listener = None
        self.drop_connections()
        with self._lock:
            threads = [thread for _, thread in self._connections]
        for thread in threads:
            thread.join(timeout=2.0)

    def drop_connections(self):
        """Close every client connection now (the clients see the socket close)."""
        with self._lock:
            connections = [connection for connection, _ in self._connections]
        for connection in connections:
            _close(connection)

    def _accept_loop(self):
        while not self._stopping.is_set():
            try:
                connection, peer = self._listener.accept()
            except socket.timeout:
                continue
            except OSError:
                break
            thread = threading.Thread(target=self._serve, args=(connection, peer), daemon=True,
                                      name=f"dashboard-client-{peer[0]}:{peer[1]}")
            with self._lock:
                self._connections.add((connection, thread))
            thread.start()

    def _serve(self, connection, peer):
        generation = self.controller.faults.generation
        log.info("dashboard: client %s:%d connected", *peer)
        try:
            connection.settimeout(POLL_INTERVAL)
            self._send(connection, protocol.GREETING)
            buffered = b""
            while not self._stopping.is_set() and self.controller.faults.generation == generation:
                try:
                    chunk = connection.recv(4096)
                except socket.timeout:
                    continue
                if not chunk:
                    break
                buffered += chunk
                if len(buffered) > MAX_LINE and b"\n" not in buffered:
                    log.warning("dashboard: %s:%d sent an over-long line; closing", *peer)
                    break
                while b"\n" in buffered:
                    raw, buffered = buffered.split(b"\n", 1)
                    if not self._answer(connection, raw.decode("utf-8", errors="replace"), peer):
                        return
        except OSError as error:
            log.info("dashboard: client %s:%d connection error: %s", peer[0], peer[1], error)
        finally:
            _close(connection)
            with self._lock:
                self._connections = {entry for entry in self._connections if entry[0] is not connection}
            log.info("dashboard: client %s:%d disconnected", *peer)

    def _answer(self, connection, line, peer):
        """Reply to one line; False when the connection must close afterwards."""
        reply = protocol.handle(line, self.controller)
        log.info("dashboard: %s:%d %r -> %r", peer[0], peer[1], line.strip(), reply.text)
        self._send(connection, reply.text)
        if reply.shutdown and self.on_shutdown is not None:
            self.on_shutdown()
        return not reply.close

    def _send(self, connection, text):
        faults = self.controller.faults
        # A frozen controller answers late rather than never: hold the reply until the window closes.
        while faults.streams_frozen and not self._stopping.is_set():
            time.sleep(min(POLL_INTERVAL, faults.frozen_remaining()) or 0.001)
        if faults.latency:
            time.sleep(faults.latency)
        connection.sendall((text + "\n").encode("utf-8"))


def _close(connection):
    try:
        connection.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    connection.close()
