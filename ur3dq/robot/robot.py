"""The Robot facade: checked motions sent as URScript and watched to their end, stops, power, TCP, freedrive.

A motion is only reported done when the controller says the program ran and ended and the arm rests at the
target; every fault (protective stop, emergency stop, program error, dropped or frozen stream, overrun) raises
its own RobotError subclass within a bounded time, and any error or KeyboardInterrupt during a motion sends
`stopj` before it leaves the driver. Nothing here ever resends a motion by itself.
"""
from __future__ import annotations

import functools
import math
import queue
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np
import numpy.typing as npt

from ur3dq import urscript
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import (
    ConnectionLostError,
    EmergencyStopError,
    MotionTimeoutError,
    ProgramError,
    ProtectiveStopError,
    RobotConnectionError,
    RobotError,
    SafetyCheckError,
)
from ur3dq.kinematics import robot_model_from_dh
from ur3dq.robot import motion, primary, safety, state
from ur3dq.robot.dashboard import Dashboard, model_from_reply
from ur3dq.robot.heartbeat import WATCHDOG_FREQUENCY, Heartbeat, armed
from ur3dq.robot.io_state import IOState
from ur3dq.robot.primary_client import PrimaryClient, send_script

if TYPE_CHECKING:
    from ur3dq.pathcheck import Cell, Margins, PathPlan

URSCRIPT_DEFAULT_A = 1.4  # rad/s², URScript movej default
URSCRIPT_DEFAULT_V = 1.05  # rad/s
SAFE_STOP_DECELERATION = 2.0  # rad/s²: stops a 1.05 rad/s joint in 0.5 s (ur_rtde's stopJ default)
MAX_BLEND_RADIUS = 2.0  # metres; ur_rtde's client-side bound
START_TIMEOUT = 5.0  # s for the controller to start a sent program (generous: a loaded simulator parses slowly)
SETTLE_TIME = 0.3  # s a stopped program may take to show the arm at rest before it counts as failed
RECONNECT_DELAYS = (0.05, 0.1, 0.2, 0.4, 0.8)  # s between stream reconnection attempts (exponential backoff)
MODE_CHANGE_TIMEOUT = 15.0  # s for power on / brake release to reach their robot mode
SERIAL_NUMBER_SINCE = (5, 6)
ROBOT_MODE_POWER_OFF = 3  # the dashboard's `get serial number` exists from PolyScope 5.6


class StateBackend(Protocol):
    """What Robot needs from a state/program backend (RTDEBackend over ur_rtde, URXBackend over urx).

    `status()` is the newest reading and never blocks on the network; `send_program` hands one URScript program
    to the controller; `connected` / `reconnect()` let Robot restore a dropped stream; `primary` is the shared
    PrimaryClient (Robot replaces it after reconnecting it).
    """

    poll_period: float      # s between two status() polls while watching a motion
    freeze_timeout: float   # s without fresh data after which the stream counts as frozen
    primary: PrimaryClient

    @property
    def connected(self) -> bool:
        """Whether the backend's connections are up."""

    def reconnect(self) -> None:
        """Open the connections again after a drop."""

    def status(self) -> state.RobotStatus:
        """The newest validated RobotStatus, without waiting on the network."""

    def io_status(self) -> IOState:
        """The newest digital and analog I/O and the program's runtime state (None where not reported)."""

    def send_program(self, script: str) -> None:
        """Send one URScript program to the controller."""

    def close(self) -> None:
        """Close every connection (idempotent)."""


def calibrated_model(name, kinematics, tcp_offset=None):
    """The ur3dq model `name` with the controller's calibrated DH and (if given) its TCP offset (UR pose vector)."""
    model = robot_model_from_dh(name, kinematics.a, kinematics.d, kinematics.alpha, kinematics.theta)
    return model.with_tcp(tcp_offset) if tcp_offset is not None else model


def effective_speed_limits(model, configuration):
    """(max joint acceleration, max joint speed) arrays: the lower of the model's and the controller's values."""
    if configuration is None:
        return np.asarray(model.max_joint_acceleration, float), np.asarray(model.max_joint_speed, float)
    return (np.minimum(model.max_joint_acceleration, configuration.max_joint_acceleration),
            np.minimum(model.max_joint_speed, configuration.max_joint_speed))


class Robot:
    """A connection to one UR controller. Use `ur3dq.robot.connect(...)`; close with `close()` or `with`."""

    _primary: PrimaryClient
    _dashboard: Dashboard
    _backend: StateBackend

    def __init__(self, host, backend: str="rtde", model=None, max_joint_travel=safety.DEFAULT_MAX_JOINT_TRAVEL,
                 connect_timeout: float=3.0, heartbeat: bool=True, path_check=None) -> None:
        if backend not in ("rtde", "urx"):
            raise ValueError(f"backend must be 'rtde' or 'urx', got {backend!r}")
        if not (isinstance(max_joint_travel, (int, float)) and max_joint_travel > 0):
            raise ValueError(f"max_joint_travel must be a positive number of radians, got {max_joint_travel!r}")
        self.host = host
        self.backend_name = backend
        self.max_joint_travel = float(max_joint_travel)
        self._connect_timeout = connect_timeout
        # _primary, _dashboard and _backend exist once connected (close() also runs on a half-made Robot)
        self._heartbeat: Heartbeat | None = None
        # Every motion program stops by itself when ur3dq dies (kill -9, a crash, a hang): ur3dq.robot.heartbeat.
        # Started with the first motion, so that reading, recording or a second ur3dq watching the same arm never
        # contend for its RTDE input registers.
        self._use_heartbeat = bool(heartbeat)
        self._path_check: tuple[Cell | None, Margins] | None = None
        self.link_delay = 0.0   # s, measured while connecting (_identify_model)
        if path_check is not None:
            self.require_path_check(*(() if path_check is True else (path_check,)))
        try:
            self._primary = self._open_primary()
            self._version: primary.VersionMessage = self._primary.version   # type: ignore[assignment]  # waited for
            self._dashboard = Dashboard(host)
            self.model_name = self._identify_model(model)
            self.model = calibrated_model(self.model_name, self._primary.kinematics,
                                          self._controller_tcp_offset())
            self._backend = self._open_backend()
        except BaseException:
            self.close()
            raise

    # --- connection -------------------------------------------------------------------------------------------

    def __enter__(self):
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def close(self) -> None:
        """Close every connection (idempotent). Never moves or stops the arm (no motion runs between calls)."""
        for name in ("_heartbeat", "_backend", "_dashboard", "_primary"):
            part = getattr(self, name, None)
            if part is not None:
                part.close()

    @property
    def controller_version(self):
        """(major, minor, bugfix, build) of the controller software, from the primary version message."""
        version = self._version
        return (version.major, version.minor, version.bugfix, version.build)

    @functools.cached_property
    def serial_number(self):
        """The controller's serial number (dashboard, PolyScope 5.6 and later), or None where it cannot tell."""
        if self.controller_version[:2] < SERIAL_NUMBER_SINCE:
            return None
        return self._dashboard.serial_number()

    def _open_primary(self):
        """A PrimaryClient that has received the version, robot mode, kinematics and configuration."""
        client = PrimaryClient(self.host)
        complete = client.wait_for(
            lambda c: None not in (c.version, c.robot_mode, c.kinematics, c.cartesian), self._connect_timeout)
        if not complete:
            client.close()
            raise RobotConnectionError(
                f"the primary interface of {self.host} sent no version, robot state and Kinematics Info "
                f"within {self._connect_timeout} s ({client.error or 'incomplete data'})")
        return client

    def _open_backend(self) -> StateBackend:
        """The state/program backend chosen at connect time."""
        if self.backend_name == "rtde":
            from ur3dq.robot.rtde_backend import RTDEBackend
            return RTDEBackend(self.host, self._primary)
        from ur3dq.robot.urx_backend import URXBackend
        return URXBackend(self.host, self._primary)

    def _identify_model(self, requested):
        """The model name from the dashboard and Configuration Data; RobotError if they or `requested` disagree."""
        major = self._version.major
        asked = time.monotonic()
        reply = self._dashboard.robot_model_reply()
        # The link's round trip, timed here: every report of a motion (its start, its end) comes that late, so each
        # motion's timeout is extended by it (a slow link is no motion timeout).
        self.link_delay = time.monotonic() - asked
        identified = model_from_reply(reply, major)
        configuration = self._primary.configuration
        if configuration is not None:
            from_configuration = primary.model_name(configuration.robot_type, major)
            if from_configuration != identified:
                raise RobotError(f"the dashboard says {identified} but Configuration Data says {from_configuration}")
        if requested is not None and requested.lower() != identified:
            raise RobotError(f"model {requested!r} was requested but the controller is a {identified}")
        return identified

    def _controller_tcp_offset(self):
        """The controller's active TCP offset (UR pose vector, flange frame), or None before software 3.2."""
        cartesian = self._primary.cartesian
        return None if cartesian is None else cartesian.tcp_offset

    def _ensure_streams(self):
        """Reconnect dead state streams (and the heartbeat) with exponential backoff; ConnectionLostError if they
        stay down."""
        beating = self._heartbeat is None or self._heartbeat.alive
        if self._primary.alive and self._backend.connected and beating:
            return
        last_error = None
        for delay in RECONNECT_DELAYS:
            try:
                if not self._primary.alive:
                    self._primary.close()
                    self._primary = self._open_primary()
                    self._backend.primary = self._primary
                if not self._backend.connected:
                    self._backend.reconnect()
                if self._heartbeat is not None and not self._heartbeat.alive:
                    self._heartbeat.restart()
                return
            except RobotConnectionError as error:
                last_error = error
                time.sleep(delay)
        raise ConnectionLostError(
            f"the state streams from {self.host} stay down after {len(RECONNECT_DELAYS)} attempts: {last_error}")

    # --- reading ----------------------------------------------------------------------------------------------

    def state(self):
        """The newest RobotStatus (joints, TCP, robot/safety mode, program running, speed fractions, age)."""
        self._ensure_streams()
        return self._backend.status()

    def io_state(self) -> IOState:
        """The controller's digital and analog I/O and the program's runtime state (ur3dq.robot.io_state)."""
        self._ensure_streams()
        return self._backend.io_status()

    def program_state(self) -> str:
        """The dashboard's `programState` reply, e.g. 'PLAYING ur3dq_program' or 'STOPPED <unnamed>'."""
        return self._dashboard.program_state()

    def joints(self) -> np.ndarray:
        """The actual joint angles (radians, 6); ConnectionLostError if the stream is frozen."""
        return self._fresh_status().joints

    def tcp_pose(self):
        """The TCP pose the controller reports, as a DualQuaternion (base frame)."""
        return DualQuaternion.from_ur_pose(self.tcp_pose_vector())

    def tcp_pose_vector(self):
        """The TCP pose the controller reports, as a UR pose vector [x, y, z, rx, ry, rz]."""
        return self._fresh_status().tcp_pose

    def _fresh_status(self):
        """A status no older than the backend's freeze timeout; a late stream gets that long again to catch up
        (a loaded controller or network can stall it briefly), then ConnectionLostError."""
        limit = self._backend.freeze_timeout
        deadline = time.monotonic() + limit
        while True:
            status = self.state()
            if status.age <= limit:
                return status
            if time.monotonic() > deadline:
                raise ConnectionLostError(
                    f"the state stream from {self.host} is frozen: no fresh data for {status.age:.2f} s")
            time.sleep(self._backend.poll_period)

    # --- motion -----------------------------------------------------------------------------------------------

    def movej(self, q, a=None, v=None, expected_pose=None):
        """Move to joint target `q` (rad) on a trapezoid with acceleration a (rad/s²) and speed v (rad/s).

        Blocks until there is evidence that this program ran and ended (its own end key message, or the state
        stream showing it running then not running) and the arm rests at `q`; returns the wall time in seconds.
        `expected_pose` (DualQuaternion) marks a target that came from IK: the model's FK of `q` must reach it.
        """
        return self.movej_path([q], blend=0.0, a=a, v=v, expected_poses=None if expected_pose is None
                               else [expected_pose])

    def movej_path(self, targets, blend: float=0.0, a=None, v=None, expected_poses=None):
        """Move through joint `targets` in one blended program (blend radius in metres); returns wall time (s)."""
        targets = [self._checked_target(q, f"targets[{index}]") for index, q in enumerate(targets)]
        if not targets:
            raise SafetyCheckError("targets must hold at least one joint vector")
        if expected_poses is not None:
            if len(expected_poses) != len(targets):
                raise SafetyCheckError(f"expected_poses has {len(expected_poses)} entries for {len(targets)} targets")
            for index, (q, pose) in enumerate(zip(targets, expected_poses)):
                safety.check_fk_consistency(self.model, q, pose, name=f"targets[{index}]")
        if not (isinstance(blend, (int, float)) and math.isfinite(blend) and 0.0 <= blend <= MAX_BLEND_RADIUS):
            raise SafetyCheckError(f"blend must be a radius in metres within [0, {MAX_BLEND_RADIUS}], got {blend!r}")
        status = self._ready_status()
        a, v = self._clamped(status.joints, targets, a, v)
        previous = status.joints
        for index, q in enumerate(targets):
            safety.check_travel(previous, q, self.max_joint_travel, name=f"targets[{index}]")
            previous = q
        if len(targets) == 1 and motion.leading_travel(status.joints, targets[0]) < 1e-9:
            return 0.0  # already there: sending a program would only add a start/stop
        if self._path_check is not None:
            from ur3dq.pathcheck import PathPlan, PathSegment

            last = len(targets) - 1
            self._require_clear_path(PathPlan(status.joints, [
                PathSegment(f"targets[{index}]", "joint", target_joints=q, speed=v, acceleration=a,
                            blend=0.0 if index == last else float(blend)) for index, q in enumerate(targets)]))
        duration = motion.path_duration(status.joints, targets, a, v)
        name = urscript.new_program_name("move")
        program = urscript.movej_program(name, targets, a, v, blend=float(blend))
        timeout = motion.motion_timeout(duration, status.target_speed_fraction) + self.link_delay
        return self._run_motion(name, program, targets[-1], status.joints, status.program_running, timeout)

    def require_path_check(self, cell=None, margins=None) -> None:
        """Refuse from now on every motion whose whole path fails the path check.

        From now on every motion is refused (SafetyCheckError, nothing sent) unless the whole path it sweeps
        passes ur3dq.pathcheck.check_path in `cell` (a Cell, or None: self-collision, singularities, limits and
        speeds only) with `margins` (a Margins, or the defaults). movej/movej_path are sampled here; run_script
        needs the PathPlan of its program (`path=`), which ur3dq.program.run gives; a script without one is refused."""
        from ur3dq.pathcheck import Margins

        self._path_check = (cell, margins or Margins())

    def _require_clear_path(self, path) -> None:
        """Check `path` (a PathPlan from the arm's joints) when a path check is required; SafetyCheckError if it
        fails, or if there is no path to check."""
        if self._path_check is None:
            return
        if path is None:
            raise SafetyCheckError("this Robot requires a path check before every motion, and this program has no "
                                   "path to check (pass run_script(..., path=PathPlan))")
        from ur3dq.pathcheck import check_path

        cell, margins = self._path_check
        result = check_path(self.model, path, cell, margins, keep_samples=False)
        if not result.ok:
            raise SafetyCheckError(f"path check: {result.summary()}")

    def movej_pose(self, pose, a=None, v=None):
        """Move to the TCP `pose` (DualQuaternion) through the IK solution closest to the current joints."""
        q = self.model.ik(pose, self.joints())
        return self.movej(q, a=a, v=v, expected_pose=pose)

    def stop(self, a=SAFE_STOP_DECELERATION) -> None:
        """Decelerate the arm to rest with `stopj(a)` (rad/s², clamped to the model's limit)."""
        self._send_stop(a)

    def _checked_target(self, q, name):
        """A joint target that is six finite values inside the model's joint limits."""
        return safety.check_joint_limits(q, self.model.joint_lower, self.model.joint_upper, name)

    def _clamped(self, q_start, targets, a, v):
        """(a, v) defaulting to URScript's and lowered so no joint of any segment exceeds its limits."""
        a = URSCRIPT_DEFAULT_A if a is None else a
        v = URSCRIPT_DEFAULT_V if v is None else v
        max_acceleration, max_speed = effective_speed_limits(self.model, self._primary.configuration)
        previous = q_start
        for q in targets:
            a, v = safety.clamp_movej_speed(np.asarray(q) - previous, a, v, max_acceleration, max_speed)
            previous = q
        return a, v

    def _ready_status(self):
        """The current status if the arm can move (running, no stop), else the specific error."""
        status = self._checked_status(self._fresh_status())
        if status.robot_mode != state.ROBOT_MODE_RUNNING:
            raise RobotError(f"the robot is in mode {status.robot_mode_name}, not RUNNING: "
                             "power it on and release the brakes first (`ur3dq robot power-on`, `ur3dq robot "
                             "brake-release`; in Python robot.power_on(), robot.brake_release())")
        return status

    def _checked_status(self, status):
        """`status` unchanged unless it shows an emergency or protective stop, or a frozen stream."""
        if status.emergency_stopped:
            raise EmergencyStopError(f"{self.host} is emergency-stopped (safety mode {status.safety_mode_name}); "
                                     "release the e-stop and power on again")
        if status.protective_stopped:
            raise ProtectiveStopError(f"{self.host} is in a protective stop; inspect the cause, then unlock it "
                                      "(`ur3dq robot unlock`; in Python robot.unlock_protective_stop())")
        if status.age > self._backend.freeze_timeout:
            raise ConnectionLostError(f"the state stream from {self.host} froze: no fresh valid data for "
                                      f"{status.age:.2f} s (silent, frozen, or sending what is not UR state)")
        if not self._primary.alive:
            raise ConnectionLostError(f"the primary interface of {self.host} closed: {self._primary.error}")
        return status

    def run_script(self, name: str, program: str, target: npt.ArrayLike, duration: float,
                   on_message: Callable[[object], None] | None = None,
                   reached_end: Callable[[], bool] | None = None, path: PathPlan | None = None) -> float:
        """Run a whole generated URScript program and watch it to its end.

        Run a whole generated `program` (URScript text of `def name(): ... end`, its targets checked by the
        caller) that ends with the arm at joint `target`, expected to take `duration` s at 100 %; each robot
        message is also given to `on_message` (which may raise to fail the run), and when `reached_end` is given
        the run is only done once it returns True (the program's own report that it ran to its end: the arm
        resting at a target it started from proves nothing). `path` (a PathPlan of the program's moves) is
        checked when require_path_check is on. Returns the wall time (s). Used by ur3dq.program.runner."""
        status = self._ready_status()
        target = self._checked_target(target, "target")
        self._require_clear_path(path)
        timeout = motion.motion_timeout(duration, status.target_speed_fraction) + self.link_delay
        return self._run_motion(urscript.check_identifier(name), program, target, status.joints,
                                status.program_running, timeout, on_message, reached_end)

    def _run_motion(self, name, program, target, q_start, running_at_send, timeout, on_message=None,
                    reached_end=None):
        """Send `program` (armed on the heartbeat), then watch it to its end; any failure stops the arm before the
        exception leaves."""
        if self._use_heartbeat:
            if self._heartbeat is None:
                self._heartbeat = Heartbeat(self.host)
            if not self._heartbeat.alive:
                raise ConnectionLostError(f"the heartbeat to {self.host} stopped: nothing would stop a motion if "
                                          "ur3dq died, so none is sent (reconnect)")
            program = armed(program, name)
        watcher = self._primary.watch()
        if self._heartbeat is not None and self._use_heartbeat:
            self._heartbeat.watch_gaps()
        sent = time.monotonic()
        try:
            self._backend.send_program(program)
            outcome = _MotionWatch(name, target, running_at_send=running_at_send,
                                   heartbeat=self._heartbeat if self._use_heartbeat else None)
            while True:
                for message in _drain(watcher):
                    outcome.note_message(message)
                    if on_message is not None:
                        on_message(message)
                status = self._checked_status(self._backend.status())
                now = time.monotonic()
                if outcome.finished(status, now) and (reached_end is None or reached_end()):
                    return now - sent
                if not outcome.started and now - sent > START_TIMEOUT + self.link_delay:
                    raise ProgramError(f"the controller did not start program {name} within "
                                       f"{START_TIMEOUT + self.link_delay:.1f} s")
                if now - sent > timeout:
                    raise MotionTimeoutError(
                        f"program {name} did not finish within {timeout:.2f} s (derived from its trapezoidal "
                        f"duration and the speed slider, plus the link's measured round trip of "
                        f"{self.link_delay:.3f} s); the arm is {outcome.distance(status):.4f} rad from target")
                time.sleep(self._backend.poll_period)
        except BaseException as error:
            self._stop_after(error)
            raise
        finally:
            self._primary.unwatch(watcher)

    def _stop_after(self, error) -> None:
        """Best-effort stopj after a failed or interrupted motion; a failing stop is attached, never raised."""
        try:
            self._send_stop(SAFE_STOP_DECELERATION)
        except RobotError as stop_error:
            error.add_note(f"ur3dq: sending stopj after this error also failed: {stop_error}")

    def _send_stop(self, a):
        """Send a `stopj` program on the primary connection, or on a fresh one if that is gone (never via urx,
        whose sending can block)."""
        a = min(float(a), float(np.min(self.model.max_joint_acceleration)))
        if not (math.isfinite(a) and a > 0):
            raise ValueError(f"a (deceleration) must be finite and > 0, got {a!r}")
        stop_program = urscript.program(urscript.new_program_name("stop"), [urscript.stopj_statement(a)])
        try:
            self._primary.send_script(stop_program)
        except ConnectionLostError:
            send_script(self.host, stop_program)

    # --- power, safety, TCP, freedrive ------------------------------------------------------------------------

    def power_on(self):
        """Power the arm on and wait until it is IDLE (brakes still held); EmergencyStopError if e-stopped."""
        if self.state().emergency_stopped:
            raise EmergencyStopError(f"power on refused: {self.host} is emergency-stopped; release the e-stop first")
        self._dashboard.power_on()
        self._wait_for_mode({state.ROBOT_MODE_IDLE, state.ROBOT_MODE_RUNNING}, "power on")

    def power_off(self) -> None:
        """Power the arm off (brakes engage) and wait until it is POWER_OFF."""
        self._dashboard.power_off()
        self._wait_for_mode({ROBOT_MODE_POWER_OFF}, "power off")

    def brake_release(self):
        """Release the brakes and wait until the arm is running.

        Release the brakes and wait until the arm is RUNNING; RobotError at once unless it is powered on (IDLE)
        or already RUNNING (the controller would not release them)."""
        mode = self.state().robot_mode
        if mode == state.ROBOT_MODE_RUNNING:
            return
        if mode != state.ROBOT_MODE_IDLE:
            raise RobotError(f"brake release refused: the robot is in mode {state.ROBOT_MODE_NAMES.get(mode, mode)}, "
                             "not IDLE; power it on first (`ur3dq robot power-on`)")
        self._dashboard.brake_release()
        self._wait_for_mode({state.ROBOT_MODE_RUNNING}, "brake release")

    def unlock_protective_stop(self):
        """Unlock a protective stop (the controller refuses within 5 s of it). Never called by ur3dq itself."""
        self._dashboard.unlock_protective_stop()
        deadline = time.monotonic() + 2.0
        while self.state().protective_stopped:
            if time.monotonic() > deadline:
                raise ProtectiveStopError(f"{self.host} still reports a protective stop 2 s after the unlock")
            time.sleep(0.01)

    def set_tcp(self, tcp):
        """Set the controller's TCP offset (DualQuaternion or UR pose vector, flange frame); the model follows."""
        pose = tcp.to_ur_pose() if isinstance(tcp, DualQuaternion) else safety.check_pose_vector(tcp, "tcp")
        name = urscript.new_program_name("tcp")
        self._backend.send_program(urscript.program(name, [urscript.set_tcp_statement(pose)]))
        applied = self._primary.wait_for(
            lambda c: c.cartesian is not None and c.cartesian.tcp_offset is not None
            and np.allclose(c.cartesian.tcp_offset, pose, atol=1e-9), timeout=2.0)
        if not applied:
            raise ProgramError(f"the controller did not apply TCP offset {list(pose)} within 2 s")
        self.model = self.model.with_tcp(pose)

    def teach_mode(self, on, hold_seconds: float=3600.0):
        """Freedrive on (a program holding freedrive for `hold_seconds`) or off; waits for the controller."""
        name = urscript.new_program_name("teach")
        statements = urscript.freedrive_statements(hold_seconds) if on else urscript.end_freedrive_statements()
        self._ready_status()
        self._backend.send_program(urscript.program(name, statements))
        wanted = 1 if on else 0  # primary controlMode: 1 TEACH, 0 POSITION
        if not self._primary.wait_for(lambda c: c.robot_mode.control_mode == wanted, timeout=2.0):
            raise ProgramError(f"the controller did not switch freedrive {'on' if on else 'off'} within 2 s")

    def freedrive_active(self) -> bool:
        """Whether the controller is in freedrive now.

        True while the controller is in freedrive (primary controlMode TEACH): another program sent to the
        controller ends ur3dq's freedrive program, so a teach session checks this before each recording."""
        self._ensure_streams()
        asked = time.monotonic()  # a state message sent after the question, not one from before a change
        if not self._primary.wait_for(lambda c: c.last_state_time is not None and c.last_state_time > asked,
                                      timeout=self._backend.freeze_timeout):
            raise ConnectionLostError(f"the primary interface of {self.host} sent no robot state for "
                                      f"{self._backend.freeze_timeout} s")
        robot_mode = self._primary.robot_mode
        return robot_mode is not None and robot_mode.control_mode == 1

    def _wait_for_mode(self, modes, action):
        """Wait until the robot mode is one of `modes`; RobotError naming `action` after MODE_CHANGE_TIMEOUT."""
        deadline = time.monotonic() + MODE_CHANGE_TIMEOUT
        while True:
            status = self.state()
            if status.robot_mode in modes:
                return
            if status.emergency_stopped:
                raise EmergencyStopError(f"{action} impossible: {self.host} is emergency-stopped")
            if time.monotonic() > deadline:
                raise RobotError(f"{action}: the robot is still in mode {status.robot_mode_name} after "
                                 f"{MODE_CHANGE_TIMEOUT} s")
            time.sleep(0.02)


class _MotionWatch:
    """What is known about one sent program: started/ended (key messages or state), and the controller's errors.

    A motion is done only on evidence that *this* program ran and ended — its own PROGRAM_XXX_STOPPED key message,
    or the state stream showing it running and then not running — and the arm at rest on the target. Being at rest
    on the target proves nothing by itself: a closed path [B, A] or a zero-length move starts there.
    """

    def __init__(self, name: str, target, running_at_send: bool, heartbeat=None) -> None:
        self.name = name
        self.heartbeat = heartbeat  # the Heartbeat the program is armed on (None: not armed)
        self.target = np.asarray(target, dtype=float)
        self.started = False
        self.stopped = False  # our STOPPED key message arrived
        # A program already running when ours was sent (or its stale flag) is not ours: the state's "running"
        # counts as our start only after the state has shown no program since the send.
        self._running_is_ours = not running_at_send
        self._seen_running = False  # the state stream showed our program running
        self._ended_on_state = False  # ... and then not running
        self.last_error_text: str | None = None
        # raised once the state had time to show a safety stop behind it instead
        self.runtime_error: ProgramError | None = None
        self._ended_at: float | None = None
        self._error_at: float | None = None

    def note_message(self, message) -> None:
        """Update from one robot message (key messages, runtime exceptions, error codes)."""
        if primary.is_program_started(message, self.name):
            self.started = True
        elif primary.is_program_stopped(message, self.name):
            self.started = self.stopped = True
        elif isinstance(message, primary.RuntimeExceptionMessage) and self.runtime_error is None:
            self.runtime_error = ProgramError(
                f"the controller reported an error in program {self.name} at line {message.line}, "
                f"column {message.column}: {message.text}")
        elif isinstance(message, primary.ErrorCodeMessage) and message.report_level >= 2:
            self.last_error_text = f"C{message.code}A{message.argument}: {message.text}"

    def distance(self, status) -> float:
        """The largest joint distance (rad) from the arm to the target."""
        return float(np.max(np.abs(status.joints - self.target)))

    @property
    def ended(self) -> bool:
        """True once there is evidence that this program ran and ended."""
        return self.stopped or self._ended_on_state

    def finished(self, status, now: float) -> bool:
        """True when the program has ended with the arm at rest on target; ProgramError if it ended elsewhere or
        the controller reported a runtime error (after SETTLE_TIME, so a safety stop behind it is seen first)."""
        if self.runtime_error is not None:
            if self._error_at is None:
                self._error_at = now
            elif now - self._error_at > SETTLE_TIME:
                raise self.runtime_error
            return False
        # The controller's key message announces the end a state cycle before the state stream agrees; waiting
        # for the stream too would add that cycle to every move.
        if status.program_running:
            if self._running_is_ours:
                self.started = self._seen_running = True
            if not self.stopped:
                self._ended_at = None
                return False
        else:
            self._running_is_ours = True
            if self._seen_running:
                self._ended_on_state = True
        if not self.ended:
            return False
        if state.at_rest_at(status, self.target):
            return True
        if self._ended_at is None:
            self._ended_at = now
        # Only a state the stream delivered after the end says where the arm ended: one from before (a frozen
        # stream, garbled on the wire) shows the arm where it was then, and the stream's freeze check reports it.
        elif now - self._ended_at > SETTLE_TIME and now - status.age > self._ended_at:
            raise ProgramError(f"program {self.name} ended with the arm {self.distance(status):.4f} rad from its "
                               f"target{self._stop_reason()}")
        return False

    def _stop_reason(self) -> str:
        """What ended the program short of its target, as far as ur3dq can tell: the controller's error, or its
        heartbeat watchdog when the heartbeat went a watchdog period without a write (the controller's key
        message does not say why a program stopped)."""
        if self.last_error_text:
            return f": {self.last_error_text}"
        gap = self.heartbeat.longest_gap() if self.heartbeat is not None else 0.0
        if gap >= 1.0 / WATCHDOG_FREQUENCY:
            return (f": most likely the controller's heartbeat watchdog (ur3dq's heartbeat wrote nothing for "
                    f"{gap:.3f} s; the watchdog stops a program after {1.0 / WATCHDOG_FREQUENCY:g} s)")
        return ""


def _drain(watcher):
    """Every message waiting in `watcher`, without blocking."""
    while True:
        try:
            yield watcher.get_nowait()
        except queue.Empty:
            return
