"""The urx backend (as the source thesis used): urx 0.11 reads joints and TCP from port 30002 and sends programs;
modes and stop flags come from our own primary-interface reader, because urx 0.11 misreads the Robot Mode Data
of controllers newer than 3.4 (its `is_running()` stays False there), so completion is watched by ur3dq's logic.
"""
from __future__ import annotations

import logging
import socket
import struct
import threading
import time

import numpy as np
import urx.ursecmon
from urx.urrobot import URRobot

from ur3dq.errors import ConnectionLostError, RobotConnectionError
from ur3dq.robot import state
from ur3dq.robot.io_state import IOState
from ur3dq.robot.primary_client import PrimaryClient

RUNTIME_STOPPED, RUNTIME_PLAYING, RUNTIME_PAUSED = 1, 2, 4   # RTDE runtime_state codes (io_state.RUNTIME_STATE_NAMES)
# urx hands a program to its reader thread and waits on a condition with no timeout; if that thread has died
# (it ends on a closed stream, or one silent for RECEIVE_TIMEOUT) the wait would never return, so it is bounded here.
SEND_TIMEOUT = 2.0
# How long urx's reader waits for data before it ends the session. urx's own 0.5 s ends a healthy session whenever
# a loaded host stalls its reader thread that long; this is ur_rtde's 2.5 s, beyond the freeze timeout, so that a
# silent stream is judged by the driver's freeze timeout on both backends, and a dead one still ends the reader.
RECEIVE_TIMEOUT = 2.5


class URXBackend:
    """Joints, TCP and program sending through urx; modes and flags from `primary` (a PrimaryClient)."""

    name = "urx"
    poll_period = 0.005  # urx and the primary interface update at 10 Hz
    freeze_timeout = 1.5  # fifteen missed 10 Hz packets (the reader itself ends after RECEIVE_TIMEOUT)

    def __init__(self, host: str, primary: PrimaryClient) -> None:
        self.host = host
        self.primary = primary
        self._robot = _open_urx(host)

    @property
    def connected(self) -> bool:
        """True while urx's reader thread and our primary reader both run."""
        return bool(self._robot.secmon.is_alive()) and self.primary.alive

    def reconnect(self) -> None:
        """Open a fresh urx connection (the primary reader is reconnected by the Robot)."""
        self._shut(self._robot)
        self._robot = _open_urx(self.host)

    def status(self) -> state.RobotStatus:
        """A RobotStatus from urx's newest joint/cartesian data and the primary reader's robot mode."""
        if not self.connected:
            self._shut(self._robot)  # a dead peer would leave urx's reader spinning on recv
            raise ConnectionLostError(f"the urx/primary state stream from {self.host} stopped (closed, or silent "
                                      f"longer than {RECEIVE_TIMEOUT} s)")
        data = self._robot.secmon.get_all_data()
        mode, state_time = self.primary.robot_mode, self.primary.last_state_time
        if mode is None or state_time is None or "JointData" not in data or "CartesianInfo" not in data:
            raise ConnectionLostError(f"no complete robot state from {self.host} yet")
        joint_data, cartesian = data["JointData"], data["CartesianInfo"]
        now = time.monotonic()
        urx_age = time.time() - self._robot.secmon.lastpacket_timestamp
        return state.validated(state.RobotStatus(
            joints=np.array([joint_data[f"q_actual{i}"] for i in range(6)]),
            joint_speeds=np.array([joint_data[f"qd_actual{i}"] for i in range(6)]),
            tcp_pose=np.array([cartesian[key] for key in ("X", "Y", "Z", "Rx", "Ry", "Rz")]),
            robot_mode=mode.robot_mode,
            safety_mode=self.primary.safety_mode if self.primary.safety_mode is not None else 0,
            program_running=mode.program_running,
            protective_stopped=mode.protective_stopped,
            emergency_stopped=mode.emergency_stopped,
            speed_scaling=mode.speed_scaling,
            target_speed_fraction=mode.target_speed_fraction,
            age=max(urx_age, now - state_time),
            program_paused=mode.program_paused,
        ), f"the urx/primary state stream from {self.host}", safety_mode_reported=False)

    def io_status(self) -> IOState:
        """The I/O from the newest masterboard data and the program state from the newest robot mode data, both as
        ur3dq's primary reader parsed them (urx 0.11 misreads 3.x controllers' masterboard data: its digital bits
        read 0 and its analog values garbage)."""
        board, mode = self.primary.board_io, self.primary.robot_mode
        if board is None or mode is None:
            raise ConnectionLostError(f"no masterboard data from {self.host} yet")
        runtime = RUNTIME_PAUSED if mode.program_paused else RUNTIME_PLAYING if mode.program_running else \
            RUNTIME_STOPPED
        return IOState(board.digital_in, board.digital_out, board.analog_in, board.analog_out, runtime)

    def send_program(self, script: str) -> None:
        """Send URScript through urx (port 30002); ConnectionLostError if urx cannot hand it over in time."""
        if not self._robot.secmon.is_alive():
            raise ConnectionLostError(f"urx's connection to {self.host} has stopped; program not sent")
        sender = threading.Thread(target=self._robot.send_program, args=(script,), daemon=True)
        sender.start()
        sender.join(SEND_TIMEOUT)
        if sender.is_alive():
            raise ConnectionLostError(f"urx could not send the program to {self.host} within {SEND_TIMEOUT} s")

    def close(self) -> None:
        """Stop urx's reader and close its socket (idempotent)."""
        self._shut(self._robot)

    @staticmethod
    def _shut(robot: _URRobot) -> None:
        """Close a URRobot without hanging. A healthy urx reader sees its stop flag after the next 10 Hz packet;
        on a dead or frozen peer it never would (it loops on recv), so then its socket is closed under it."""
        secmon = robot.secmon
        secmon._trystop = True
        secmon.join(timeout=0.6)
        if secmon.is_alive():
            try:
                secmon._s_secondary.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            secmon._s_secondary.close()
            secmon.join(timeout=2.0)
        secmon._s_secondary.close()


# What urx's parser takes for the start of a packet: a big-endian int32 size in [5, 2000] and the type byte 16.
_HEADER = struct.Struct("!iB")
_PACKET_TYPE = 16
_MIN_PACKET, _MAX_PACKET = 5, 2000


def take_packet(queue: bytes) -> tuple[bytes | None, bytes]:
    """Split the first packet urx would take off the front of `queue`.

    (packet, rest) for the first span of `queue` urx would take for a packet, or (None, rest) when there is none
    yet: `rest` then keeps only what could still begin one, so garbage is dropped as it is read.

    The same packet as urx's `ParserUtils.find_first_packet`, which steps one byte at a time with a copy of the
    rest per step and keeps the skipped garbage until a packet turns up; its reader rescans that whole queue after
    every 1,024-byte read, so a stream of garbage costs time quadratic in its length. That reader holds the GIL
    nearly all the time, and the heartbeat
    thread (ur3dq.robot.heartbeat) would then miss the controller's 0.1 s watchdog and the program stop before the
    driver could report the stream as garbage. Here the type byte is found by `bytes.find`, in C, and the queue
    holds at most one incomplete packet and the 1,024 bytes read after it."""
    start = 0
    while True:
        at = queue.find(bytes((_PACKET_TYPE,)), start + 4)
        if at < 0:
            return None, queue[max(start, len(queue) - 4):]
        start = at - 4
        size = _HEADER.unpack_from(queue, start)[0]
        if _MIN_PACKET <= size <= _MAX_PACKET:
            if len(queue) - start < size:
                return None, queue[start:]
            return queue[start:start + size], queue[start + size:]
        start += 1


# urx ships no type information, so its classes are Any to mypy; these two subclasses are where urx enters ur3dq.
class _QuietSecondaryMonitor(urx.ursecmon.SecondaryMonitor):  # type: ignore[misc]  # urx is untyped (above)
    """urx's 30002 reader thread, ending quietly when the stream breaks or falls silent (the error kept in `error`):
    urx's own run() dies there with a traceback on stderr, while the driver reports the loss as ConnectionLostError."""

    # The attributes of urx's monitor that ur3dq reads or sets, as urx's __init__ makes them.
    _dataqueue: bytes   # urx's receive buffer
    _s_secondary: socket.socket
    _trystop: bool   # urx's reader loop ends when it is set
    lastpacket_timestamp: float   # time.time() of the last packet urx parsed

    # A class default: the thread starts inside urx's __init__ and may end before it returns.
    error: OSError | None = None

    def start(self) -> None:
        # urx's reader is not a daemon: on a stream of garbage it spins looking for a packet forever, and a failed
        # connection (urx raises from its constructor, so nobody holds the thread) kept the process from exiting.
        self.daemon = True
        self._s_secondary.settimeout(RECEIVE_TIMEOUT)   # urx's constructor opened it with 0.5 s
        super().start()

    def run(self) -> None:
        try:
            super().run()
        except OSError as error:  # closed, reset, or silent for RECEIVE_TIMEOUT
            self.error = error

    def _get_data(self) -> bytes:
        """urx's read of the next packet, linear in the bytes read (take_packet); ConnectionResetError when the
        controller closed the connection (urx's own loop spins on the empty reads, its thread alive, so the driver
        took the connection for up and read the state of before the close as the newest)."""
        while True:
            packet, self._dataqueue = take_packet(self._dataqueue)
            if packet is not None:
                return packet
            data = self._s_secondary.recv(1024)
            if not data:
                raise ConnectionResetError("the controller closed urx's connection (port 30002)")
            self._dataqueue += data

    def wait(self, timeout: float = 0.5) -> None:
        """urx's wait for a fresh packet; on its timeout the reader is ended and its socket closed before the
        exception leaves (urx's constructor raises it, and the half-built connection would otherwise live on)."""
        try:
            super().wait(timeout)
        except urx.ursecmon.TimeoutException:
            self._trystop = True
            try:
                self._s_secondary.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            self._s_secondary.close()
            raise


class _URRobot(URRobot):  # type: ignore[misc]  # urx is untyped (above)
    """urx's URRobot on a _QuietSecondaryMonitor (URRobot.__init__ hard-codes its monitor class); the monitor's
    constructor already waits for the first packet, and the 125 Hz real-time monitor stays off as in urx."""

    def __init__(self, host: str) -> None:
        self.logger = logging.getLogger("urx")
        self.host = host
        self.csys = None
        self.rtmon = None
        self.joinEpsilon = 0.01
        self.max_float_length = 6
        self.secmon = _QuietSecondaryMonitor(host)


#: Attempts at urx's connection: urx gives the controller a fixed 0.5 s for its first state packet, which a loaded
#: machine (or controller) can miss once; a refused or unreachable port is not retried.
URX_CONNECT_ATTEMPTS = 3


def _open_urx(host: str) -> _URRobot:
    """A connected urx URRobot, or RobotConnectionError."""
    for _ in range(URX_CONNECT_ATTEMPTS):
        try:
            return _URRobot(host)
        except urx.ursecmon.TimeoutException:
            continue   # urx's 0.5 s for the first packet ran out: try again
        except OSError as error:
            raise RobotConnectionError(f"urx cannot connect to {host}:30002: {error}") from None
    raise RobotConnectionError(f"urx cannot connect to {host}:30002: no valid state packet within 0.5 s "
                               f"({URX_CONNECT_ATTEMPTS} attempts: the port is silent, slow, or not sending a UR "
                               "controller's data)")
