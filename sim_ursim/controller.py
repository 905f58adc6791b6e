"""The emulated UR controller: robot and safety modes, the control loop, commands, I/O and program hooks.

Contract 3 of docs/architecture.md: a façade over vocabulary.py (modes, status bits, `ControllerState`, refusals),
motion_queue.py, trajectories.py and modes.py. One thread runs the control loop (cycle_clock.py: one period per
cycle, none skipped); a cycle applies the inputs clients queued (`at_cycle_start`), advances the motion and
publishes an immutable snapshot that servers read (`state()`), wait for (`wait_cycle()`) or take in order
(`cycles_after()`). Every command and setter changes the controller's fields under its lock and then calls
`_commit()`, which republishes the present snapshot with the command-set fields recomputed (same cycle number), so
its effect is in `state()` as soon as it returns (I/O writes too, through IOState's change hook). Command-time
problems raise `CommandRefused` or ValueError; run-time problems end the Motion with `.error` set, and a motion
crossing a joint or joint-speed limit raises a protective stop (motion_queue.py). Modelling choices: docs/ursim.md.
"""
import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence

import numpy as np

from . import kinematics, trajectories
from .cycle_clock import CLOCKS, FAST, REAL_TIME, RECORD_SECONDS, CycleBoard, CycleClock, CycleInputs, FrameTurn
from .faults import Faults
from .io import IOState
from .messages import MessageBus
from .models import check_version_fits, default_version, parse_version, robot_model
from .modes import MAIN_VOLTAGE, ModeMachine
from .motion_queue import DEFAULT_STOP_CODE, Motion, MotionEntry, MotionFault, MotionQueue
from .vocabulary import (
    PROTECTIVE_STOP_DECELERATION,
    PROTECTIVE_STOP_UNLOCK_DELAY,
    STATUS_BIT_POWER_ON,
    STATUS_BIT_PROGRAM_RUNNING,
    STATUS_BIT_TEACH_BUTTON,
    CommandRefused,
    ControllerState,
    ControlMode,
    RobotMode,
    SafetyMode,
    frozen_array,
    replaced_state,
    runtime_state_of,
)

log = logging.getLogger("sim_ursim.controller")

Vector = Sequence[float] | np.ndarray  # 6 (or 3) numbers: joints [rad], a pose vector [m, rad], a wrench…

DEFAULT_MODE_DELAY = 0.3  # s from `power on` to IDLE and from `brake release` to RUNNING (real arms take seconds)
PAUSE_RAMP_TIME = 0.3  # s for speed_scaling to fall to 0 on pause (and rise back to 1 on resume)
JOINT_HISTORY_CYCLES = 1000  # measured joints kept for get_actual_joint_positions_history (2 s at 500 Hz)


class Controller:
    """Emulated UR controller (Contract 3). Create, `start()`, command, `shutdown()`."""

    def __init__(self, model="ur3", version=None, initial_q=None, calibration=None, serial_number=None,
                 frequency=None, mode_delay=DEFAULT_MODE_DELAY, unlock_delay=PROTECTIVE_STOP_UNLOCK_DELAY,
                 clock=REAL_TIME):
        """`clock`: REAL_TIME (a controller's), or FAST for test pipelines (see cycle_clock and docs/ursim.md)."""
        if clock not in CLOCKS:
            raise ValueError(f"clock must be one of {', '.join(CLOCKS)}, got {clock!r}")
        self.clock = clock
        self.model = robot_model(model, calibration=calibration, serial_number=serial_number)
        self.version = default_version(self.model) if version is None else parse_version(version)
        check_version_fits(self.model, self.version)
        control_frequency = 500.0 if self.version.is_e_series else 125.0
        if frequency is not None:
            if not 1.0 <= float(frequency) <= 1000.0:
                raise ValueError(f"frequency must be 1..1000 Hz, got {frequency!r}")
            control_frequency = float(frequency)
        self.period = 1.0 / control_frequency
        self.messages = MessageBus()
        self._modes = ModeMachine(mode_delay, unlock_delay, self.messages.publish)
        self.faults = Faults()
        self.io = IOState()
        self._arm = kinematics.ArmKinematics(self.model.dh, np.zeros(6))
        start_q = np.zeros(6) if initial_q is None else kinematics.checked_vector(initial_q, 6, "initial_q")
        self._check_within_limits(start_q, "initial_q", refuse=ValueError)

        self._lock = threading.RLock()
        self._thread = None
        self._stop_loop = threading.Event()
        self._cycle = 0
        self._sim_time = 0.0
        #: The time.monotonic() at which the last computed cycle was due: its time on the controller's own timeline
        #: (behind the host's clock while the host runs the loop late). Read by the RTDE input watchdogs.
        self.cycle_due = time.monotonic()
        self._cycle_inputs = CycleInputs()  # what clients' inputs queued for the start of the next cycle
        self.frame_turn = FrameTurn()  # the thread of a held speedj/speedl gets its turn before the next cycle

        self._q = frozen_array(start_q)
        self.joint_history = deque([self._q], JOINT_HISTORY_CYCLES)  # measured joints per control period, newest last
        self._qd = frozen_array(np.zeros(6))
        self._qdd = frozen_array(np.zeros(6))
        self._payload = 0.0
        self._payload_cog = frozen_array(np.zeros(3))
        self._payload_inertia = frozen_array(np.zeros(6))
        self._speed_slider = 1.0
        self._speed_scaling = 1.0  # trajectory-time scaling the controller applies itself (pause ramps it to 0)
        self._freedrive = False
        self._motions = MotionQueue(self.model)
        self._runner = None
        self._program_running = False
        self._program_paused = False
        self.programs_directory = None  # dashboard `load` resolves relative paths here (None: current directory)
        self.loaded_program = None  # path of the program `play` runs
        self.loaded_program_source = None
        self._changes = 0
        self._idle_signature: tuple[object, object, object] = (None, None, None)
        self._execution_time = 0.0
        self._script_control_line = 0
        self._external_force_torque = frozen_array(np.zeros(6))
        self._board = CycleBoard(self._snapshot(self._q, self.period), round(RECORD_SECONDS / self.period),
                                 _cycle_of, self._stop_loop.is_set)   # the last cycle's snapshot, and the recent ones
        self.io.on_change = lambda: self._commit(**self.io.snapshot_fields())

    # ---------------------------------------------------------------- lifecycle
    def start(self) -> None:
        """Start the control-loop thread (idempotent)."""
        with self._lock:
            if self._thread is not None:
                return
            self._stop_loop.clear()
            self._thread = threading.Thread(target=self._loop, name="sim_ursim-control", daemon=True)
            self._thread.start()
        log.info("controller %s (%s) started at %.0f Hz", self.model.name, self.version, 1 / self.period)

    def shutdown(self) -> None:
        """Stop the control loop, end every motion and the program; waits for the thread."""
        self._stop_loop.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(timeout=2.0)
        with self._lock:
            self._motions.clear("controller shut down")
            runner = self._runner
        if runner is not None and runner.is_running:
            runner.stop()
        self._board.wake()

    def step(self, cycles: int = 1) -> ControllerState:
        """Advance `cycles` cycles synchronously (loop not started: deterministic tests); the last snapshot."""
        if self._thread is not None:
            raise CommandRefused("step() drives a stopped controller; this one runs its own control loop")
        for _ in range(int(cycles)):
            self._cycle_once()
        return self._state

    @property
    def running(self) -> bool:
        """True while the control loop runs."""
        return self._thread is not None

    def _loop(self) -> None:
        clock = CycleClock(self.period)
        fast = self.clock == FAST
        while not self._stop_loop.is_set():
            if fast:   # no real time between two cycles: every script thread and stream takes its turn first
                self.frame_turn.await_threads()
                self._board.await_readers()
            # a late cycle starts at once: the missed ones follow back to back, none is skipped
            clock.wait(hurry=fast and self._has_work())
            if not fast:
                self.frame_turn.await_turn(self._motions.holding_owner)
            try:
                self._cycle_once(clock.due)
            except Exception as error:  # noqa: BLE001 - a bug must not kill the loop: halt the arm, say why, go on
                log.exception("control cycle failed; halting the arm")
                with self._lock:
                    self._halt(f"simulator internal error: {error!r}")

    def _has_work(self) -> bool:
        """True while something takes simulated time: a motion, a running program, a mode change under way."""
        return self._motions.busy or self._modes.transition_pending or (
            self._program_running and not self._program_paused)

    def at_cycle_start(self, action: Callable[[], None]) -> None:
        """Run `action` at the next cycle's start: a controller reads its inputs once per cycle, not as they come."""
        self._cycle_inputs.add(action)

    def _cycle_once(self, due: float | None = None) -> None:
        """One control cycle of one period, due at `due` (time.monotonic; None: now): apply the queued inputs,
        advance modes and motion, publish the snapshot."""
        dt = self.period
        began = time.perf_counter()
        with self._lock:
            self._cycle_inputs.apply()
            # The I/O as the program set it before this cycle's motion: a script thread whose move ends in this cycle
            # writes its next outputs in the next one, however soon its Python thread wakes.
            io_version, io_fields = self.io.versioned_snapshot()
            self._cycle += 1
            self._sim_time += dt
            if self._modes.advance(self._sim_time):
                self._touch()
            signature = (self._changes, io_version, self._q)
            if self._at_rest_and_unchanged(signature):
                state = self._next_idle_snapshot(began)
            else:
                previous_q, previous_qd = self._q, self._qd
                new_q = self._advance_motion(dt)
                qd = (new_q - previous_q) / dt
                self._qdd = frozen_array((qd - previous_qd) / dt)
                self._qd = frozen_array(qd)
                if not np.array_equal(new_q, previous_q):
                    self._q = frozen_array(new_q)
                self._execution_time = time.perf_counter() - began
                state = self._snapshot(previous_q, dt, io_fields)
            self._idle_signature = (self._changes, io_version, self._q)
            self.joint_history.append(self._q)
            self._board.publish(state, new_cycle=True)   # under the lock: a commit never overwrites a newer cycle
            self.cycle_due = time.monotonic() if due is None else due

    def _at_rest_and_unchanged(self, signature):
        """True when nothing moves or changed since the last snapshot, so it can be reused with a new cycle number."""
        last = self._state
        return (not self._motions.busy and signature[0] == self._idle_signature[0]
                and signature[1] == self._idle_signature[1] and signature[2] is self._idle_signature[2]
                and not np.any(last.actual_qd) and not np.any(last.target_qdd) and last.actual_q is self._q)

    def _next_idle_snapshot(self, began):
        """The last snapshot with this cycle's number and times: an idle cycle costs almost nothing."""
        self._execution_time = time.perf_counter() - began
        return replaced_state(self._state, cycle=self._cycle, timestamp=self._sim_time,
                              execution_time=self._execution_time)

    @property
    def _state(self) -> ControllerState:
        return self._board.latest

    def _commit(self, **fields) -> None:
        """THE way a command or setter publishes its effect: the present snapshot with `fields` (recomputed from the
        controller's own fields by the caller) replaced, same cycle number, visible in state() at once. Noted as
        a change, so the next control cycle computes a full snapshot again."""
        with self._lock:
            self._touch()
            self._board.publish(replaced_state(self._state, **fields), new_cycle=False)

    def _touch(self):
        """Note a change the next control cycle must recompute (its idle shortcut reuses an unchanged snapshot)."""
        self._changes += 1

    # ---------------------------------------------------------------- snapshots
    def state(self) -> ControllerState:
        """The snapshot of the last control cycle."""
        return self._state

    def wait_cycle(self, after_cycle: int, timeout: float | None = None) -> ControllerState:
        """Block until a cycle newer than `after_cycle` is published (or timeout); returns the latest snapshot."""
        return self._board.wait_newer(after_cycle, timeout)

    def cycles_after(self, after_cycle: int, timeout: float | None = None,
                     reader: str | None = None) -> list[ControllerState]:
        """Every cycle's snapshot since `after_cycle` (RECORD_SECONDS kept), oldest first; [] after `timeout`.
        `reader`: the stream's name, for a fast clock to wait for it (`forget_reader` when it stops)."""
        return self._board.newer(after_cycle, timeout, reader)

    def forget_reader(self, reader: str) -> None:
        """The stream `reader` reads no more cycles."""
        self._board.forget_reader(reader)

    def await_published(self) -> None:
        """Return once the cycle being computed, if any, is published (a motion that ended in it shows in state())."""
        with self._lock:
            pass

    def _snapshot(self, previous_q, dt, io_fields=None):
        """A full snapshot of the present cycle (I/O fields read now unless given); TCP and elbow speeds by finite
        difference from previous_q over dt."""
        _, frames, _, _ = self._arm.poses_at(self._q)
        tcp_speed, elbow_velocity = self._arm.speeds_between(previous_q, self._q, dt)
        zeros6 = _ZEROS6
        return ControllerState(
            **self._status_fields(), **self._settings_fields(),
            **(self.io.snapshot_fields() if io_fields is None else io_fields),
            cycle=self._cycle, timestamp=self._sim_time,
            target_q=self._q, target_qd=self._qd, target_qdd=self._qdd, actual_q=self._q, actual_qd=self._qd,
            actual_current=zeros6, target_current=zeros6, target_moment=zeros6, joint_control_output=zeros6,
            actual_tcp_speed=frozen_array(tcp_speed), target_tcp_speed=frozen_array(tcp_speed),
            elbow_position=frozen_array(frames[2][:3, 3]), elbow_velocity=frozen_array(elbow_velocity),
            actual_main_voltage=MAIN_VOLTAGE, actual_robot_current=0.0, actual_momentum=0.0,
            speed_scaling=self._speed_scaling, execution_time=self._execution_time,
        )

    def _status_fields(self):
        """Snapshot fields that commands change between cycles: modes, status bits, program, slider, payload."""
        running = self._program_running and not self._program_paused
        status_bits = (STATUS_BIT_POWER_ON if self._modes.powered else 0) | (
            STATUS_BIT_PROGRAM_RUNNING if running else 0) | (STATUS_BIT_TEACH_BUTTON if self._freedrive else 0)
        return dict(
            **self._modes.snapshot_fields(), robot_status_bits=status_bits,
            control_mode=ControlMode.TEACH if self._freedrive else ControlMode.POSITION,
            runtime_state=runtime_state_of(self._program_running, self._program_paused),
            program_running=self._program_running, program_paused=self._program_paused,
            freedrive=self._freedrive, motion_active=self._motions.busy, target_speed_fraction=self._speed_slider,
            payload=self._payload, payload_cog=self._payload_cog, payload_inertia=self._payload_inertia,
        )

    def _settings_fields(self):
        """Snapshot fields that follow the TCP offset and the fed-in wrench (the TCP poses at the present joints)."""
        _, _, tcp_pose, flange_pose = self._arm.poses_at(self._q)
        return dict(
            tcp_offset=self._arm.tcp_offset, actual_tcp_pose=tcp_pose, target_tcp_pose=tcp_pose,
            flange_pose=flange_pose,
            actual_tcp_force=self._external_force_torque, external_force_torque=self._external_force_torque,
            script_control_line=self._script_control_line,
        )

    def _commit_status(self):
        """Commit a command that changed modes, status, program state, slider or payload."""
        self._commit(**self._status_fields())

    # ---------------------------------------------------------------- power, brakes, safety (modes.py)
    def power_on(self) -> None:
        """POWER_OFF → POWER_ON → (after mode_delay) IDLE. Refused during an emergency stop."""
        with self._lock:
            self._modes.power_on(self._sim_time)
            self._commit_status()

    def brake_release(self) -> None:
        """Release the brakes: → RUNNING after mode_delay (powering on first from POWER_OFF, as the controller does)."""
        with self._lock:
            self._modes.brake_release(self._sim_time)
            self._commit_status()

    def power_off(self) -> None:
        """Cut power at once: motions and the program stop, brakes engage, robot mode POWER_OFF."""
        with self._lock:
            self._halt("robot powered off")
            self._freedrive = False
            self._modes.power_off()
            self._commit_status()
        self._stop_program_for("robot powered off")

    def power_up(self, timeout: float = 5.0) -> ControllerState:
        """Convenience for tests and demos: power on, release brakes and wait until RUNNING; TimeoutError if not."""
        self.power_on()
        self.brake_release()
        deadline = time.monotonic() + timeout
        while self._state.robot_mode != RobotMode.RUNNING:
            if time.monotonic() > deadline:
                raise TimeoutError(f"robot not RUNNING after {timeout} s (mode {self._state.robot_mode})")
            self.wait_cycle(self._state.cycle, timeout=0.1)
        return self._state

    def protective_stop(self, reason: str = "protective stop requested") -> None:
        """Enter PROTECTIVE_STOP: decelerate the arm, fail the motions, stop the program. Unlock ≥ 5 s later."""
        with self._lock:
            if self._modes.safety_mode != SafetyMode.NORMAL:
                return
            self._protective_stop_locked(reason)
            self._commit_status()
        self._stop_program_for(f"protective stop: {reason}")

    def _protective_stop_locked(self, reason, code=DEFAULT_STOP_CODE):
        """Protective stop from the control loop or a locked command (program stop left to the caller), C<code>."""
        self._modes.enter_protective_stop(reason, code)
        self._touch()
        self._motions.stop(self._qd, PROTECTIVE_STOP_DECELERATION, "stop", error=f"protective stop: {reason}")

    def unlock_protective_stop(self, enforce_delay: bool = True) -> None:
        """Back to NORMAL; UnlockTooEarly within 5 s of the stop unless not `enforce_delay`; CommandRefused if none."""
        with self._lock:
            self._modes.unlock_protective_stop(enforce_delay)
            self._commit_status()

    def emergency_stop(self) -> None:
        """Robot emergency stop: the arm halts at once, power is cut, the program stops. Release, then power on."""
        with self._lock:
            if not self._modes.emergency_stop():
                return
            self._halt("emergency stop")
            self._freedrive = False
            self._commit_status()
        self._stop_program_for("emergency stop")

    def release_emergency_stop(self) -> None:
        """Release the emergency-stop button: safety NORMAL again, the arm stays powered off."""
        with self._lock:
            if self._modes.release_emergency_stop():
                self._commit_status()

    # ---------------------------------------------------------------- motion commands
    def movej(self, q: Vector, a: float = 1.4, v: float = 1.05, t: float = 0.0, r: float = 0.0) -> Motion:
        """Joint move on synchronised trapezoids (leading axis a [rad/s²], v [rad/s]; t [s] overrides)."""
        q = kinematics.checked_vector(q, 6, "q")
        a, v, t, r = self._checked_move_parameters(a, v, t, r)
        self._check_within_limits(q, "movej target")
        with self._lock:
            self._require_motion_allowed("movej")
            motion = Motion("movej", r)
            tcp_matrix = self._arm.with_fixed_tcp().tcp_matrix   # its blend zone is measured at this TCP
            self._enqueue(MotionEntry(None, motion, True, target_q=q, tcp_matrix=tcp_matrix),
                          lambda start: trajectories.plan_joint_move(
                              start, q, a, v, t, self.model.max_joint_speed, self.model.max_joint_acceleration))
            return motion

    def movel(self, pose: Vector, a: float = 1.2, v: float = 0.25, t: float = 0.0, r: float = 0.0) -> Motion:
        """Straight-line TCP move to `pose` (a [m/s²], v [m/s]; t [s] overrides); IK from the joints before it."""
        pose = kinematics.checked_vector(pose, 6, "pose")
        a, v, t, r = self._checked_move_parameters(a, v, t, r)
        with self._lock:
            self._require_motion_allowed("movel")
            start_q = self._motions.end_q(self._q)
            q_end = self._ik_checked(pose, start_q)
            motion = Motion("movel", r)
            # The line is the TCP's at this command, to the end of the move: a set_tcp while it still runs
            # (blended into the next move) applies to the moves after it.
            arm = self._arm.with_fixed_tcp()
            self._enqueue(MotionEntry(None, motion, True, target_q=q_end, tcp_matrix=arm.tcp_matrix),
                          lambda start: trajectories.plan_linear_move(
                              arm.tcp_matrix(start), kinematics.pose_to_matrix(pose), start, q_end, a, v, t,
                              self.model.max_joint_speed, arm.solve_planned))
            return motion

    def speedj(self, qd: Vector, a: float = 1.4, t: float = 0.0, hold_owner: object = None) -> Motion:
        """Joint speeds qd [rad/s] reached at acceleration a; after t s (t > 0) decelerate to rest, or with
        `hold_owner` (a script thread) hold there until its next command: the Motion ends after t (see JointSpeed)."""
        qd = kinematics.checked_vector(qd, 6, "qd")
        a = kinematics.checked_positive(a, "a")
        t = kinematics.checked_non_negative(t, "t")
        if np.any(np.abs(qd) > self.model.max_joint_speed * 1.0000001):
            raise ValueError(f"qd {np.round(qd, 4).tolist()} exceeds the joint speed limits "
                             f"{np.round(self.model.max_joint_speed, 4).tolist()} rad/s")
        with self._lock:
            self._require_motion_allowed("speedj")
            start = self._motions.speed_ramp_start("speedj", self._qd)
            return self._replace_motion(trajectories.JointSpeed(start, qd, a, t, hold_owner), "speedj", True)

    def release_speed_hold(self, owner: object) -> None:
        """`owner`'s held speedj or speedl gets no next command: it ramps to rest."""
        with self._lock:
            self._motions.release_hold(owner)

    def speedl(self, xd: Vector, a: float = 1.2, t: float = 0.0, hold_owner: object = None) -> Motion:
        """TCP twist xd [vx vy vz wx wy wz] (base frame, m/s, rad/s) reached at acceleration a; after t s stop, or
        with `hold_owner` hold as speedj does."""
        xd = kinematics.checked_vector(xd, 6, "xd")
        a = kinematics.checked_positive(a, "a")
        t = kinematics.checked_non_negative(t, "t")
        with self._lock:
            self._require_motion_allowed("speedl")
            start = self._motions.speed_ramp_start("speedl", self._state.actual_tcp_speed)
            arm = self._arm
            segment = trajectories.CartesianSpeed(start, xd, a, t, arm.tcp_matrix, arm.solve_planned, hold_owner)
            return self._replace_motion(segment, "speedl", True)

    def servoj(self, q: Vector, a: float = 0.0, v: float = 0.0, t: float = 0.008, lookahead_time: float = 0.1,
               gain: float = 300) -> Motion:
        """Servo towards q, arriving t s from now.

        a and v are accepted; lookahead_time (0.03..0.2) and gain (100..2000) are checked.
        """
        q = kinematics.checked_vector(q, 6, "q")
        t = kinematics.checked_positive(t, "t")
        if not 0.03 <= float(lookahead_time) <= 0.2:
            raise ValueError(f"lookahead_time must be 0.03..0.2 s, got {lookahead_time!r}")
        if not 100 <= float(gain) <= 2000:
            raise ValueError(f"gain must be 100..2000, got {gain!r}")
        self._check_within_limits(q, "servoj target")
        with self._lock:
            self._require_motion_allowed("servoj")
            return self._replace_motion(trajectories.ServoTarget(q, t, self.model.max_joint_speed), "servoj", False)

    def stopj(self, a: float = 2.0) -> Motion:
        """Decelerate every joint to rest at a [rad/s²] (path kept); the current and queued motions end."""
        a = kinematics.checked_positive(a, "a")
        with self._lock:
            return self._stop_with(a, "stopj")

    def stopl(self, a: float = 1.2) -> Motion:
        """Decelerate the TCP to rest at a [m/s²] (joint-space deceleration taking the TCP's stopping time)."""
        a = kinematics.checked_positive(a, "a")
        with self._lock:
            tcp_speed = float(np.linalg.norm(self._state.actual_tcp_speed[:3]))
            joint_speed = float(np.max(np.abs(self._qd)))
            # Same stopping time as the TCP would need: T = |v_tcp| / a, applied to the joints.
            joint_deceleration = joint_speed * a / tcp_speed if tcp_speed > 1e-9 else PROTECTIVE_STOP_DECELERATION
            return self._stop_with(joint_deceleration, "stopl")

    def move_joints_by_hand(self, q: Vector) -> None:
        """Freedrive: the operator pushes the arm to q (must be within limits; freedrive must be on)."""
        q = kinematics.checked_vector(q, 6, "q")
        self._check_within_limits(q, "hand-guided joints")
        with self._lock:
            if not self._freedrive:
                raise CommandRefused("the arm can be moved by hand only in freedrive (teach) mode")
            self._q = frozen_array(q)
            self._commit(**vars(self._snapshot(self._q, self.period)))

    def set_freedrive(self, on: bool) -> None:
        """Freedrive / teach mode on or off (on needs RUNNING + NORMAL; motions are refused while it is on)."""
        with self._lock:
            if on:
                self._modes.require_running_normal("freedrive")
                self._halt("freedrive started")
            if bool(on) != self._freedrive:
                log.info("freedrive %s", "on" if on else "off")
            self._freedrive = bool(on)
            self._commit_status()

    # ---------------------------------------------------------------- settings
    def set_speed_slider(self, fraction: float) -> None:
        """Speed slider 0..1: planned trajectories advance by dt × fraction."""
        fraction = float(fraction)
        if not 0.0 <= fraction <= 1.0 or math.isnan(fraction):
            raise ValueError(f"speed slider fraction must be 0..1, got {fraction!r}")
        with self._lock:
            self._speed_slider = fraction
            self._commit_status()

    def set_tcp(self, pose: Vector) -> None:
        """TCP offset as a UR pose vector in the flange frame."""
        pose = frozen_array(kinematics.checked_vector(pose, 6, "tcp pose"))
        with self._lock:
            self._arm.tcp_offset = pose
            self._commit(**self._settings_fields())

    @property
    def tcp_offset(self) -> np.ndarray:
        """The active TCP offset (pose vector in the flange frame), as set by the last set_tcp."""
        return self._arm.tcp_offset

    @property
    def payload(self) -> tuple[float, np.ndarray, np.ndarray]:
        """(mass [kg], centre of gravity [m] (3,), inertia (6,)) as set by the last set_payload."""
        with self._lock:
            return self._payload, self._payload_cog, self._payload_inertia

    def set_payload(self, mass: float, cog: Vector | None = None, inertia: Vector | None = None) -> None:
        """Payload mass [kg] (≥ 0), centre of gravity [m] in the flange frame, inertia [Ixx Iyy Izz Ixy Ixz Iyz]."""
        mass = kinematics.checked_non_negative(mass, "mass")
        with self._lock:
            self._payload = mass
            if cog is not None:
                self._payload_cog = frozen_array(kinematics.checked_vector(cog, 3, "cog"))
            if inertia is not None:
                self._payload_inertia = frozen_array(kinematics.checked_vector(inertia, 6, "inertia"))
            self._commit_status()

    def set_external_force_torque(self, wrench: Vector) -> None:
        """Wrench [Fx Fy Fz Tx Ty Tz] an RTDE client feeds in (external_force_torque); reported as actual_TCP_force."""
        wrench = frozen_array(kinematics.checked_vector(wrench, 6, "external_force_torque"))
        with self._lock:
            self._external_force_torque = wrench
            self._commit(**self._settings_fields())

    def set_script_control_line(self, line: int) -> None:
        """The URScript line being executed (RTDE script_control_line); set by the runner."""
        line = max(0, int(line))
        with self._lock:
            if line != self._script_control_line:  # a thread waiting again at the same line changes nothing
                self._script_control_line = line
                self._commit(script_control_line=line)

    # ---------------------------------------------------------------- kinematics helpers
    def fk(self, q: Vector) -> np.ndarray:
        """TCP pose vector (base frame, current TCP offset) at joints q."""
        return self._arm.tcp_pose(kinematics.checked_vector(q, 6, "q"))

    def ik(self, pose: Vector, q_near: Vector | None = None) -> np.ndarray:
        """Joints reaching TCP `pose` nearest to q_near (default: the current joints); kinematics.IKError if none."""
        pose = kinematics.checked_vector(pose, 6, "pose")
        start = self._q if q_near is None else kinematics.checked_vector(q_near, 6, "q_near")
        return self._arm.solve_ik(pose, start)

    def _ik_checked(self, pose, q_near):
        try:
            q = self._arm.solve_planned(pose, q_near)
        except kinematics.IKError as error:
            raise CommandRefused(str(error)) from None
        self._check_within_limits(q, "IK solution")
        return q

    # ---------------------------------------------------------------- program hooks
    def attach_program_runner(self, runner) -> None:
        """The URScript runner: has submit(source, origin), stop(), pause(), resume(), is_running."""
        self._runner = runner

    @property
    def program_runner(self):
        """The attached runner (None until attach_program_runner)."""
        return self._runner

    def set_program_state(self, running: bool, paused: bool = False) -> None:
        """Called by the runner when a program starts / pauses / resumes / ends: runtime_state and status bits."""
        with self._lock:
            if (bool(running), bool(paused)) != (self._program_running, self._program_paused):
                log.info("program %s", "paused" if running and paused else "running" if running else "stopped")
            self._program_running = bool(running)
            self._program_paused = bool(running) and bool(paused)
            if not running:
                self._speed_scaling = 1.0  # a stopped program leaves no pause ramp behind
            self._commit_status()

    def run_program(self, source: str, origin: str = "dashboard") -> bool:
        """Hand URScript `source` to the runner; its answer (False: refused) is returned. CommandRefused if none."""
        if self._runner is None:
            raise CommandRefused("no URScript runner attached")
        return self._runner.submit(source, origin)

    def stop_program(self) -> None:
        """Stop the running program and the arm (stopj with the protective deceleration)."""
        if self._runner is not None:
            self._runner.stop()
        with self._lock:
            self._stop_with(PROTECTIVE_STOP_DECELERATION, "program stopped")
        self.set_program_state(False)

    def pause_program(self) -> None:
        """Pause the running program (the runner decides how its motion pauses)."""
        if self._runner is not None:
            self._runner.pause()
        self.set_program_state(self._program_running, True)

    def resume_program(self) -> None:
        """Resume a paused program."""
        if self._runner is not None:
            self._runner.resume()
        self.set_program_state(self._program_running, False)

    def _stop_program_for(self, reason):
        """A safety event or power-off ends the program through the runner (outside the controller lock)."""
        runner = self._runner
        if runner is not None and (runner.is_running or self._program_running):
            log.info("stopping the program: %s", reason)
            runner.stop()
        self.set_program_state(False)

    # ---------------------------------------------------------------- motion engine internals
    def _require_motion_allowed(self, what):
        self._modes.require_running_normal(what)
        if self._freedrive:
            raise CommandRefused(f"{what} refused: freedrive (teach) mode is on")

    def _checked_move_parameters(self, a, v, t, r):
        return (kinematics.checked_positive(a, "a"), kinematics.checked_positive(v, "v"),
                kinematics.checked_non_negative(t, "t"), kinematics.checked_non_negative(r, "r"))

    def _check_within_limits(self, q, what, refuse=None):
        outside = np.nonzero((q < self.model.joint_lower) | (q > self.model.joint_upper))[0]
        if outside.size:
            i = int(outside[0])
            error = refuse or CommandRefused
            raise error(f"{what}: joint {i} at {q[i]:.4f} rad is outside its limits "
                        f"[{self.model.joint_lower[i]:.4f}, {self.model.joint_upper[i]:.4f}]")

    def _enqueue(self, entry, plan):
        """Queue a planned move (`plan(start_q)` builds its segment when it starts) and commit."""
        self._motions.enqueue(entry, plan, self._q, self._qd)
        self._commit_status()

    def _replace_motion(self, segment, kind, follows_slider):
        """A streaming command (speedj, speedl, servoj) takes over at once; commit and return its Motion."""
        motion = self._motions.replace(segment, kind, follows_slider)
        self._commit_status()
        return motion

    def _stop_with(self, deceleration, kind):
        """Replace every motion by a deceleration to rest; commit and return the stop's Motion."""
        motion = self._motions.stop(self._qd, deceleration, kind)
        self._commit_status()
        return motion

    def _halt(self, error):
        """Immediate halt (e-stop, power off): speed zero now, every motion fails."""
        self._motions.clear(error)
        self._qd = frozen_array(np.zeros(6))

    def _advance_motion(self, dt):
        """Joints after one cycle of the active motion (protective stop on limit, speed or IK failures)."""
        q = np.array(self._q)
        if self._freedrive or self._motions.active is None:
            return q
        planned_dt = dt * self._speed_slider * self._ramp_speed_scaling(dt)
        try:
            return self._motions.advance(q, dt, planned_dt)
        except MotionFault as fault:
            self._protective_stop_locked(fault.reason, fault.code)
            self._request_program_stop(fault.program_reason)
            return q

    def _ramp_speed_scaling(self, dt):
        """speed_scaling after dt: towards 0 while the program is paused, towards 1 otherwise."""
        goal = 0.0 if self._program_paused else 1.0
        self._speed_scaling = trajectories.step_towards(self._speed_scaling, goal, dt / PAUSE_RAMP_TIME)
        return self._speed_scaling

    def _request_program_stop(self, reason):
        """From inside the control loop: stop the program on another thread so the loop never waits for it."""
        threading.Thread(target=self._stop_program_for, args=(reason,), name="sim_ursim-program-stop",
                         daemon=True).start()


_ZEROS6 = frozen_array(np.zeros(6))


def _cycle_of(state: ControllerState) -> int:
    return state.cycle
