"""A short, bounded RTDE handshake of our own before ur_rtde touches the port.

ur_rtde's RTDEReceiveInterface constructor blocks in C++ (holding the GIL) on a port that accepts and stays silent,
and can abort the process on a malformed reply; so the driver first asks the port for protocol version 2 itself,
with a deadline, and only hands the host to ur_rtde when the reply is a well-formed RTDE 'V' answer.
"""
import os
import socket
import struct
import time

from ur3dq.errors import RobotConnectionError

RTDE_PORT = 30004
DEFAULT_CONNECT_TIMEOUT = 5.0  # s per connection step; a real controller answers in milliseconds
_REQUEST_PROTOCOL_VERSION = 86  # 'V'
_PROTOCOL_VERSION = 2
_HEADER = struct.Struct(">HB")  # package size (header included), package type


def connect_timeout():
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


def probe_rtde(host, port=RTDE_PORT, timeout=None):
    """Check that `host:port` answers the RTDE protocol-version handshake.

    Ask `host:port` for RTDE protocol version 2 within `timeout` s (default connect_timeout());
    RobotConnectionError naming the port if it cannot be reached, stays silent, or answers anything but a
    well-formed 4-byte 'V' reply."""
    timeout = connect_timeout() if timeout is None else timeout
    where = f"the RTDE interface at {host}:{port}"
    deadline = time.monotonic() + timeout
    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            sock.sendall(_HEADER.pack(5, _REQUEST_PROTOCOL_VERSION) + struct.pack(">H", _PROTOCOL_VERSION))
            reply = _receive_exactly(sock, 4, deadline)
    except TimeoutError:
        raise RobotConnectionError(f"{where} did not answer the protocol version request within {timeout:g} s") \
            from None
    except OSError as error:
        raise RobotConnectionError(f"cannot reach {where}: {error.strerror or error}") from None
    if reply is None:
        raise RobotConnectionError(f"{where} closed the connection during the protocol version request")
    size, kind = _HEADER.unpack_from(reply)
    if size != 4 or kind != _REQUEST_PROTOCOL_VERSION or reply[3] not in (0, 1):
        raise RobotConnectionError(f"{where} answered the protocol version request with {reply!r}, "
                                   "not an RTDE reply: is it a UR controller?")
    if reply[3] != 1:
        raise RobotConnectionError(f"{where} refused RTDE protocol version {_PROTOCOL_VERSION}")


def _receive_exactly(sock, count, deadline):
    """`count` bytes from `sock` before `deadline` (socket.timeout after it), or None if the peer closes first."""
    data = b""
    while len(data) < count:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError
        sock.settimeout(remaining)
        chunk = sock.recv(count - len(data))
        if not chunk:
            return None
        data += chunk
    return data
