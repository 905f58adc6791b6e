"""The default backend: state from ur_rtde's RTDEReceiveInterface (125/500 Hz), programs over the primary port."""
from __future__ import annotations

import time
from typing import Protocol, cast

import numpy as np
import rtde_receive

from ur3dq.errors import ConnectionLostError, RobotConnectionError
from ur3dq.robot import state
from ur3dq.robot.io_state import IOState
from ur3dq.robot.primary_client import PrimaryClient
from ur3dq.robot.rtde_wire import probe_rtde

# Only what the driver reads, so no version-gated default variable can make the controller refuse the recipe.
RTDE_VARIABLES = [
    "timestamp", "actual_q", "actual_qd", "actual_TCP_pose", "robot_mode", "safety_mode", "runtime_state",
    "robot_status_bits", "safety_status_bits", "speed_scaling", "target_speed_fraction",
    "actual_digital_input_bits", "actual_digital_output_bits", "standard_analog_input0", "standard_analog_input1",
    "standard_analog_output0", "standard_analog_output1",
]


class RTDEReceive(Protocol):
    """What the backend uses of ur_rtde's rtde_receive.RTDEReceiveInterface (signatures as its bindings document
    them)."""

    def isConnected(self) -> bool: ...
    def reconnect(self) -> bool: ...
    def disconnect(self) -> None: ...
    def getTimestamp(self) -> float: ...
    def getActualQ(self) -> list[float]: ...
    def getActualQd(self) -> list[float]: ...
    def getActualTCPPose(self) -> list[float]: ...
    def getRobotMode(self) -> int: ...
    def getRobotStatus(self) -> int: ...
    def getSafetyMode(self) -> int: ...
    def getSafetyStatusBits(self) -> int: ...
    def getRuntimeState(self) -> int: ...
    def getSpeedScaling(self) -> float: ...
    def getTargetSpeedFraction(self) -> float: ...
    def getActualDigitalInputBits(self) -> int: ...
    def getActualDigitalOutputBits(self) -> int: ...
    def getStandardAnalogInput0(self) -> float: ...
    def getStandardAnalogInput1(self) -> float: ...
    def getStandardAnalogOutput0(self) -> float: ...
    def getStandardAnalogOutput1(self) -> float: ...


class RTDEBackend:
    """State over RTDE, URScript on the primary connection `primary` (a PrimaryClient); `close()` disconnects."""

    name = "rtde"
    poll_period = 0.001  # RTDE delivers every 2-8 ms; polling faster than that only burns CPU
    freeze_timeout = 1.0  # 125 CB3 cycles without fresh data: frozen, not just late (even on a loaded machine)

    def __init__(self, host: str, primary: PrimaryClient) -> None:
        self.host = host
        self.primary = primary
        self._closed = False
        self._receive: RTDEReceive | None = _open_receive(host)
        self._last_timestamp: float | None = None
        self._last_fresh = time.monotonic()

    @property
    def connected(self) -> bool:
        """True while ur_rtde's receive thread holds the connection (False once closed)."""
        return self._receive is not None and bool(self._receive.isConnected())

    def reconnect(self) -> None:
        """Re-open the RTDE stream on a new ur_rtde interface; RobotConnectionError if the controller does not
        answer, or its stream stops again before the first package.

        ur_rtde's own `reconnect()` is never called: it waits for the new session's first package without a
        bound, and ur_rtde ends a session after 2.5 s without data, so a stream still silent by then (a controller
        frozen longer than that) leaves that wait going forever, even once the data flows again. The
        constructor's wait ends with its session: a new interface fails in bounded time instead. No new session
        is opened while the primary interface, still open, shows the controller silent too (frozen, or cut off):
        it would wait those 2.5 s for nothing."""
        if self._closed:
            raise RobotConnectionError(f"the RTDE stream from {self.host} was closed; connect again")
        silent = time.monotonic() - (self.primary.last_state_time or 0.0)
        if self.primary.alive and silent > self.freeze_timeout:
            raise RobotConnectionError(f"{self.host} has sent nothing for {silent:.1f} s, on its primary interface "
                                       "either (frozen, or cut off)")
        self._destroy_receive()
        self._receive = _open_receive(self.host)
        self._last_timestamp, self._last_fresh = None, time.monotonic()
        if not self._receive.isConnected():
            self._destroy_receive()
            raise RobotConnectionError(f"the RTDE stream from {self.host}:30004 stopped again before its first "
                                       "package (the controller is silent)")

    def status(self) -> state.RobotStatus:
        """A RobotStatus from the newest RTDE package; ConnectionLostError if the stream has closed."""
        receive = self._receive
        try:
            if receive is None or not receive.isConnected():
                raise ConnectionLostError(f"the RTDE state stream from {self.host} is closed")
            timestamp = receive.getTimestamp()
            now = time.monotonic()
            if timestamp != self._last_timestamp:
                self._last_timestamp, self._last_fresh = timestamp, now
            safety_mode = receive.getSafetyMode()
            safety_bits = receive.getSafetyStatusBits()
            runtime_state = receive.getRuntimeState()
            status = state.RobotStatus(
                joints=np.array(receive.getActualQ()),
                joint_speeds=np.array(receive.getActualQd()),
                tcp_pose=np.array(receive.getActualTCPPose()),
                robot_mode=receive.getRobotMode(),
                safety_mode=safety_mode,
                program_running=state.program_running_from(runtime_state, receive.getRobotStatus()),
                protective_stopped=state.protective_stopped_from(safety_bits, safety_mode),
                emergency_stopped=state.emergency_stopped_from(safety_bits, safety_mode),
                speed_scaling=receive.getSpeedScaling(),
                target_speed_fraction=receive.getTargetSpeedFraction(),
                age=now - self._last_fresh,
                program_paused=state.program_paused_from(runtime_state),
            )
        finally:
            # An error raised here (or a KeyboardInterrupt) keeps this frame in its traceback, and a caller may keep
            # the error in a reference cycle: the frame must not keep the interface, or close() (below) is not its
            # last reference and a later garbage collection runs its 0.5 s destructor, holding the GIL.
            receive = None
        return state.validated(status, f"the RTDE stream from {self.host}")

    def io_status(self) -> IOState:
        """The I/O and the program's runtime state from the newest RTDE package."""
        receive = self._receive
        try:
            if receive is None or not receive.isConnected():
                raise ConnectionLostError(f"the RTDE state stream from {self.host} is closed")
            return IOState(int(receive.getActualDigitalInputBits()), int(receive.getActualDigitalOutputBits()),
                           (receive.getStandardAnalogInput0(), receive.getStandardAnalogInput1()),
                           (receive.getStandardAnalogOutput0(), receive.getStandardAnalogOutput1()),
                           int(receive.getRuntimeState()))
        finally:
            receive = None   # as in status(): no frame may keep the interface

    def send_program(self, script: str) -> None:
        """Send URScript on the open primary connection (port 30001)."""
        self.primary.send_script(script)

    def close(self) -> None:
        """Disconnect the RTDE stream and destroy ur_rtde's interface now (idempotent).

        ur_rtde's RTDEReceiveInterface destructor disconnects and waits 0.5 s holding the GIL. Left to the
        garbage collector, it runs at whatever moment a later collection finds the connection in a reference
        cycle: during the next connection's motion, every thread of the process (the heartbeat included) then
        stops for 0.5 s and the controller's heartbeat watchdog stops a healthy motion. Dropping the last
        reference here runs it while this connection moves nothing (status() keeps none in its frame, which a
        raised error's traceback may keep)."""
        self._closed = True
        self._destroy_receive()

    def _destroy_receive(self) -> None:
        """Disconnect and destroy the current interface, if any (why now: close()). Only the destructor
        disconnects: it waits its 0.5 s holding the GIL even after an explicit `disconnect()`, which would wait
        0.5 s more (one reference: dropping it runs the destructor)."""
        receive, self._receive = self._receive, None
        del receive


def _open_receive(host: str) -> RTDEReceive:
    """A new ur_rtde receive interface on `host`'s RTDE stream, after ur3dq's own bounded handshake (ur_rtde's
    constructor would block without limit on a port that accepts and stays silent); RobotConnectionError if either
    fails. Its wait for the first package ends when the session does: check `isConnected()`."""
    probe_rtde(host)
    try:
        # ur_rtde ships no type information: the interface is typed by the Protocol above from here on.
        return cast(RTDEReceive, rtde_receive.RTDEReceiveInterface(host, -1.0, RTDE_VARIABLES))
    except RuntimeError as error:
        raise RobotConnectionError(f"cannot start the RTDE state stream from {host}:30004: {error}") from None

