"""The External Control URCap's program node: its URScript is fetched from the remote PC when play is pressed.

What the URCap (Universal_Robots_ExternalControl_URCap, RequestProgram.java) does, and so the simulator: connect to
the configured host and port (5 s to connect), send `request_program\\n`, read the reply (500 ms for its first
line, then whatever keeps arriving), and split it at `# HEADER_BEGIN` / `# HEADER_END`: the header (definitions)
goes into the program once, the rest (the control loop) at every External Control node. URCL's ScriptSender
answers on port 50002 with its External Control script.

When no program arrives the URCap's script is a blocking error popup ("The connection to the remote PC at
host:port could not be established. Reason: ..." or "Timeout while reading requested program from host:port",
title "Receive program failed"). There is no operator to close it in the simulator, so the program halts after the
popup: it stops with the URCap's message.
"""
import ipaddress
import logging
import socket
import time
from dataclasses import dataclass
from xml.etree.ElementTree import Element

from polyscope_format.urp_file import ProgramTree

from .errors import UrpError
from .script_writer import string_literal

log = logging.getLogger("sim_ursim.polyscope")

DEFAULT_PORT = 50002
URCAP_CLASS = "com.fzi.externalcontrol.ExternalControlNode"
CONNECT_TIMEOUT = 5.0  # s, the URCap's connect timeout
FIRST_LINE_TIMEOUT = 0.5  # s, the URCap's socket read timeout
QUIET_GAP = 0.02  # s without a byte after which the reply is complete (the URCap reads while bytes are ready)
MAX_PROGRAM_BYTES = 4 * 1024 * 1024


@dataclass(frozen=True)
class ExternalControlSettings:
    """The URCap's installation settings: the remote PC's address and port (loopback only in the simulator)."""

    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT

    def __post_init__(self) -> None:
        if not 0 < self.port < 65536:
            raise ValueError(f"External Control port must be 1..65535, got {self.port}")
        if self.host != "localhost":
            try:
                loopback = ipaddress.ip_address(self.host).is_loopback
            except ValueError:
                loopback = False
            if not loopback:
                raise ValueError(f"External Control host {self.host!r}: sim_ursim only connects to loopback "
                                 "addresses (127.x.y.z)")


class ExternalControl:
    """The External Control nodes of one script generation: one request, the header once, the loop per node.

    Call it as a translation's `contributed` callback (translation.program_urscript).
    """

    def __init__(self, settings: ExternalControlSettings) -> None:
        self.settings = settings
        self._loop: str | None = None

    def __call__(self, tree: ProgramTree, node: Element) -> str:
        check_supported(tree, node)
        if self._loop is not None:
            return self._loop
        header, self._loop = split_program(request_program(self.settings))
        return header + self._loop


def check_supported(tree: ProgramTree, node: Element) -> None:
    """UrpError unless `node` is the External Control URCap's node (the only URCap the simulator plays)."""
    if node.get("strategyClass") != URCAP_CLASS:
        what = node.get("strategyProgramNodeType") or node.get("strategyClass") or "?"
        by = node.get("strategyURCapName") or "an unknown URCap"
        raise UrpError(f"{tree.path_of(node)}: URCap node {what!r} ({by}) is not supported by sim_ursim "
                       "(only External Control is)")


def request_program(settings: ExternalControlSettings) -> str:
    """The URScript the remote PC sends for `request_program`, or the URCap's popup (then `halt`) when none came."""
    where = f"{settings.host}:{settings.port}"
    try:
        connection = socket.create_connection((settings.host, settings.port), timeout=CONNECT_TIMEOUT)
    except OSError as error:
        log.warning("External Control: no program from %s: %s", where, error.strerror or error)
        return _failure(f"The connection to the remote PC at {where} could not be established. "
                        f"Reason: {error.strerror or error}")
    with connection:
        try:
            connection.sendall(b"request_program\n")
            reply = _read_reply(connection)
        except OSError as error:
            log.warning("External Control: reading the program from %s failed: %s", where, error)
            reply = b""
    if not reply.strip():
        log.warning("External Control: no program from %s within %.1f s", where, FIRST_LINE_TIMEOUT)
        return _failure(f"Timeout while reading requested program from {where}")
    log.info("External Control: received %d bytes of program from %s", len(reply), where)
    return "\n".join(" " + line for line in reply.decode("utf-8", errors="replace").splitlines())


def _read_reply(connection: socket.socket) -> bytes:
    """The first line within FIRST_LINE_TIMEOUT, then what keeps arriving (gaps under QUIET_GAP), bounded."""
    received = bytearray()
    deadline = time.monotonic() + FIRST_LINE_TIMEOUT
    while b"\n" not in received:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return bytes(received) if received.strip() else b""
        connection.settimeout(remaining)
        try:
            chunk = connection.recv(65536)
        except TimeoutError:
            return b""
        if not chunk:
            return bytes(received)
        received += chunk
    connection.settimeout(QUIET_GAP)
    while len(received) <= MAX_PROGRAM_BYTES:
        try:
            chunk = connection.recv(65536)
        except TimeoutError:
            break
        if not chunk:
            break
        received += chunk
    if len(received) > MAX_PROGRAM_BYTES:
        raise OSError(f"the program is larger than {MAX_PROGRAM_BYTES // (1024 * 1024)} MB")
    return bytes(received)


def _failure(message: str) -> str:
    return (f"popup({string_literal(message)}, \"Receive program failed\", False, True, blocking=True)\n"
            "sync()\nhalt")


def split_program(program: str) -> tuple[str, str]:
    """(header, control loop) as the URCap splits a received program; no header anchors: ("", program)."""
    header: list[str] = []
    loop: list[str] = []
    in_header = ended = False
    for line in program.split("\n"):
        marker = line.strip()
        if marker == "# HEADER_BEGIN":
            in_header = True
            header.append(line)
        elif marker == "# HEADER_END" and in_header:
            in_header, ended = False, True
            header.append(line)
        elif in_header:
            header.append(line)
        elif ended:
            loop.append(line)
    if not ended:
        return "", program
    return "".join(line + "\n" for line in header), "".join(line + "\n" for line in loop)
