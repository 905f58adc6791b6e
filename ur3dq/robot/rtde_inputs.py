"""This client's RTDE inputs (port 30004): integer registers, the digital outputs and the speed slider, on one
connection.

One RTDE connection of ur3dq's own (RTDE protocol version 2, UR's "Real-Time Data Exchange" guide): an input
recipe per purpose — each integer register asked for, and each output family's mask and bits — set up once, then
a data package per write, as ur_rtde's RTDEIOInterface does (docs/protocols.md, 5.7). Writes go out from the
calling thread; one lock serialises the writes of several threads (Robot.set_digital_out, a jog's keep-alive).
The heartbeat's process opens a second one holding its register alone (ur3dq.robot.heartbeat_process).

ur_rtde's RTDEIOInterface is not used for this: when the controller goes away it aborts the process that holds it
(after a failed write it still counts itself as started, so its disconnect, and again its destructor, writes
RTDE's pause request to the dead socket and throws from C++ where nothing can catch it: std::terminate, exit 134).
A write here that fails is a Python OSError: the inputs count as closed until reconnect(), and ur3dq reports the
lost connection itself. Another RTDE client holding the same inputs (a second ur3dq moving the same arm, a user's
own RTDEIOInterface) makes the controller answer IN_USE: RobotConnectionError naming them.
"""
from __future__ import annotations

import socket
import struct
import threading
import time
from collections.abc import Iterable

from ur3dq.errors import RobotConnectionError
from ur3dq.robot.io_state import io_bit
from ur3dq.robot.rtde_wire import (
    DATA,
    HEADER,
    PROTOCOL_VERSION,
    REQUEST_PROTOCOL_VERSION,
    RTDE_PORT,
    SETUP_INPUTS,
    connect_timeout,
    exchange,
)

#: Each output family's RTDE inputs: the mask of the pins to set, and their bits.
OUTPUT_INPUTS = {
    "standard": ("standard_digital_output_mask", "standard_digital_output"),
    "configurable": ("configurable_digital_output_mask", "configurable_digital_output"),
    "tool": ("tool_digital_output_mask", "tool_digital_output"),
}
#: The integer registers held: ur_rtde's lower range, as its RTDEIOInterface holds it (21: a held jog's keep-alive,
#: ur3dq.robot.jog), but for 20, which the heartbeat's process holds on a connection of its own
#: (ur3dq.robot.heartbeat).
INPUT_INT_REGISTERS = (18, 19, 21, 22)
#: The speed slider's RTDE inputs and their types: which fields to apply (bit 0: the fraction), and the fraction.
SPEED_SLIDER_INPUTS = (("speed_slider_mask", "UINT32"), ("speed_slider_fraction", "DOUBLE"))
#: Seconds a write may block (the controller no longer reading) before the inputs count as lost.
WRITE_TIMEOUT = 1.0


class RTDEInputs:
    """The RTDE inputs of `host`: the integer registers `int_registers` and, with `outputs`, every digital output
    family and the speed slider, opened at construction; RobotConnectionError if the controller cannot be reached or
    refuses them.

    Examples
    --------
    >>> from ur3dq.robot.rtde_inputs import RTDEInputs
    >>> inputs = RTDEInputs("127.0.0.2")     # doctest: +SKIP
    >>> inputs.set_int_register(18, 1), inputs.set_digital_out("tool", 0, True)     # doctest: +SKIP
    (True, None)
    """

    def __init__(self, host: str, int_registers: Iterable[int] = INPUT_INT_REGISTERS, outputs: bool = True) -> None:
        self.host = host
        self._outputs = bool(outputs)
        self._lock = threading.Lock()
        self._registers = tuple(int(register) for register in int_registers)
        self._socket: socket.socket | None = None
        self._recipes: dict[str, int] = {}   # "int R" or an output family -> recipe id
        self._open()

    # --- the connection --------------------------------------------------------------------------------------

    def _open(self) -> None:
        """Connect, agree on protocol version 2, set up one recipe per purpose. No start request: a controller
        takes input data packages without one, as from ur_rtde's RTDEIOInterface (docs/protocols.md, 5.3)."""
        where = f"the RTDE inputs of {self.host}:{RTDE_PORT}"
        timeout = connect_timeout()
        try:
            sock = socket.create_connection((self.host, RTDE_PORT), timeout=timeout)
        except OSError as error:
            raise RobotConnectionError(f"cannot reach {where}: {error.strerror or error}") from None
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            deadline = time.monotonic() + timeout
            if exchange(sock, REQUEST_PROTOCOL_VERSION, struct.pack(">H", PROTOCOL_VERSION), deadline)[:1] != b"\1":
                raise RobotConnectionError(f"{where}: the controller refused RTDE protocol version 2")
            recipes = {f"int {register}": [(f"input_int_register_{register}", "INT32")] for register in self._registers}
            if self._outputs:
                recipes.update({family: [(name, "UINT8") for name in names] for family, names in OUTPUT_INPUTS.items()})
                recipes["speed slider"] = list(SPEED_SLIDER_INPUTS)
            for purpose, fields in recipes.items():
                self._recipes[purpose] = _set_up(sock, fields, deadline, where)
            sock.settimeout(WRITE_TIMEOUT)
        except BaseException as error:
            sock.close()
            if isinstance(error, TimeoutError):
                raise RobotConnectionError(f"{where} did not answer within {timeout:g} s") from None
            if isinstance(error, OSError):
                raise RobotConnectionError(f"{where}: {error.strerror or error}") from None
            raise
        self._socket = sock

    def _write(self, purpose: str, payload: bytes) -> bool:
        """One data package of the recipe for `purpose`; False (and the inputs closed) when it cannot be sent."""
        recipe = self._recipes.get(purpose)
        if recipe is None:
            raise ValueError(f"these RTDE inputs of {self.host} hold no {purpose} (opened with outputs=False)")
        with self._lock:
            sock = self._socket
            if sock is None:
                return False
            body = bytes([recipe]) + payload
            try:
                sock.sendall(HEADER.pack(HEADER.size + len(body), DATA) + body)
            except OSError:   # reset, broken pipe, or the controller stopped reading for WRITE_TIMEOUT
                self._socket = None
                sock.close()
                return False
            return True

    # --- what the driver writes ------------------------------------------------------------------------------

    def set_int_register(self, register: int, value: int) -> bool:
        """Write RTDE `input_int_register_<register>` (one of `int_registers`); False when the write failed."""
        if f"int {register}" not in self._recipes:
            raise ValueError(f"input_int_register_{register} is not one of these inputs ({self._registers})")
        return self._write(f"int {register}", struct.pack(">i", int(value)))

    def set_digital_out(self, family: str, pin: int, on: bool) -> None:
        """Switch digital output `pin` of `family` ('standard', 'configurable', 'tool') on or off; ValueError for a
        pin that does not exist, RobotConnectionError when the write fails."""
        io_bit(family, pin)
        bit = 1 << int(pin)
        if not self._write(family, struct.pack(">BB", bit, bit if on else 0)):
            raise RobotConnectionError(f"cannot switch {family} digital output {pin} {'on' if on else 'off'} "
                                       f"through the RTDE inputs of {self.host}:{RTDE_PORT}")

    @property
    def connected(self) -> bool:
        """False once a write failed or the inputs were closed."""
        return self._socket is not None

    def set_speed_slider(self, fraction: float) -> None:
        """Set the controller's speed slider (0..1: the speed scaling of every motion); ValueError outside it,
        RobotConnectionError when the write fails."""
        if not (isinstance(fraction, (int, float)) and 0.0 <= fraction <= 1.0):
            raise ValueError(f"speed slider: {fraction!r} is not a fraction 0..1")
        if not self._write("speed slider", struct.pack(">Id", 1, float(fraction))):
            raise RobotConnectionError(f"cannot set the speed slider through the RTDE inputs of "
                                       f"{self.host}:{RTDE_PORT}")

    def reconnect(self) -> bool:
        """Open the connection again after a failed write; RobotConnectionError if the controller refuses."""
        with self._lock:
            self._close_socket()
            self._open()
        return True

    def _close_socket(self) -> None:
        sock, self._socket = self._socket, None
        if sock is not None:
            sock.close()

    def close(self) -> None:
        """Disconnect (idempotent); the controller then frees the inputs for other clients."""
        with self._lock:
            self._close_socket()


def _set_up(sock: socket.socket, fields: list[tuple[str, str]], deadline: float, where: str) -> int:
    """Set up an input recipe of `fields` ((name, type) pairs); its id, or RobotConnectionError naming the inputs
    the controller refused (IN_USE: another client writes them)."""
    names = [name for name, _ in fields]
    reply = exchange(sock, SETUP_INPUTS, ",".join(names).encode("ascii"), deadline)
    recipe = reply[0] if reply else 0
    types = reply[1:].decode("ascii", "replace").split(",")
    refused = [f"{name} ({found})" for (name, kind), found in zip(fields, types) if found != kind]
    if recipe == 0 or refused or len(types) != len(names):
        raise RobotConnectionError(
            f"{where} refused {', '.join(refused) or ', '.join(names)}: another client writes them; end the other "
            "ur3dq command on this arm (a record-pose --teach, jog, run-poses) or RTDE client, and try again")
    return recipe
