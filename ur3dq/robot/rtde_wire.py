"""RTDE packages on a socket of ur3dq's own (port 30004, protocol version 2): the header, exact reads under a
deadline, a request and its reply, and the bounded handshake the driver makes before ur_rtde touches the port.

ur_rtde's RTDEReceiveInterface constructor blocks in C++ (holding the GIL) on a port that accepts and stays silent,
and can abort the process on a malformed reply; so the driver first asks the port for protocol version 2 itself
(probe_rtde), with a deadline, and only hands the host to ur_rtde when the reply is a well-formed RTDE 'V' answer.
ur3dq's RTDE inputs (ur3dq.robot.rtde_inputs) speak the protocol through the same functions.
"""
from __future__ import annotations

import os
import socket
import struct
import time

from ur3dq.errors import RobotConnectionError

RTDE_PORT = 30004
PROTOCOL_VERSION = 2
DEFAULT_CONNECT_TIMEOUT = 5.0  # s per connection step; a real controller answers in milliseconds
HEADER = struct.Struct(">HB")  # package size (header included), package type
REQUEST_PROTOCOL_VERSION, SETUP_INPUTS, DATA, TEXT_MESSAGE = (ord(c) for c in "VIUM")


def connect_timeout() -> float:
    """Seconds each connection step may take: UR3DQ_CONNECT_TIMEOUT if set (a positive number), else 5."""
    text = os.environ.get("UR3DQ_CONNECT_TIMEOUT")
    if not text:
        return DEFAULT_CONNECT_TIMEOUT
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value > 0 and value < 3600):
        raise RobotConnectionError(f"UR3DQ_CONNECT_TIMEOUT must be a number of seconds in (0, 3600), got {text!r}")
    return value


def probe_rtde(host: str, port: int = RTDE_PORT, timeout: float | None = None) -> None:
    """Check that `host:port` answers the RTDE protocol-version handshake.

    Ask `host:port` for RTDE protocol version 2 within `timeout` s (default connect_timeout());
    RobotConnectionError naming the port if it cannot be reached, stays silent, or answers anything but a
    well-formed 4-byte 'V' reply."""
    timeout = connect_timeout() if timeout is None else timeout
    where = f"the RTDE interface at {host}:{port}"
    deadline = time.monotonic() + timeout
    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            sock.sendall(HEADER.pack(5, REQUEST_PROTOCOL_VERSION) + struct.pack(">H", PROTOCOL_VERSION))
            reply = receive_exactly(sock, 4, deadline)
    except TimeoutError:
        raise RobotConnectionError(f"{where} did not answer the protocol version request within {timeout:g} s") \
            from None
    except PeerClosed:
        raise RobotConnectionError(f"{where} closed the connection during the protocol version request") from None
    except OSError as error:
        raise RobotConnectionError(f"cannot reach {where}: {error.strerror or error}") from None
    size, kind = HEADER.unpack_from(reply)
    if size != 4 or kind != REQUEST_PROTOCOL_VERSION or reply[3] not in (0, 1):
        raise RobotConnectionError(f"{where} answered the protocol version request with {reply!r}, "
                                   "not an RTDE reply: is it a UR controller?")
    if reply[3] != 1:
        raise RobotConnectionError(f"{where} refused RTDE protocol version {PROTOCOL_VERSION}")


class PeerClosed(ConnectionError):
    """The controller closed the connection in the middle of a reply."""


def receive_exactly(sock: socket.socket, count: int, deadline: float) -> bytes:
    """`count` bytes from `sock` before `deadline` (time.monotonic()); TimeoutError after it, PeerClosed if the
    peer closes first."""
    data = b""
    while len(data) < count:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError
        sock.settimeout(remaining)
        chunk = sock.recv(count - len(data))
        if not chunk:
            raise PeerClosed("the controller closed the connection")
        data += chunk
    return data


def exchange(sock: socket.socket, kind: int, payload: bytes, deadline: float) -> bytes:
    """Send a request of type `kind`, return the payload of the controller's reply of the same type (text
    messages skipped); TimeoutError after `deadline`, ConnectionError when the controller closes or answers
    another type."""
    sock.sendall(HEADER.pack(HEADER.size + len(payload), kind) + payload)
    while True:
        size, reply_kind = HEADER.unpack(receive_exactly(sock, HEADER.size, deadline))
        body = receive_exactly(sock, size - HEADER.size, deadline) if size > HEADER.size else b""
        if reply_kind == kind:
            return body
        if reply_kind != TEXT_MESSAGE:
            raise ConnectionError(f"unexpected RTDE package type {reply_kind} in reply to {chr(kind)!r}")
