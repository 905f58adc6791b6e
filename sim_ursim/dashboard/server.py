"""Dashboard server: greeting, one reply line per command line, several clients at once (on tcp_server.TCPServer).

Honours controller.faults: added latency delays every reply, a frozen window holds replies until it ends, and a
new drop generation closes every connection (the base's watcher). A line longer than MAX_LINE drops the client.
"""
import logging

from ..polyscope.program_tab import ProgramTab
from ..tcp_server import Connection, TCPServer
from . import protocol

log = logging.getLogger("sim_ursim.dashboard")

MAX_LINE = 64 * 1024  # bytes of one command line; the longest real command (load <path>) is far shorter
SEND_TIMEOUT = 2.0  # s a client may leave a reply unread before it is disconnected


class DashboardServer(TCPServer):
    """Serves the dashboard protocol for `controller` on host:port (29999 by default)."""

    def __init__(self, controller, host="127.0.0.1", port=29999, on_shutdown=None, programs=None):
        super().__init__(controller, host, port)
        self.on_shutdown = on_shutdown  # called after a `shutdown` command has been answered; must not block
        self.programs = programs or ProgramTab(controller)  # load/play: sim_ursim.polyscope.program_tab

    def serve(self, connection: Connection) -> None:
        log.info("dashboard: client %s connected", connection)
        if not self._send(connection, protocol.GREETING):
            return
        buffered = b""
        for chunk in self.read_chunks(connection):
            buffered += chunk
            while b"\n" in buffered:
                raw, buffered = buffered.split(b"\n", 1)
                if not self._answer(connection, raw.decode("utf-8", errors="replace")):
                    return
            if len(buffered) > MAX_LINE:
                log.warning("dashboard: %s sent an over-long line; closing", connection)
                return
        log.info("dashboard: client %s disconnected", connection)

    def _answer(self, connection: Connection, line: str) -> bool:
        """Reply to one line; False when the connection must close afterwards."""
        reply = protocol.handle(line, self.controller, self.programs)
        log.info("dashboard: %s %r -> %r", connection, line.strip(), reply.text)
        sent = self._send(connection, reply.text)
        if reply.shutdown and self.on_shutdown is not None:
            self.on_shutdown()
        return sent and not reply.close

    def _send(self, connection: Connection, text: str) -> bool:
        """Send one reply line, late while the streams are frozen and after the injected latency."""
        self.hold_while_frozen()
        latency = self.controller.faults.latency
        if latency:
            self._stopping.wait(latency)
        return connection.send_all((text + "\n").encode("utf-8"), SEND_TIMEOUT)
