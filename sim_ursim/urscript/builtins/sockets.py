"""URScript `socket_*` built-ins: real outgoing TCP connections from the simulated controller to a client.

A robot program opens connections back to the PC (URCL's External Control script: the reverse, trajectory and
script-command interfaces).  Semantics follow UR's script manual:

- `socket_open(address, port, socket_name="socket_0")` → True/False; re-opening a name closes the old socket.
- `socket_send_string/line/int/byte(value, socket_name)` → True/False; ints are 32-bit big-endian, a line adds "\\n".
- `socket_read_binary_integer(number, socket_name, timeout=2)` → [count, int32…]; `socket_read_byte_list` →
  [count, bytes…]; `socket_read_ascii_float(number, …)` reads "(f1, f2, …)" → [count, floats…]; count 0 (and no
  values) on timeout or a closed socket.  `socket_read_line` / `socket_read_string(prefix, suffix)` → "" on timeout.
  A timeout ≤ 0 waits until the read completes.
- `socket_get_var(name, socket_name)` sends "GET name\\n" and reads an integer line; `socket_set_var(name, value,
  socket_name)` sends "SET name value\\n".

The simulator only ever connects to loopback addresses (127.0.0.0/8, "localhost"): any other address makes
`socket_open` return False, as a controller does when a host cannot be reached.  Every socket of a program is
closed when its main thread ends.  Blocking reads release the script scheduler and end at once when the program
is stopped.
"""
import ipaddress
import logging
import re
import socket
import struct
import threading
import time

from sim_ursim.urscript.builtins.registry import builtin
from sim_ursim.urscript.values import ScriptError, to_str

log = logging.getLogger("sim_ursim.urscript")

DEFAULT_SOCKET = "socket_0"
DEFAULT_TIMEOUT = 2.0
CONNECT_TIMEOUT = 2.0
POLL = 0.02  # s between checks of the program's cancel flag while a read waits
_FLOAT = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


class _ScriptSocket:
    """One named connection and the bytes received on it that no read has taken yet."""

    def __init__(self, sock):
        self.sock = sock
        self.buffer = bytearray()
        self.closed = False
        self.last_data = time.monotonic()  # when bytes last arrived: a timed-out read says how long the peer was silent

    def receive(self, timeout):
        """Append what arrives within `timeout` s (0: only what is already there) to the buffer; closed on EOF."""
        self.sock.settimeout(timeout if timeout > 0 else 0.0)
        try:
            chunk = self.sock.recv(65536)
        except (TimeoutError, BlockingIOError):
            return
        except OSError:
            chunk = b""
        if not chunk:
            self.close()
            return
        self.buffer += chunk
        self.last_data = time.monotonic()

    def close(self):
        self.closed = True
        try:
            self.sock.close()
        except OSError:
            pass


class _Registry:
    """The open sockets of one program run; all closed when its main thread ends."""

    def __init__(self, execution):
        self.sockets = {}
        self.lock = threading.Lock()
        threading.Thread(target=self._close_at_end, args=(execution,), daemon=True,
                         name=f"urscript-sockets-{execution.program.name}").start()

    def _close_at_end(self, execution):
        execution.main.done.wait()
        with self.lock:
            sockets, self.sockets = list(self.sockets.values()), {}
        for script_socket in sockets:
            script_socket.close()


_REGISTRIES_LOCK = threading.Lock()


def _registry(ctx):
    execution = ctx.execution
    with _REGISTRIES_LOCK:
        registry = getattr(execution, "_script_sockets", None)
        if registry is None:
            registry = _Registry(execution)
            execution._script_sockets = registry
        return registry


def _name(value):
    if not isinstance(value, str):
        raise ScriptError(f"runtime_error:socket name must be a string, got {to_str(value)}:")
    return value


def _get(ctx, socket_name):
    registry = _registry(ctx)
    with registry.lock:
        return registry.sockets.get(_name(socket_name))


def is_loopback(address):
    """True for "localhost" and any IPv4/IPv6 loopback literal."""
    if address == "localhost":
        return True
    try:
        return ipaddress.ip_address(address).is_loopback
    except ValueError:
        return False


@builtin
def socket_open(ctx, address, port, socket_name=DEFAULT_SOCKET):
    """Connect to address:port under `socket_name`; False when the connection cannot be made."""
    name = _name(socket_name)
    if not isinstance(address, str) or isinstance(port, bool) or not isinstance(port, (int, float)):
        raise ScriptError("runtime_error:socket_open needs an address string and a port number:")
    registry = _registry(ctx)
    with registry.lock:
        old = registry.sockets.pop(name, None)
    if old is not None:
        old.close()
    if not is_loopback(address):
        log.warning("socket_open(%s, %s): the simulator connects to loopback addresses only", address, port)
        return False
    with ctx.waiting():
        try:
            sock = socket.create_connection((address, int(port)), timeout=CONNECT_TIMEOUT)
        except OSError as error:
            log.info("socket_open(%s, %s, %s) failed: %s", address, port, name, error)
            sock = None
    ctx.check()
    if sock is None:
        return False
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    with registry.lock:
        registry.sockets[name] = _ScriptSocket(sock)
    log.info("socket_open(%s, %s, %s): connected", address, port, name)
    return True


@builtin
def socket_close(ctx, socket_name=DEFAULT_SOCKET):
    """Close the named socket (nothing happens when it is not open)."""
    registry = _registry(ctx)
    with registry.lock:
        script_socket = registry.sockets.pop(_name(socket_name), None)
    if script_socket is not None:
        script_socket.close()


def _send(ctx, socket_name, data):
    script_socket = _get(ctx, socket_name)
    if script_socket is None or script_socket.closed:
        return False
    try:
        script_socket.sock.sendall(data)
    except OSError:
        script_socket.close()
        return False
    return True


@builtin
def socket_send_string(ctx, value, socket_name=DEFAULT_SOCKET):
    """Send the text of `value` (strings as they are, other values as URScript prints them)."""
    return _send(ctx, socket_name, to_str(value).encode("utf-8"))


@builtin
def socket_send_line(ctx, value, socket_name=DEFAULT_SOCKET):
    """Send the text of `value` and a newline."""
    return _send(ctx, socket_name, to_str(value).encode("utf-8") + b"\n")


@builtin
def socket_send_int(ctx, value, socket_name=DEFAULT_SOCKET):
    """Send a 32-bit big-endian signed integer."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
        raise ScriptError(f"runtime_error:socket_send_int needs an integer, got {to_str(value)}:")
    if not -2 ** 31 <= int(value) < 2 ** 31:
        raise ScriptError(f"runtime_error:socket_send_int: {int(value)} does not fit 32 bits:")
    return _send(ctx, socket_name, struct.pack(">i", int(value)))


@builtin
def socket_send_byte(ctx, value, socket_name=DEFAULT_SOCKET):
    """Send one byte (0..255)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= int(value) <= 255:
        raise ScriptError(f"runtime_error:socket_send_byte needs a value 0..255, got {to_str(value)}:")
    return _send(ctx, socket_name, bytes([int(value)]))


def _read_until(ctx, what, socket_name, timeout, complete):
    """Wait until `complete(buffer)` returns (consumed, result) or the timeout passes / the socket closes.

    Returns the result, or None on timeout or a closed socket (noted in `ctx.last_timeout` for the log of a halt
    that follows, as URCL's External Control script halts on a timed-out read).  A value already in the socket is
    taken at once, keeping the thread's turn; otherwise the scheduler is released while the read waits, and a
    stopped program ends the wait within POLL seconds.
    """
    script_socket = _get(ctx, socket_name)
    if script_socket is None:
        return None
    timeout = float(timeout) if isinstance(timeout, (int, float)) and not isinstance(timeout, bool) else None
    started = time.monotonic()
    deadline = None if timeout is None or timeout <= 0 else started + timeout
    if not script_socket.closed:
        # Data that is already there is read without waiting: no physical time passes, so the thread keeps its
        # turn and no other script thread runs in between (inside enter_critical, External Control's trajectory
        # thread reads a point and counts it down before its main thread may kill it).
        script_socket.receive(0)
    taken = _take(ctx, script_socket, complete)
    if taken is not None:
        return taken[0]
    with ctx.waiting():
        while True:
            taken = _take(ctx, script_socket, complete)
            if taken is not None:
                return taken[0]
            if script_socket.closed or ctx.cancel.is_set():
                return None
            remaining = POLL if deadline is None else min(POLL, deadline - time.monotonic())
            if remaining > 0:
                script_socket.receive(remaining)
                continue
            # The deadline has passed, maybe while this thread waited for the GIL: take what is in the socket first.
            # Whether it came before the deadline cannot be told, and a late thread is the simulator's delay, not
            # the client's (External Control would halt on a client that wrote in time).
            script_socket.receive(0)
            if complete(script_socket.buffer) is None:
                _note_timeout(ctx, what, socket_name, timeout, started, script_socket)
                return None


def _take(ctx, script_socket, complete):
    """(result,) consumed from the socket's buffer when `complete` finds a whole value there, else None."""
    found = complete(script_socket.buffer)
    if found is None:
        return None
    consumed, result = found
    del script_socket.buffer[:consumed]
    ctx.last_timeout = None
    return (result,)


def _note_timeout(ctx, what, socket_name, timeout, started, script_socket):
    """Record (and log at debug level: polling reads time out every cycle) a read that got no complete data."""
    now = time.monotonic()
    ctx.last_timeout = (f"{what}(\"{socket_name}\") got no data within {timeout:.3f} s (waited {now - started:.3f} s; "
                        f"last bytes {now - script_socket.last_data:.3f} s before, {len(script_socket.buffer)} "
                        f"buffered)")
    log.debug("%s timed out", ctx.last_timeout)


def _count(value, name, limit=30):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 1 <= int(value) <= limit:
        raise ScriptError(f"runtime_error:{name}: number must be 1..{limit}, got {to_str(value)}:")
    return int(value)


@builtin
def socket_read_binary_integer(ctx, number, socket_name=DEFAULT_SOCKET, timeout=DEFAULT_TIMEOUT):
    """[count, int32…]: `number` big-endian 32-bit integers, or [0] on timeout."""
    number = _count(number, "socket_read_binary_integer")
    size = 4 * number

    def complete(buffer):
        if len(buffer) < size:
            return None
        return size, list(struct.unpack_from(f">{number}i", buffer))

    values = _read_until(ctx, "socket_read_binary_integer", socket_name, timeout, complete)
    ctx.check()
    return [0] if values is None else [number] + values


@builtin
def socket_read_byte_list(ctx, number, socket_name=DEFAULT_SOCKET, timeout=DEFAULT_TIMEOUT):
    """[count, bytes…]: `number` bytes (0..255), or [0] on timeout."""
    number = _count(number, "socket_read_byte_list")

    def complete(buffer):
        return (number, list(buffer[:number])) if len(buffer) >= number else None

    values = _read_until(ctx, "socket_read_byte_list", socket_name, timeout, complete)
    ctx.check()
    return [0] if values is None else [number] + values


@builtin
def socket_read_ascii_float(ctx, number, socket_name=DEFAULT_SOCKET, timeout=DEFAULT_TIMEOUT):
    """[count, floats…] from a message "(f1, f2, …)" holding `number` floats; [0] on timeout or a malformed one."""
    number = _count(number, "socket_read_ascii_float")

    def complete(buffer):
        end = buffer.find(b")")
        if end < 0:
            return None
        start = buffer.rfind(b"(", 0, end)
        text = buffer[start + 1:end].decode("ascii", "replace") if start >= 0 else ""
        values = [float(match) for match in _FLOAT.findall(text)]
        return end + 1, values if start >= 0 and len(values) == number else None

    values = _read_until(ctx, "socket_read_ascii_float", socket_name, timeout, complete)
    ctx.check()
    return [0] if not values else [number] + values


@builtin
def socket_read_line(ctx, socket_name=DEFAULT_SOCKET, timeout=DEFAULT_TIMEOUT):
    """The next line without its "\\n" (and "\\r"), or "" on timeout."""

    def complete(buffer):
        end = buffer.find(b"\n")
        return None if end < 0 else (end + 1, buffer[:end].decode("utf-8", "replace").rstrip("\r"))

    line = _read_until(ctx, "socket_read_line", socket_name, timeout, complete)
    ctx.check()
    return "" if line is None else line


@builtin
def socket_read_string(ctx, socket_name=DEFAULT_SOCKET, prefix="", suffix="", interpret_escape=False,
                       timeout=DEFAULT_TIMEOUT):
    """Text between `prefix` and `suffix` (with neither: whatever has arrived), or "" on timeout."""
    start_mark, end_mark = prefix.encode(), suffix.encode()

    def complete(buffer):
        start = buffer.find(start_mark) if start_mark else 0
        if start < 0 or not buffer:
            return None
        body_start = start + len(start_mark)
        if not end_mark:
            return len(buffer), bytes(buffer[body_start:]).decode("utf-8", "replace")
        end = buffer.find(end_mark, body_start)
        if end < 0:
            return None
        return end + len(end_mark), bytes(buffer[body_start:end]).decode("utf-8", "replace")

    text = _read_until(ctx, "socket_read_string", socket_name, timeout, complete)
    ctx.check()
    if text is None:
        return ""
    if interpret_escape:
        text = text.replace("\\r", "\r").replace("\\n", "\n").replace("\\t", "\t")
    return text


@builtin
def socket_set_var(ctx, name, value, socket_name=DEFAULT_SOCKET):
    """Send "SET name value\\n" (value an integer)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScriptError(f"runtime_error:socket_set_var needs a number, got {to_str(value)}:")
    _send(ctx, socket_name, f"SET {_name(name)} {int(value)}\n".encode())


@builtin
def socket_get_var(ctx, name, socket_name=DEFAULT_SOCKET):
    """Send "GET name\\n" and return the integer of the reply line "name value" (0 if none comes in 2 s)."""
    _send(ctx, socket_name, f"GET {_name(name)}\n".encode())
    line = socket_read_line(ctx, socket_name, DEFAULT_TIMEOUT)
    match = re.search(r"(-?\d+)\s*$", line)
    return int(match.group(1)) if match else 0
