"""The Robot facade: checked motions sent as URScript and watched to their end, stops, power, TCP, freedrive.

A motion is only reported done when the controller says the program ran and ended and the arm rests at the
target; every fault (protective stop, emergency stop, program error, dropped or frozen stream, overrun) raises
its own RobotError subclass within a bounded time, and any error or KeyboardInterrupt during a motion sends
`stopj` before it leaves the driver. Nothing here ever resends a motion by itself.
"""
from __future__ import annotations

import functools
import math
import threading
import time
from collections.abc import Callable, Collection, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ur3dq import errors, urscript
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import (
    ConnectionLostError,
    EmergencyStopError,
    ProgramError,
    ProtectiveStopError,
    RobotConnectionError,
    RobotError,
    SafetyCheckError,
    add_separate_note,
)
from ur3dq.robot import interrupts, jog_steps, motion, primary, safety, state
from ur3dq.robot.backend import StateBackend, calibrated_model, effective_speed_limits
from ur3dq.robot.dashboard import Dashboard, identified_model
from ur3dq.robot.heartbeat import WATCHDOG_FREQUENCY, Heartbeat, armed
from ur3dq.robot.io_state import IOState, io_bit
from ur3dq.robot.motion_watch import MotionWatch, drain, last_reports
from ur3dq.robot.primary_client import PrimaryClient, send_script
from ur3dq.robot.rtde_inputs import RTDEInputs
from ur3dq.robot.state import RobotStatus

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel
    from ur3dq.pathcheck import Cell, Margins, PathPlan

PoseLike = safety.PoseLike

URSCRIPT_DEFAULT_A = 1.4  # rad/s², URScript movej default
URSCRIPT_DEFAULT_V = 1.05  # rad/s
SAFE_STOP_DECELERATION = 2.0  # rad/s²: stops a 1.05 rad/s joint in 0.5 s (ur_rtde's stopJ default)
MAX_BLEND_RADIUS = 2.0  # metres; ur_rtde's client-side bound
AFTER_STOP_WAIT = 0.5  # s to read a stopped program's last reports (its end key message) before giving up
LATE_REPORTS_WAIT = 3.0  # ... when the streams went silent: a frozen controller sends its reports late, not never
PROGRAM_STATE_TIMEOUT = 2.0  # s for a pause or a resume to show in the state
OUTPUT_TIMEOUT = 1.0  # s for a digital output written over RTDE to show in the state
REST_SPEED = 1e-3  # rad/s: a paused arm whose every joint is slower than this rests
RECONNECT_DELAYS = (0.05, 0.1, 0.2, 0.4, 0.8)  # s between stream reconnection attempts (exponential backoff)
RECONNECT_TIMEOUT = 2.0  # s from the first attempt on, no other starts: one on a silent controller takes seconds
MODE_CHANGE_TIMEOUT = 15.0  # s for power on / brake release to reach their robot mode
SERIAL_NUMBER_SINCE = (5, 6)  # the dashboard's `get serial number` exists from PolyScope 5.6
ROBOT_MODE_POWER_OFF = 3


class Robot:
    """A connection to one UR controller. Use `ur3dq.robot.connect(...)`; close with `close()` or `with`."""

    _primary: PrimaryClient
    _dashboard: Dashboard
    _backend: StateBackend

    def __init__(self, host: str, backend: str = "rtde", model: str | None = None,
                 max_joint_travel: float = safety.DEFAULT_MAX_JOINT_TRAVEL, connect_timeout: float = 3.0,
                 heartbeat: bool = True, path_check: object = None) -> None:
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
        self._inputs: RTDEInputs | None = None
        # Every program that moves or frees the arm stops by itself when ur3dq dies (kill -9, a crash, a hang):
        # ur3dq.robot.heartbeat. Started with the first such program, so that reading, recording or a second ur3dq
        # watching the same arm never contend for its RTDE input registers.
        self._use_heartbeat = bool(heartbeat)
        self._path_check: tuple[Cell | None, Margins] | None = None
        self._dashboard_lock = threading.Lock()   # pause()/resume() may come from another thread
        self.link_delay = 0.0   # s, measured while connecting (_identify_model)
        if path_check is not None:
            self.require_path_check(*(() if path_check is True else (path_check,)))
        try:
            self._primary = self._open_primary()
            self._version: primary.VersionMessage = self._primary.version   # type: ignore[assignment]  # waited for
            self._dashboard = Dashboard(host)
            self.model_name = self._identify_model(model)
            kinematics = self._primary.kinematics
            if kinematics is None:   # _open_primary waits for it
                raise RobotConnectionError(f"{host} sent no Kinematics Info")
            self.model: URModel = calibrated_model(self.model_name, kinematics, self._controller_tcp_offset())
            self._backend = self._open_backend()
        except BaseException:
            self.close()
            raise

    # --- connection -------------------------------------------------------------------------------------------

    def __enter__(self) -> Robot:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Close every connection (idempotent). Never moves or stops the arm (no motion runs between calls)."""
        for name in ("_heartbeat", "_inputs", "_backend", "_dashboard", "_primary"):
            part = getattr(self, name, None)
            if part is not None:
                part.close()

    @property
    def controller_version(self) -> tuple[int, int, int, int]:
        """(major, minor, bugfix, build) of the controller software, from the primary version message."""
        return (self._version.major, self._version.minor, self._version.bugfix, self._version.build)

    @functools.cached_property
    def serial_number(self) -> str | None:
        """The controller's serial number (dashboard, PolyScope 5.6 and later), or None where it cannot tell."""
        if self.controller_version[:2] < SERIAL_NUMBER_SINCE:
            return None
        return self._dashboard.serial_number()

    def _open_primary(self) -> PrimaryClient:
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

    def _identify_model(self, requested: str | None) -> str:
        """The model name from the dashboard and Configuration Data; RobotError if they or `requested` disagree."""
        asked = time.monotonic()
        reply = self._dashboard.robot_model_reply()
        # The link's round trip: each motion's reports come that late, so its timeout is extended by it.
        self.link_delay = time.monotonic() - asked
        configuration = self._primary.configuration
        return identified_model(reply, self._version.major, None if configuration is None
                                else configuration.robot_type, requested)

    def _controller_tcp_offset(self) -> np.ndarray | None:
        """The controller's active TCP offset (UR pose vector, flange frame), or None before software 3.2."""
        cartesian = self._primary.cartesian
        return None if cartesian is None else cartesian.tcp_offset

    def _ensure_streams(self) -> None:
        """Reconnect dead state streams and heartbeat (exponential backoff, RECONNECT_TIMEOUT; a silenced heartbeat
        stays silent until the next program, _armed); ConnectionLostError if they stay down."""
        heartbeat = self._heartbeat
        beating = heartbeat is None or heartbeat.alive or heartbeat.silenced
        if self._primary.alive and self._backend.connected and beating:
            return
        last_error, first = None, time.monotonic()
        for delay in RECONNECT_DELAYS:
            try:
                if not self._primary.alive:
                    self._primary.close()
                    self._primary = self._open_primary()
                    self._backend.primary = self._primary
                if not self._backend.connected:
                    self._backend.reconnect()
                if heartbeat is not None and not heartbeat.alive and not heartbeat.silenced:
                    heartbeat.restart()
                return
            except RobotConnectionError as error:
                last_error = error
                if time.monotonic() + delay - first > RECONNECT_TIMEOUT:
                    break
                interrupts.poll(delay)
        raise ConnectionLostError(f"the state streams from {self.host} stay down after reconnecting: {last_error}")

    # --- reading ----------------------------------------------------------------------------------------------

    def state(self) -> RobotStatus:
        """The newest RobotStatus (joints, TCP, robot/safety mode, program running or paused, speeds, I/O, age)."""
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

    def tcp_pose(self) -> DualQuaternion:
        """The TCP pose the controller reports, as a DualQuaternion (base frame)."""
        return DualQuaternion.from_ur_pose(self.tcp_pose_vector())

    def tcp_pose_vector(self) -> np.ndarray:
        """The TCP pose the controller reports, as a UR pose vector [x, y, z, rx, ry, rz]."""
        return self._fresh_status().tcp_pose

    def _fresh_status(self) -> RobotStatus:
        """A status within the freeze timeout; a briefly stalled stream gets as long again, else ConnectionLostError."""
        limit = self._backend.freeze_timeout
        deadline = time.monotonic() + limit
        status = self.state()
        if status.age > limit:   # the usual reading is fresh: only a wait pays for deferring Ctrl-C
            with interrupts.at_polls():
                while status.age > limit:
                    if time.monotonic() > deadline:
                        raise ConnectionLostError(
                            f"the state stream from {self.host} is frozen: no fresh data for {status.age:.2f} s")
                    interrupts.poll(self._backend.poll_period)
                    status = self.state()
        return status

    # --- motion -----------------------------------------------------------------------------------------------

    def movej(self, q: Sequence[float] | np.ndarray, a: float | None = None, v: float | None = None,
              expected_pose: DualQuaternion | None = None) -> float:
        """Move to joint target `q` (rad) on a trapezoid with acceleration a (rad/s²) and speed v (rad/s).

        Blocks until there is evidence that this program ran and ended (its own end key message, or the state
        stream showing it running then not running), the arm rests at `q` and `state()` shows it ended; returns
        the wall time (s). `expected_pose` (DualQuaternion) marks a target from IK: the model's FK of `q` must reach it.

        Examples
        --------
        >>> import ur3dq.robot
        >>> with ur3dq.robot.connect("127.0.0.2") as robot:     # doctest: +SKIP
        ...     seconds = robot.movej([0.0, -1.2, 1.0, -1.4, -1.57, 0.0], v=0.5)
        """
        return self.movej_path([q], blend=0.0, a=a, v=v, expected_poses=None if expected_pose is None
                               else [expected_pose])

    def movej_path(self, targets: Sequence[Sequence[float] | np.ndarray], blend: float = 0.0,
                   a: float | None = None, v: float | None = None,
                   expected_poses: Sequence[DualQuaternion] | None = None) -> float:
        """Move through joint `targets` in one blended program (blend radius in metres); returns wall time (s)."""
        checked = [self._checked_target(q, f"targets[{index}]") for index, q in enumerate(targets)]
        if not checked:
            raise SafetyCheckError("targets must hold at least one joint vector")
        if expected_poses is not None:
            if len(expected_poses) != len(checked):
                raise SafetyCheckError(f"expected_poses has {len(expected_poses)} entries for {len(checked)} targets")
            for index, (q, pose) in enumerate(zip(checked, expected_poses, strict=True)):
                safety.check_fk_consistency(self.model, q, pose, name=f"targets[{index}]")
        if not (isinstance(blend, (int, float)) and math.isfinite(blend) and 0.0 <= blend <= MAX_BLEND_RADIUS):
            raise SafetyCheckError(f"blend must be a radius in metres within [0, {MAX_BLEND_RADIUS}], got {blend!r}")
        status = self._ready_status()
        a, v = self._clamped(status.joints, checked, a, v)
        previous = status.joints
        for index, q in enumerate(checked):
            safety.check_travel(previous, q, self.max_joint_travel, name=f"targets[{index}]")
            previous = q
        if len(checked) == 1 and motion.leading_travel(status.joints, checked[0]) < 1e-9:
            return 0.0  # already there: sending a program would only add a start/stop
        if self._path_check is not None:
            from ur3dq.pathcheck import PathPlan, PathSegment

            last = len(checked) - 1
            self._require_clear_path(PathPlan(status.joints, [
                PathSegment(f"targets[{index}]", "joint", target_joints=q, speed=v, acceleration=a,
                            blend=0.0 if index == last else float(blend)) for index, q in enumerate(checked)]))
        name = urscript.new_program_name("move")
        program = urscript.movej_program(name, checked, a, v, blend=float(blend))
        return self._send_watched(name, program, checked[-1], status,
                                  motion.path_duration(status.joints, checked, a, v))

    def movel(self, pose: PoseLike, a: float | None = None, v: float | None = None) -> float:
        """Move the TCP on a straight line to `pose` (DualQuaternion, or a UR pose vector [x, y, z, rx, ry, rz] of
        the TCP in the base frame) at speed v (m/s) and acceleration a (m/s²), clamped to the driver's TCP limits.

        The target is the IK solution nearest the arm's joints (FK-checked, inside the limits, within the travel
        bound), and the whole line is path-checked before anything is sent (reach, IK branch, singularities, joint
        speeds, and the cell when a path check is required); watched to its end like movej. Returns the wall time.

        Examples
        --------
        >>> lower = robot.tcp_pose_vector() - [0, 0, 0.05, 0, 0, 0]     # doctest: +SKIP
        >>> robot.movel(lower, v=0.05)                                   # doctest: +SKIP
        """
        return self._move_line("linear", pose, a, v)

    def movep(self, pose: PoseLike, a: float | None = None, v: float | None = None) -> float:
        """Like movel, as a process move (movep: the same straight line at a constant TCP speed)."""
        return self._move_line("process", pose, a, v)

    def jog(self, step: jog_steps.JogStep, speed: float) -> float:
        """One bounded jog step (jog_steps.JogStep) at `speed` (rad/s, m/s for X Y Z; capped at the jog's limits),
        checked and watched to its end: ur3dq.robot.jog.Jog.run (Jog.start: hold-to-move). Returns the wall time."""
        from ur3dq.robot.jog import Jog

        return Jog(self).run(step, speed)

    def _move_line(self, move: str, pose: PoseLike, a: float | None, v: float | None) -> float:
        """movel/movep to `pose` from the arm's joints, its whole line checked first."""
        from ur3dq.pathcheck import PathPlan, PathSegment

        pose = safety.pose_of(pose)
        status = self._ready_status()
        q = self._checked_target(self.model.ik(pose, status.joints), "target")
        safety.check_fk_consistency(self.model, q, pose, name="target")
        safety.check_travel(status.joints, q, self.max_joint_travel, name="target")
        a, v = safety.clamp_tcp_speed(a, v)
        if motion.leading_travel(status.joints, q) < 1e-9:
            return 0.0
        segment = PathSegment("target", move, target_joints=q, target_pose=pose.to_array(), speed=v, acceleration=a)
        self._require_clear_path(PathPlan(status.joints, [segment]), always=True)
        metres, radians = self.model.fk(status.joints).distance(pose)
        name = urscript.new_program_name("move")
        function = "movel" if move == "linear" else "movep"
        statement = urscript.move_statement(function, q, a, v, t=0 if function == "movel" else None)
        return self._send_watched(name, urscript.program(name, [statement]), q, status,
                                  motion.trapezoid_duration(max(metres, radians), a, v))

    def require_path_check(self, cell: Cell | None = None, margins: Margins | None = None) -> None:
        """Refuse from now on every motion whose whole path fails the path check.

        From now on every motion is refused (SafetyCheckError, nothing sent) unless the whole path it sweeps
        passes ur3dq.pathcheck.check_path in `cell` (a Cell, or None: self-collision, singularities, limits and
        speeds only) with `margins` (a Margins, or the defaults). movej/movej_path are sampled here (movel and movep
        always are); run_script needs the PathPlan of its program (`path=`), which ur3dq.program.run gives; a
        script without one is refused."""
        from ur3dq.pathcheck import Margins

        self._path_check = (cell, margins or Margins())

    @property
    def required_path_check(self) -> tuple[Cell | None, Margins] | None:
        """(cell, margins) every motion's path is checked in since require_path_check, or None."""
        return self._path_check

    def _require_clear_path(self, path: PathPlan | None, always: bool = False) -> None:
        """Check `path` (a PathPlan from the arm's joints) when a path check is required (or `always`, without a
        cell unless one is required); SafetyCheckError if it fails, or if there is no path to check."""
        if self._path_check is None and not always:
            return
        if path is None:
            raise SafetyCheckError("this Robot requires a path check before every motion, and this program has no "
                                   "path to check (pass run_script(..., path=PathPlan))")
        from ur3dq.pathcheck import Margins, check_path

        cell, margins = self._path_check or (None, Margins())
        result = check_path(self.model, path, cell, margins, keep_samples=False)
        if not result.ok:
            raise result.refusal()

    def movej_pose(self, pose: DualQuaternion, a: float | None = None, v: float | None = None) -> float:
        """Move to the TCP `pose` (DualQuaternion) through the IK solution closest to the current joints."""
        return self.movej(self.model.ik(pose, self.joints()), a=a, v=v, expected_pose=pose)

    def stop(self, a: float = SAFE_STOP_DECELERATION) -> None:
        """Decelerate the arm to rest with `stopj(a)` (rad/s², clamped to the model's limit)."""
        self._send_stop(a)

    def pause(self) -> str:
        """Pause the running program: the arm decelerates to rest on its path and `resume()` goes on from there.

        The controller's own pause (dashboard `pause`) where the program allows it; where the controller refuses
        or does not pause within 2 s, the arm is stopped with stopj instead (the program then ends). Returns
        "paused" once the arm rests, or "stopped". Safe to call from another thread while one watches a motion:
        the watch waits while the program is paused, its timeout standing still.

        Examples
        --------
        >>> worker = threading.Thread(target=robot.movej, args=(far,)); worker.start()    # doctest: +SKIP
        >>> robot.pause(); time.sleep(2); robot.resume(); worker.join()                  # doctest: +SKIP
        """
        with self._dashboard_lock:
            try:
                self._dashboard.pause()
            except RobotError:
                self._send_stop(SAFE_STOP_DECELERATION)
                return "stopped"
        def rests(status: RobotStatus) -> bool:   # paused and at rest, or the program ended meanwhile
            if status.program_paused:
                return float(np.max(np.abs(status.joint_speeds))) < REST_SPEED
            return not status.program_running

        if not self._wait_until(lambda: rests(self.state())):
            self._send_stop(SAFE_STOP_DECELERATION)
            return "stopped"
        return "paused"

    def resume(self) -> None:
        """Resume the paused program (dashboard `play`, sent only while a program is paused: to a stopped
        controller it would start the loaded program); RobotError if nothing is paused or it does not go on."""
        with self._dashboard_lock:
            if not self.state().program_paused:
                raise RobotError(f"resume: no program is paused on {self.host}")
            self._dashboard.play()
        if not self._wait_until(lambda: not self.state().program_paused):
            raise RobotError(f"resume: the program on {self.host} is still paused {PROGRAM_STATE_TIMEOUT:g} s "
                             "after `play`")

    def _checked_target(self, q: object, name: str) -> np.ndarray:
        """A joint target that is six finite values inside the model's joint limits."""
        return safety.check_joint_limits(q, self.model.joint_lower, self.model.joint_upper, name)

    def _clamped(self, q_start: np.ndarray, targets: Sequence[np.ndarray], a: float | None,
                 v: float | None) -> tuple[float, float]:
        """(a, v) defaulting to URScript's and lowered so no joint of any segment exceeds its limits."""
        a = URSCRIPT_DEFAULT_A if a is None else a
        v = URSCRIPT_DEFAULT_V if v is None else v
        max_acceleration, max_speed = effective_speed_limits(self.model, self._primary.configuration)
        previous = q_start
        for q in targets:
            a, v = safety.clamp_movej_speed(np.asarray(q) - previous, a, v, max_acceleration, max_speed)
            previous = q
        return a, v

    def _ready_status(self) -> RobotStatus:
        """The current status if the arm can move (running, no stop), else the specific error."""
        status = self._checked_status(self._fresh_status())
        if status.robot_mode != state.ROBOT_MODE_RUNNING:
            raise RobotError(f"the robot is in mode {status.robot_mode_name}, not RUNNING: "
                             f"power it on and release the brakes first {errors.POWER_ON_HINT}")
        return status

    def _checked_status(self, status: RobotStatus) -> RobotStatus:
        """`status` unchanged unless it shows an emergency or protective stop, or a frozen stream."""
        if status.emergency_stopped:
            raise EmergencyStopError(f"{self.host} is emergency-stopped (safety mode {status.safety_mode_name}); "
                                     "release the e-stop and power on again")
        if status.protective_stopped:
            raise ProtectiveStopError(f"{self.host} is in a protective stop; inspect the cause, then unlock it "
                                      f"{errors.UNLOCK_HINT}")
        if status.age > self._backend.freeze_timeout:
            raise ConnectionLostError(f"the state stream from {self.host} froze: no fresh valid data for "
                                      f"{status.age:.2f} s (silent, frozen, or sending what is not UR state)")
        if not self._primary.alive:
            raise ConnectionLostError(f"the primary interface of {self.host} closed: {self._primary.error}")
        return status

    def run_script(self, name: str, program: str, target: Sequence[float] | np.ndarray, duration: float,
                   on_message: Callable[[object], None] | None = None,
                   reached_end: Callable[[], bool] | None = None, path: PathPlan | None = None,
                   on_sent: Callable[[], None] | None = None) -> float:
        """Run a whole generated URScript program and watch it to its end.

        Run a whole generated `program` (URScript text of `def name(): ... end`, its targets checked by the
        caller) that ends with the arm at joint `target`, expected to take `duration` s at 100 %; each robot
        message is also given to `on_message` (which may raise to fail the run; after a failure it still gets the
        program's last messages), and when `reached_end` is given the run is only done once it returns True (the
        program's own report that it ran to its end: the arm resting at a target it started from proves nothing;
        a program that ended without it, stopped, is a ProgramError).
        `path` (a PathPlan of the program's moves) is checked when require_path_check is on. `on_sent()` is
        called once the program is handed to the controller (an error before it: nothing was sent). Returns the
        wall time (s). Used by ur3dq.program.runner."""
        status = self._ready_status()
        target = self._checked_target(target, "target")
        self._require_clear_path(path)
        return self._send_watched(urscript.check_identifier(name), program, target, status, duration, on_message,
                                  reached_end, on_sent)

    @interrupts.taken_at_polls
    def _send_watched(self, name: str, program: str, target: np.ndarray, status: RobotStatus,
                      duration: float, on_message: Callable[[object], None] | None = None,
                      reached_end: Callable[[], bool] | None = None,
                      on_sent: Callable[[], None] | None = None) -> float:
        """Send `program` (armed on the heartbeat) from `status`, expected to take `duration` s at 100 %, then watch
        it to its end; any failure stops the arm before the exception leaves."""
        timeout = motion.motion_timeout(duration, status.target_speed_fraction) + self.link_delay
        program = self._armed(program, name)
        motion.refuse_oversize(program, name)
        start_timeout = motion.program_start_timeout(program) + self.link_delay
        watcher = self._primary.watch()
        sent = time.monotonic()
        outcome = MotionWatch(name, target, running_at_send=status.program_running, heartbeat=self._heartbeat,
                              watchdog_period=1.0 / WATCHDOG_FREQUENCY, state_lag=self._backend.freeze_timeout,
                              reported_end=reached_end)
        try:
            self._backend.send_program(program)
            if on_sent is not None:
                on_sent()
            while True:
                for message in drain(watcher):
                    outcome.note_message(message)
                    if on_message is not None:
                        on_message(message)
                status = self._checked_status(self._backend.status())
                now = time.monotonic()
                if outcome.finished(status, now):
                    return now - sent
                outcome.check_progress(status, now - sent, now, start_timeout, timeout,
                                       f"plus the link's measured round trip of {self.link_delay:.3f} s")
                interrupts.poll(self._backend.poll_period)
        except BaseException as error:
            self._stop_after(error)
            if on_message is not None:
                late = isinstance(error, ConnectionLostError) and self._primary.alive
                last_reports(watcher, outcome, on_message, LATE_REPORTS_WAIT if late else AFTER_STOP_WAIT)
            raise
        finally:
            self._primary.unwatch(watcher)

    def _armed(self, program: str, name: str) -> str:
        """`program` armed on the heartbeat's watchdog (started now if it is not yet), or as it is without one;
        ConnectionLostError when the heartbeat is down: nothing would stop the program if ur3dq died."""
        if not self._use_heartbeat:   # then self._heartbeat stays None
            return program
        if self._heartbeat is None:
            self._heartbeat = Heartbeat(self._rtde_inputs())
        elif self._heartbeat.silenced:   # not while the program it was silenced for runs (Heartbeat.silence)
            self._wait_until(lambda: not self.state().program_running)
            self._heartbeat.restart()
        if not self._heartbeat.alive:
            raise ConnectionLostError(f"the heartbeat to {self.host} stopped: nothing would stop a program if "
                                      "ur3dq died, so none is sent (reconnect)")
        self._heartbeat.watch_gaps()
        return armed(program, name)

    def _stop_after(self, error: BaseException) -> None:
        """Stop the arm after a failed or interrupted motion, never slower than the controller's own stop: nothing
        after a safety stop (the controller stops the arm); after a lost connection, or the heartbeat's, the
        heartbeat silenced (the watchdog stops the program at the controller's stop: a stopj would replace it with a
        gentler one); else (a timeout, a program error, Ctrl-C) a best-effort stopj, a failure to send it noted."""
        if isinstance(error, (ProtectiveStopError, EmergencyStopError)):
            return
        if self._heartbeat is not None and (isinstance(error, ConnectionLostError) or not self._heartbeat.alive):
            self._heartbeat.silence()
            return
        try:
            self._send_stop(SAFE_STOP_DECELERATION)
        except RobotError as stop_error:
            add_separate_note(error, f"sending stopj after this error also failed: {stop_error}")

    def _send_stop(self, a: float) -> None:
        """Send a `stopj` program on the primary connection, or a fresh one if it is gone (never via urx: it blocks)."""
        a = min(float(a), float(np.min(self.model.max_joint_acceleration)))
        if not (math.isfinite(a) and a > 0):
            raise ValueError(f"a (deceleration) must be finite and > 0, got {a!r}")
        stop_program = urscript.program(urscript.new_program_name("stop"), [urscript.stopj_statement(a)])
        try:
            self._primary.send_script(stop_program)
        except ConnectionLostError:
            send_script(self.host, stop_program)

    # --- digital I/O ------------------------------------------------------------------------------------------

    def set_digital_out(self, pin: int, on: bool) -> None:
        """Switch standard digital output `pin` (0-7) on or off (through this client's RTDE inputs, so a running
        program is left alone); returns once the controller shows it. ValueError for a pin that does not exist."""
        self._set_output("standard", pin, on)

    def set_tool_digital_out(self, pin: int, on: bool) -> None:
        """Switch tool digital output `pin` (0-1, e.g. a gripper) on or off; returns once the controller shows it."""
        self._set_output("tool", pin, on)

    def set_configurable_digital_out(self, pin: int, on: bool) -> None:
        """Switch configurable digital output `pin` (0-7) on or off; returns once the controller shows it."""
        self._set_output("configurable", pin, on)

    def digital_in(self, pin: int, family: str = "standard") -> bool:
        """True while digital input `pin` of `family` ('standard' 0-7, 'configurable' 0-7, 'tool' 0-1) is on."""
        return bool(self.io_state().digital_in & io_bit(family, pin))

    def digital_out(self, pin: int, family: str = "standard") -> bool:
        """True while digital output `pin` of `family` ('standard', 'configurable', 'tool') is on."""
        return bool(self.io_state().digital_out & io_bit(family, pin))

    def outputs_on(self) -> list[tuple[str, int]]:
        """(family, pin) of every digital output that is on now, e.g. [('tool', 0)]."""
        return self.io_state().outputs_on()

    def _set_output(self, family: str, pin: int, on: bool) -> None:
        bit = io_bit(family, pin)
        if not isinstance(on, bool):
            raise ValueError(f"{family} digital output {pin}: on must be True or False, got {on!r}")
        self._rtde_inputs().set_digital_out(family, pin, on)
        if not self._wait_until(lambda: bool(self.io_state().digital_out & bit) == on, OUTPUT_TIMEOUT):
            raise RobotError(f"{self.host} does not show {family} digital output {pin} "
                             f"{'on' if on else 'off'} {OUTPUT_TIMEOUT:g} s after it was set")

    @property
    def inputs(self) -> RTDEInputs:
        """This client's RTDE inputs (opened on first use): outputs, speed slider, registers 18, 19, 21, 22."""
        return self._rtde_inputs()

    def _rtde_inputs(self) -> RTDEInputs:
        """This client's RTDE inputs (opened on first use; the heartbeat opens them with its own)."""
        if self._inputs is None:
            self._inputs = RTDEInputs(self.host)
        return self._inputs

    # --- power, safety, TCP, freedrive ------------------------------------------------------------------------

    def power_on(self) -> None:
        """Power the arm on and wait until it is IDLE (brakes still held); EmergencyStopError if e-stopped."""
        if self.state().emergency_stopped:
            raise EmergencyStopError(f"power on refused: {self.host} is emergency-stopped; release the e-stop first")
        self._dashboard.power_on()
        self._wait_for_mode({state.ROBOT_MODE_IDLE, state.ROBOT_MODE_RUNNING}, "power on")

    def power_off(self) -> None:
        """Power the arm off (brakes engage) and wait until it is POWER_OFF."""
        self._dashboard.power_off()
        self._wait_for_mode({ROBOT_MODE_POWER_OFF}, "power off")

    def brake_release(self) -> None:
        """Release the brakes and wait until RUNNING (done if it is); RobotError unless IDLE: the controller refuses."""
        mode = self.state().robot_mode
        if mode == state.ROBOT_MODE_RUNNING:
            return
        if mode != state.ROBOT_MODE_IDLE:
            raise RobotError(f"brake release refused: the robot is in mode {state.ROBOT_MODE_NAMES.get(mode, mode)}, "
                             "not IDLE; power it on first (`ur3dq robot power-on`)")
        self._dashboard.brake_release()
        self._wait_for_mode({state.ROBOT_MODE_RUNNING}, "brake release")

    def unlock_protective_stop(self) -> bool:
        """Unlock a protective stop (refused within 5 s of it): False if none, EmergencyStopError if e-stopped."""
        if not state.unlock_needed(self.state(), self.host):
            return False
        self._dashboard.unlock_protective_stop()
        if not self._wait_until(lambda: not self.state().protective_stopped, 2.0):
            raise ProtectiveStopError(f"{self.host} still reports a protective stop 2 s after the unlock")
        return True

    def set_tcp(self, tcp: PoseLike) -> None:
        """Set the controller's TCP offset (DualQuaternion or UR pose vector, flange frame); the model follows."""
        pose = tcp.to_ur_pose() if isinstance(tcp, DualQuaternion) else safety.check_pose_vector(tcp, "tcp")
        name = urscript.new_program_name("tcp")
        self._backend.send_program(urscript.program(name, [urscript.set_tcp_statement(pose)]))
        applied = self._primary.wait_for(lambda c: c.cartesian is not None and c.cartesian.tcp_offset is not None
                                         and np.allclose(c.cartesian.tcp_offset, pose, atol=1e-9), timeout=2.0)
        if not applied:
            raise ProgramError(f"the controller did not apply TCP offset {list(pose)} within 2 s")
        self.model = self.model.with_tcp(pose)

    def teach_mode(self, on: bool, hold_seconds: float = 3600.0) -> None:
        """Freedrive on (a program holding freedrive for `hold_seconds`, armed on the heartbeat like every motion:
        freedrive ends within 0.1 s if ur3dq dies) or off; waits for the controller."""
        name = urscript.new_program_name("teach")
        statements = urscript.freedrive_statements(hold_seconds) if on else urscript.end_freedrive_statements()
        self._ready_status()
        program = urscript.program(name, statements)
        self._backend.send_program(self._armed(program, name) if on else program)
        wanted = 1 if on else 0  # primary controlMode: 1 TEACH, 0 POSITION
        if not self._primary.wait_for(lambda c: c.control_mode == wanted, timeout=2.0):
            raise ProgramError(f"the controller did not switch freedrive {'on' if on else 'off'} within 2 s")

    def freedrive_active(self) -> bool:
        """Whether the controller is in freedrive now (primary controlMode TEACH): another program sent to the
        controller ends ur3dq's freedrive program, so a teach session checks this before each recording."""
        self._ensure_streams()
        asked = time.monotonic()  # a state message sent after the question, not one from before a change
        if not self._primary.wait_for(lambda c: c.last_state_time is not None and c.last_state_time > asked,
                                      timeout=self._backend.freeze_timeout):
            raise ConnectionLostError(f"the primary interface of {self.host} sent no robot state for "
                                      f"{self._backend.freeze_timeout} s")
        return self._primary.control_mode == 1

    @interrupts.taken_at_polls
    def _wait_until(self, reached: Callable[[], bool], timeout: float = PROGRAM_STATE_TIMEOUT) -> bool:
        """Poll until reached() (≤ `timeout` s; a Ctrl-C taken between polls); False if it never was."""
        deadline = time.monotonic() + timeout
        while not reached():
            if time.monotonic() > deadline:
                return False
            interrupts.poll(self._backend.poll_period)
        return True

    @interrupts.taken_at_polls
    def _wait_for_mode(self, modes: Collection[int], action: str) -> None:
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
            interrupts.poll(0.02)
