"""This client's RTDE inputs (port 30004): the heartbeat register and the digital outputs, through one connection.

ur_rtde's RTDEIOInterface takes RTDE input registers 18–22 and the output masks it writes for this client; every
write goes out from the calling thread, so one lock serialises the heartbeat thread's writes and the caller's
(ur3dq.robot.heartbeat, Robot.set_digital_out). Another RTDE client holding the same inputs (a second ur3dq moving
the same arm, a user's own RTDEIOInterface) makes the controller refuse the connection: RobotConnectionError.
"""
from __future__ import annotations

import threading
from collections.abc import Callable

import rtde_io

from ur3dq.errors import RobotConnectionError
from ur3dq.robot.io_state import io_bit

_OUTPUT_SETTERS = {"standard": "setStandardDigitalOut", "configurable": "setConfigurableDigitalOut",
                   "tool": "setToolDigitalOut"}


class RTDEInputs:
    """The RTDE inputs of `host`, opened at construction; RobotConnectionError if the controller refuses them.

    Examples
    --------
    >>> from ur3dq.robot.rtde_inputs import RTDEInputs
    >>> inputs = RTDEInputs("127.0.0.2")           # doctest: +SKIP
    >>> inputs.set_digital_out("tool", 0, True)     # doctest: +SKIP
    """

    def __init__(self, host: str) -> None:
        self.host = host
        self._lock = threading.Lock()
        self._broken = False   # a write failed: the connection is gone until reconnect() opens it again
        try:
            self._io = rtde_io.RTDEIOInterface(host)
        except RuntimeError as error:
            if "already in use" in str(error):   # ur_rtde's words; its advice (fieldbus adapters) rarely applies
                raise RobotConnectionError(
                    f"cannot open the RTDE inputs of {host}:30004: another client holds input registers 18-22; end "
                    "the other ur3dq command on this arm (a record-pose --teach, jog, run-poses) and try again") \
                    from None
            raise RobotConnectionError(
                f"cannot open the RTDE inputs of {host}:30004 (input registers 18-22; is another RTDE client "
                f"writing them?): {error}") from None

    def write(self, call: Callable[[rtde_io.RTDEIOInterface], object]) -> bool:
        """call(RTDEIOInterface) under the lock; False when it reports failure or raises (a dropped connection)."""
        with self._lock:
            try:
                written = bool(call(self._io))
            except RuntimeError:
                written = False
            self._broken = self._broken or not written
            return written

    def set_int_register(self, register: int, value: int) -> bool:
        """Write RTDE `input_int_register_<register>`; False when the write failed."""
        return self.write(lambda io: io.setInputIntRegister(register, value))

    def set_digital_out(self, family: str, pin: int, on: bool) -> None:
        """Switch digital output `pin` of `family` ('standard', 'configurable', 'tool') on or off; ValueError for a
        pin that does not exist, RobotConnectionError when the write fails."""
        io_bit(family, pin)
        setter = _OUTPUT_SETTERS[family]
        if not self.write(lambda io: getattr(io, setter)(pin, bool(on))):
            raise RobotConnectionError(f"cannot switch {family} digital output {pin} {'on' if on else 'off'} "
                                       f"through the RTDE inputs of {self.host}:30004")

    def set_speed_slider(self, fraction: float) -> None:
        """Set the controller's speed slider (0..1: the speed scaling of every motion); ValueError outside it,
        RobotConnectionError when the write fails."""
        if not (isinstance(fraction, (int, float)) and 0.0 <= fraction <= 1.0):
            raise ValueError(f"speed slider: {fraction!r} is not a fraction 0..1")
        if not self.write(lambda io: io.setSpeedSlider(float(fraction))):
            raise RobotConnectionError(f"cannot set the speed slider through the RTDE inputs of {self.host}:30004")

    def reconnect(self) -> bool:
        """Open the connection again after a failed write; False (or RobotConnectionError) if refused."""
        with self._lock:
            try:
                reconnected = bool(self._io.reconnect())
            except RuntimeError as error:
                raise RobotConnectionError(f"the RTDE inputs of {self.host}:30004 cannot reconnect: {error}") from None
            self._broken = not reconnected
            return reconnected

    def close(self) -> None:
        """Disconnect (idempotent).

        After a failed write ur_rtde still takes the connection for open, and its disconnect — by hand or in its
        destructor — writes to the dead socket and throws from C++ code that cannot pass the error on, which
        aborts the process (SIGABRT, exit 134). So a broken connection is opened again first, then closed cleanly;
        when the controller cannot be reached any more, that abort remains (a known ur_rtde 1.6 behaviour).
        """
        if self._broken:
            try:
                self.reconnect()
            except RobotConnectionError:
                pass
        self.write(lambda io: io.disconnect())
