"""The emulated UR controller: robot and safety modes, the control loop, the motion engine, I/O and program hooks.

Contract 3 of docs/architecture.md. One thread runs the control loop on a steady clock (time.monotonic, absolute
deadlines); each cycle advances the active motion and publishes an immutable `ControllerState` snapshot that
servers read (`state()`) or wait for (`wait_cycle()`).

Modelling choices (documented where the real controller's rule is not public):
- Command-time problems raise: `CommandRefused` (not RUNNING/NORMAL, freedrive on, target outside joint limits,
  unreachable pose) or ValueError (malformed arguments). Run-time problems end the Motion with `.error` set.
- Joint-limit protection: a movej/movel/servoj target outside the limits is refused before moving; a motion that
  would cross a limit while running (speedj, speedl, a movel through the limit) raises a protective stop.
- movel / speedl joint speeds above the model's limits (a singularity on the way) raise a protective stop.
- Blending (r > 0): the Motion counts as done once the TCP is within r of its target; the next move then starts
  and is superposed on the rest of the current one in joint space (q = q_rest + q_next − q_next_start), so speed
  stays continuous and the arm ends exactly on the next target. The blend path is not the controller's.
- Speed slider: planned trajectories (movej, movel) and speed commands advance by dt × slider × speed_scaling;
  stops use real time. Pausing the program ramps speed_scaling to 0 in PAUSE_RAMP_TIME (the arm halts on its path)
  and resuming ramps it back to 1, so a paused move continues where it stopped.
- Protective stop: decelerate at `PROTECTIVE_STOP_DECELERATION`; emergency stop: the arm halts at once.
"""
import dataclasses
import logging
import math
import threading
import time

import numpy as np

from . import kinematics, motion
from .faults import Faults
from .io import IOState
from .messages import ErrorCodeMessage, MessageBus, SafetyModeMessage
from .models import check_version_fits, default_version, parse_version, robot_model

log = logging.getLogger("sim_ursim.controller")


class RobotMode:
    """robot_mode enumeration (protocols.md §1.6)."""

    NO_CONTROLLER, DISCONNECTED, CONFIRM_SAFETY, BOOTING, POWER_OFF, POWER_ON, IDLE, BACKDRIVE, RUNNING = range(-1, 8)
    NAMES = {-1: "NO_CONTROLLER", 0: "DISCONNECTED", 1: "CONFIRM_SAFETY", 2: "BOOTING", 3: "POWER_OFF",
             4: "POWER_ON", 5: "IDLE", 6: "BACKDRIVE", 7: "RUNNING", 8: "UPDATING_FIRMWARE"}


class SafetyMode:
    """safety_mode / safety_status enumeration (protocols.md §1.6)."""

    NORMAL, REDUCED, PROTECTIVE_STOP, RECOVERY, SAFEGUARD_STOP = 1, 2, 3, 4, 5
    SYSTEM_EMERGENCY_STOP, ROBOT_EMERGENCY_STOP, VIOLATION, FAULT = 6, 7, 8, 9
    NAMES = {1: "NORMAL", 2: "REDUCED", 3: "PROTECTIVE_STOP", 4: "RECOVERY", 5: "SAFEGUARD_STOP",
             6: "SYSTEM_EMERGENCY_STOP", 7: "ROBOT_EMERGENCY_STOP", 8: "VIOLATION", 9: "FAULT",
             10: "VALIDATE_JOINT_ID", 11: "UNDEFINED_SAFETY_MODE"}


class RuntimeState:
    """runtime_state enumeration (protocols.md §1.6)."""

    STOPPING, STOPPED, PLAYING, PAUSING, PAUSED, RESUMING = range(6)


class JointMode:
    """joint_mode enumeration (protocols.md §3.5)."""

    BACKDRIVE, POWER_OFF, MOTOR_INITIALISATION, BOOTING, RUNNING, IDLE = 238, 239, 246, 247, 253, 255


class ControlMode:
    """Primary RobotModeData controlMode."""

    POSITION, TEACH, FORCE, TORQUE = range(4)


# safety_status_bits (protocols.md §1.4)
SAFETY_BIT_NORMAL, SAFETY_BIT_REDUCED, SAFETY_BIT_PROTECTIVE_STOPPED = 1 << 0, 1 << 1, 1 << 2
SAFETY_BIT_ROBOT_EMERGENCY_STOPPED, SAFETY_BIT_EMERGENCY_STOPPED, SAFETY_BIT_STOPPED_DUE_TO_SAFETY = (
    1 << 6, 1 << 7, 1 << 10)
# robot_status_bits
STATUS_BIT_POWER_ON, STATUS_BIT_PROGRAM_RUNNING, STATUS_BIT_TEACH_BUTTON = 1 << 0, 1 << 1, 1 << 2

PROTECTIVE_STOP_UNLOCK_DELAY = 5.0  # s: "Cannot unlock protective stop until 5s after occurrence"
PROTECTIVE_STOP_DECELERATION = 10.0  # rad/s² on every joint: a controlled (category 2) stop
DEFAULT_MODE_DELAY = 0.3  # s from `power on` to IDLE and from `brake release` to RUNNING (real arms take seconds)
PAUSE_RAMP_TIME = 0.3  # s for speed_scaling to fall to 0 on pause (and rise back to 1 on resume)
JOINT_SPEED_TOLERANCE = 1.05  # movel/speedl may exceed a joint's max speed by 5 % before the protective stop
AMBIENT_TEMPERATURE = 25.0
POWERED_TEMPERATURE = 32.0
MAIN_VOLTAGE = 48.0


class CommandRefused(RuntimeError):
    """The controller refused a command in its present state (the message says why)."""


class UnlockTooEarly(CommandRefused):
    """`unlock protective stop` came less than 5 s after the stop."""


def safety_status_bits(safety_mode):
    """safety_status_bits word for a safety mode (normal, protective stop, robot e-stop; others map to their bit)."""
    if safety_mode == SafetyMode.NORMAL:
        return SAFETY_BIT_NORMAL
    if safety_mode == SafetyMode.PROTECTIVE_STOP:
        return SAFETY_BIT_PROTECTIVE_STOPPED | SAFETY_BIT_STOPPED_DUE_TO_SAFETY
    if safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
        return SAFETY_BIT_ROBOT_EMERGENCY_STOPPED | SAFETY_BIT_EMERGENCY_STOPPED | SAFETY_BIT_STOPPED_DUE_TO_SAFETY
    return (1 << (safety_mode - 1)) | SAFETY_BIT_STOPPED_DUE_TO_SAFETY


def runtime_state_of(running, paused):
    """runtime_state for a program that is (not) running and (not) paused."""
    if not running:
        return RuntimeState.STOPPED
    return RuntimeState.PAUSED if paused else RuntimeState.PLAYING


def _frozen(array):
    """A read-only float copy of `array`, safe to share between snapshots."""
    result = np.array(array, dtype=float)
    result.setflags(write=False)
    return result


@dataclasses.dataclass(frozen=True)
class ControllerState:
    """Immutable snapshot of one control cycle (arrays are read-only); field names follow RTDE outputs."""

    cycle: int
    timestamp: float
    target_q: np.ndarray
    target_qd: np.ndarray
    target_qdd: np.ndarray
    actual_q: np.ndarray
    actual_qd: np.ndarray
    actual_current: np.ndarray
    target_current: np.ndarray
    target_moment: np.ndarray
    joint_control_output: np.ndarray
    actual_tcp_pose: np.ndarray
    actual_tcp_speed: np.ndarray
    actual_tcp_force: np.ndarray
    target_tcp_pose: np.ndarray
    target_tcp_speed: np.ndarray
    tcp_offset: np.ndarray
    flange_pose: np.ndarray
    elbow_position: np.ndarray
    elbow_velocity: np.ndarray
    robot_mode: int
    control_mode: int
    safety_mode: int
    safety_status: int
    safety_status_bits: int
    robot_status_bits: int
    runtime_state: int
    joint_mode: tuple
    joint_temperatures: np.ndarray
    actual_joint_voltage: np.ndarray
    actual_main_voltage: float
    actual_robot_voltage: float
    actual_robot_current: float
    actual_momentum: float
    speed_scaling: float
    target_speed_fraction: float
    digital_input_bits: int  # bits 0-7 standard, 8-15 configurable, 16-17 tool (as RTDE reports them)
    configurable_digital_input_bits: int
    tool_digital_input_bits: int
    digital_output_bits: int  # bits 0-7 standard, 8-15 configurable, 16-17 tool
    standard_digital_output_bits: int
    configurable_digital_output_bits: int
    tool_digital_output_bits: int
    analog_io_types: int
    standard_analog_input0: float
    standard_analog_input1: float
    standard_analog_output0: float
    standard_analog_output1: float
    tool_analog_input0: float
    tool_analog_input1: float
    standard_analog_inputs: np.ndarray
    standard_analog_outputs: np.ndarray
    tool_analog_inputs: np.ndarray
    input_int_registers: np.ndarray
    output_int_registers: np.ndarray
    input_double_registers: np.ndarray
    output_double_registers: np.ndarray
    input_bit_registers: np.ndarray
    output_bit_registers: np.ndarray
    payload: float
    payload_cog: np.ndarray
    payload_inertia: np.ndarray
    program_running: bool
    program_paused: bool
    power_on: bool
    brakes_released: bool
    protective_stopped: bool
    emergency_stopped: bool
    freedrive: bool
    motion_active: bool
    execution_time: float  # s the last control cycle's computation took
    script_control_line: int
    external_force_torque: np.ndarray


class Motion:
    """Handle of one commanded motion: `wait()` for its end, then read `error` (None when it succeeded)."""

    def __init__(self, kind, blend_radius=0.0):
        self.kind = kind
        self.blend_radius = blend_radius
        self.error = None
        self._ended = threading.Event()

    @property
    def done(self):
        """True once the motion has ended, successfully or not (see `error`)."""
        return self._ended.is_set()

    @property
    def succeeded(self):
        """True once the motion has ended without error."""
        return self._ended.is_set() and self.error is None

    def wait(self, timeout=None, cancel=None):
        """Block until the motion ends (True), or `timeout` s pass / `cancel` is set (False). Does not stop the arm."""
        if cancel is None:
            return self._ended.wait(timeout)
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._ended.is_set():
            if cancel.is_set():
                return False
            remaining = 0.05 if deadline is None else min(0.05, deadline - time.monotonic())
            if remaining <= 0:
                return False
            self._ended.wait(remaining)
        return True

    def _finish(self, error=None):
        if not self._ended.is_set():
            self.error = error
            self._ended.set()

    def __repr__(self):
        status = "running" if not self.done else ("ok" if self.error is None else f"failed: {self.error}")
        return f"<Motion {self.kind} {status}>"


@dataclasses.dataclass
class _Active:
    """A segment being executed, the Motion it reports to, and whether trajectory time follows the slider."""

    segment: object
    motion: Motion
    follows_slider: bool
    target_q: np.ndarray = None  # planned moves: where the arm ends (for blending and queued starts)
    plan: object = None  # planned moves: start_q -> segment, called when the move starts
    in_blend_zone: bool = False


class Controller:
    """Emulated UR controller (Contract 3). Create, `start()`, command, `shutdown()`."""

    def __init__(self, model="ur3", version=None, initial_q=None, calibration=None, serial_number=None,
                 frequency=None, mode_delay=DEFAULT_MODE_DELAY, unlock_delay=PROTECTIVE_STOP_UNLOCK_DELAY):
        self.model = robot_model(model, calibration=calibration, serial_number=serial_number)
        self.version = default_version(self.model) if version is None else parse_version(version)
        check_version_fits(self.model, self.version)
        control_frequency = 500.0 if self.version.is_e_series else 125.0
        if frequency is not None:
            if not 1.0 <= float(frequency) <= 1000.0:
                raise ValueError(f"frequency must be 1..1000 Hz, got {frequency!r}")
            control_frequency = float(frequency)
        self.period = 1.0 / control_frequency
        self.mode_delay = float(mode_delay)
        self.unlock_delay = float(unlock_delay)
        self.messages = MessageBus()
        self.faults = Faults()
        self.io = IOState()
        self._dh = self.model.dh
        start_q = np.zeros(6) if initial_q is None else kinematics.checked_vector(initial_q, 6, "initial_q")
        self._check_within_limits(start_q, "initial_q", refuse=ValueError)

        self._lock = threading.RLock()
        self._cycle_changed = threading.Condition()
        self._thread = None
        self._stop_loop = threading.Event()
        self._cycle = 0
        self._sim_time = 0.0

        self._q = _frozen(start_q)
        self._qd = _frozen(np.zeros(6))
        self._qdd = _frozen(np.zeros(6))
        self._tcp_offset = _frozen(np.zeros(6))
        self._payload = 0.0
        self._payload_cog = _frozen(np.zeros(3))
        self._payload_inertia = _frozen(np.zeros(6))
        self._speed_slider = 1.0
        self._speed_scaling = 1.0  # trajectory-time scaling the controller applies itself (pause ramps it to 0)
        self._robot_mode = RobotMode.POWER_OFF
        self._safety_mode = SafetyMode.NORMAL
        self._pending_mode = None  # (sim time, robot mode) of a power-on / brake-release transition
        self._brakes_released = False
        self._freedrive = False
        self._protective_stop_at = None
        self._active = None  # _Active
        self._tail = None  # _Active still finishing underneath a blended successor
        self._queue = []  # _Active planned moves waiting for the current one
        self._runner = None
        self._program_running = False
        self._program_paused = False
        self.programs_directory = None  # dashboard `load` resolves relative paths here (None: current directory)
        self.loaded_program = None  # path of the program `play` runs
        self.loaded_program_source = None
        self._kinematics_cache = (None, None)
        self._changes = 0
        self._idle_signature = (None, None, None)
        self._execution_time = 0.0
        self._script_control_line = 0
        self._external_force_torque = _frozen(np.zeros(6))
        self._state = self._snapshot(self._q, self.period)

    # ---------------------------------------------------------------- lifecycle
    def start(self):
        """Start the control-loop thread (idempotent)."""
        with self._lock:
            if self._thread is not None:
                return
            self._stop_loop.clear()
            self._thread = threading.Thread(target=self._loop, name="sim_ursim-control", daemon=True)
            self._thread.start()
        log.info("controller %s (%s) started at %.0f Hz", self.model.name, self.version, 1 / self.period)

    def shutdown(self):
        """Stop the control loop, end every motion and the program; waits for the thread."""
        self._stop_loop.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(timeout=2.0)
        with self._lock:
            self._abort_motions("controller shut down")
            runner = self._runner
        if runner is not None and runner.is_running:
            runner.stop()
        with self._cycle_changed:
            self._cycle_changed.notify_all()

    def step(self, cycles=1, periods=1):
        """Advance `cycles` control cycles synchronously and return the last snapshot (only while the loop is stopped).

        Each cycle covers `periods` control periods, as the loop's cycles do when it catches up after a stall.
        For deterministic tests and hosts that drive simulated time themselves.
        """
        if self._thread is not None:
            raise CommandRefused("step() drives a stopped controller; this one runs its own control loop")
        periods = int(periods)
        if periods < 1:
            raise ValueError(f"periods must be ≥ 1, got {periods}")
        for _ in range(int(cycles)):
            self._cycle_once(periods)
        return self._state

    @property
    def running(self):
        """True while the control loop runs."""
        return self._thread is not None

    def _loop(self):
        deadline = time.monotonic()
        while not self._stop_loop.is_set():
            deadline += self.period
            delay = deadline - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            steps = 1
            late = time.monotonic() - deadline
            if late > 5 * self.period:
                # Far behind (the machine was busy): skip the missed cycles in one longer step instead of racing.
                missed = int(late / self.period)
                deadline += missed * self.period
                steps += missed
            try:
                self._cycle_once(steps)
            except Exception as error:  # noqa: BLE001 - a bug must not kill the loop: halt the arm, say why, go on
                log.exception("control cycle failed; halting the arm")
                with self._lock:
                    self._halt(f"simulator internal error: {error!r}")

    def _cycle_once(self, steps=1):
        """One control cycle covering `steps` periods: advance modes and motion, then publish the snapshot."""
        dt = self.period * steps
        began = time.perf_counter()
        with self._lock:
            self._cycle += steps
            self._sim_time += dt
            self._advance_mode_transition()
            signature = (self._changes, self.io.version, self._q)
            if self._at_rest_and_unchanged(signature):
                state = self._next_idle_snapshot(began)
            else:
                previous_q, previous_qd = self._q, self._qd
                new_q = self._advance_motion(dt)
                qd = (new_q - previous_q) / dt
                self._qdd = _frozen((qd - previous_qd) / dt)
                self._qd = _frozen(qd)
                if not np.array_equal(new_q, previous_q):
                    self._q = _frozen(new_q)
                self._execution_time = time.perf_counter() - began
                state = self._snapshot(previous_q, dt)
            self._idle_signature = (self._changes, self.io.version, self._q)
            # Stored under the lock so a command's _publish_status never overwrites a newer cycle.
            with self._cycle_changed:
                self._state = state
                self._cycle_changed.notify_all()

    def _at_rest_and_unchanged(self, signature):
        """True when nothing moves or changed since the last snapshot, so it can be reused with a new cycle number."""
        last = self._state
        return (self._active is None and self._tail is None and signature[0] == self._idle_signature[0]
                and signature[1] == self._idle_signature[1] and signature[2] is self._idle_signature[2]
                and not np.any(last.actual_qd) and not np.any(last.target_qdd) and last.actual_q is self._q)

    def _next_idle_snapshot(self, began):
        """The last snapshot with this cycle's number and times: an idle cycle costs almost nothing."""
        state = object.__new__(ControllerState)
        fields = state.__dict__
        fields.update(self._state.__dict__)
        self._execution_time = time.perf_counter() - began
        fields.update(cycle=self._cycle, timestamp=self._sim_time, execution_time=self._execution_time)
        return state

    def _touch(self):
        """Note a change the next snapshot must show (commands, settings, hand moves)."""
        self._changes += 1

    # ---------------------------------------------------------------- snapshots
    def state(self):
        """The snapshot of the last control cycle."""
        return self._state

    def wait_cycle(self, after_cycle, timeout=None):
        """Block until a cycle newer than `after_cycle` is published (or timeout); returns the latest snapshot."""
        with self._cycle_changed:
            self._cycle_changed.wait_for(lambda: self._state.cycle > after_cycle or self._stop_loop.is_set(), timeout)
            return self._state

    def _kinematics_of(self, q):
        """(tcp matrix, joint frames) at q, cached while q and the TCP offset are unchanged (idle costs nothing)."""
        key, cached = self._kinematics_cache
        if key is not None and key[0] is q and key[1] is self._tcp_offset:
            return cached
        frames = kinematics.joint_frames(self._dh, q)
        tcp = frames[-1] @ kinematics.pose_to_matrix(self._tcp_offset)
        result = (tcp, frames, _frozen(kinematics.matrix_to_pose(tcp)), _frozen(kinematics.matrix_to_pose(frames[-1])))
        self._kinematics_cache = ((q, self._tcp_offset), result)
        return result

    def _snapshot(self, previous_q, dt):
        """A full snapshot of the present cycle; TCP and elbow speeds by finite difference from previous_q over dt."""
        tcp, frames, tcp_pose, flange_pose = self._kinematics_of(self._q)
        if previous_q is self._q:
            tcp_speed = np.zeros(6)
            elbow_velocity = np.zeros(3)
        else:
            old_frames = kinematics.joint_frames(self._dh, previous_q)
            old_tcp = old_frames[-1] @ kinematics.pose_to_matrix(self._tcp_offset)
            tcp_speed = np.concatenate([(tcp[:3, 3] - old_tcp[:3, 3]) / dt,
                                        kinematics.matrix_to_rotation_vector(tcp[:3, :3] @ old_tcp[:3, :3].T) / dt])
            elbow_velocity = (frames[2][:3, 3] - old_frames[2][:3, 3]) / dt
        powered = self._robot_mode in (RobotMode.POWER_ON, RobotMode.IDLE, RobotMode.RUNNING)
        io = self.io
        zeros6 = _ZEROS6
        return ControllerState(
            **self._status_fields(),
            cycle=self._cycle,
            timestamp=self._sim_time,
            target_q=self._q, target_qd=self._qd, target_qdd=self._qdd,
            actual_q=self._q, actual_qd=self._qd,
            actual_current=zeros6, target_current=zeros6, target_moment=zeros6, joint_control_output=zeros6,
            actual_tcp_pose=tcp_pose, actual_tcp_speed=_frozen(tcp_speed), actual_tcp_force=self._external_force_torque,
            target_tcp_pose=tcp_pose, target_tcp_speed=_frozen(tcp_speed),
            tcp_offset=self._tcp_offset, flange_pose=flange_pose,
            elbow_position=_frozen(frames[2][:3, 3]), elbow_velocity=_frozen(elbow_velocity),
            joint_temperatures=_POWERED_TEMPERATURES if powered else _AMBIENT_TEMPERATURES,
            actual_joint_voltage=_JOINT_VOLTAGES if powered else zeros6,
            actual_main_voltage=MAIN_VOLTAGE,
            actual_robot_voltage=MAIN_VOLTAGE if powered else 0.0,
            actual_robot_current=0.0,
            actual_momentum=0.0,
            speed_scaling=self._speed_scaling,
            digital_input_bits=io.digital_input_bits,
            configurable_digital_input_bits=io.configurable_digital_inputs,
            tool_digital_input_bits=io.tool_digital_inputs,
            digital_output_bits=io.digital_output_bits,
            standard_digital_output_bits=io.standard_digital_outputs,
            configurable_digital_output_bits=io.configurable_digital_outputs,
            tool_digital_output_bits=io.tool_digital_outputs,
            analog_io_types=io.analog_io_types,
            standard_analog_input0=float(io.analog_inputs[0]), standard_analog_input1=float(io.analog_inputs[1]),
            standard_analog_output0=float(io.analog_outputs[0]), standard_analog_output1=float(io.analog_outputs[1]),
            tool_analog_input0=float(io.tool_analog_inputs[0]), tool_analog_input1=float(io.tool_analog_inputs[1]),
            standard_analog_inputs=io.analog_inputs, standard_analog_outputs=io.analog_outputs,
            tool_analog_inputs=io.tool_analog_inputs,
            input_int_registers=io.input_int_registers, output_int_registers=io.output_int_registers,
            input_double_registers=io.input_double_registers, output_double_registers=io.output_double_registers,
            input_bit_registers=io.input_bit_registers, output_bit_registers=io.output_bit_registers,
            execution_time=self._execution_time,
            script_control_line=self._script_control_line,
            external_force_torque=self._external_force_torque,
        )

    def _status_fields(self):
        """Snapshot fields that commands change between cycles (modes, status bits, program, settings)."""
        powered = self._robot_mode in (RobotMode.POWER_ON, RobotMode.IDLE, RobotMode.RUNNING)
        status_bits = (STATUS_BIT_POWER_ON if powered else 0) | (
            STATUS_BIT_PROGRAM_RUNNING if self._program_running and not self._program_paused else 0) | (
            STATUS_BIT_TEACH_BUTTON if self._freedrive else 0)
        return dict(
            robot_mode=self._robot_mode,
            control_mode=ControlMode.TEACH if self._freedrive else ControlMode.POSITION,
            safety_mode=self._safety_mode, safety_status=self._safety_mode,
            safety_status_bits=safety_status_bits(self._safety_mode),
            robot_status_bits=status_bits,
            runtime_state=runtime_state_of(self._program_running, self._program_paused),
            joint_mode=(self._joint_mode(),) * 6,
            program_running=self._program_running, program_paused=self._program_paused,
            power_on=powered, brakes_released=self._brakes_released,
            protective_stopped=self._safety_mode == SafetyMode.PROTECTIVE_STOP,
            emergency_stopped=self._safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP,
            freedrive=self._freedrive,
            motion_active=self._active is not None or self._tail is not None,
            target_speed_fraction=self._speed_slider,
            payload=self._payload, payload_cog=self._payload_cog, payload_inertia=self._payload_inertia,
        )

    def _publish_status(self):
        """Make a command's effect visible in state() at once (same cycle number; motion fields unchanged)."""
        with self._lock, self._cycle_changed:
            self._touch()
            self._state = dataclasses.replace(self._state, **self._status_fields())
            self._cycle_changed.notify_all()

    def _joint_mode(self):
        if self._robot_mode == RobotMode.RUNNING:
            return JointMode.RUNNING
        if self._robot_mode == RobotMode.IDLE:
            return JointMode.IDLE
        if self._robot_mode == RobotMode.POWER_ON:
            return JointMode.MOTOR_INITIALISATION
        return JointMode.POWER_OFF

    # ---------------------------------------------------------------- power, brakes, safety
    def power_on(self):
        """POWER_OFF → POWER_ON → (after mode_delay) IDLE. Refused during an emergency stop."""
        with self._lock:
            if self._safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
                raise CommandRefused("cannot power on: the emergency stop is active (release it first)")
            if self._robot_mode == RobotMode.POWER_OFF:
                self._set_robot_mode(RobotMode.POWER_ON)
                self._pending_mode = (self._sim_time + self.mode_delay, RobotMode.IDLE)
                self._publish_status()

    def brake_release(self):
        """Release the brakes: → RUNNING after mode_delay (powering on first from POWER_OFF, as the controller does)."""
        with self._lock:
            if self._safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
                raise CommandRefused("cannot release brakes: the emergency stop is active")
            if self._robot_mode == RobotMode.RUNNING:
                return
            if self._robot_mode == RobotMode.POWER_OFF:
                self._set_robot_mode(RobotMode.POWER_ON)
            delay = self.mode_delay * (2 if self._robot_mode == RobotMode.POWER_ON else 1)
            self._pending_mode = (self._sim_time + delay, RobotMode.RUNNING)
            self._publish_status()

    def power_off(self):
        """Cut power at once: motions and the program stop, brakes engage, robot mode POWER_OFF."""
        with self._lock:
            self._halt("robot powered off")
            self._pending_mode = None
            self._brakes_released = False
            self._freedrive = False
            self._set_robot_mode(RobotMode.POWER_OFF)
            self._publish_status()
        self._stop_program_for("robot powered off")

    def power_up(self, timeout=5.0):
        """Convenience for tests and demos: power on, release brakes and wait until RUNNING; TimeoutError if not."""
        self.power_on()
        self.brake_release()
        deadline = time.monotonic() + timeout
        while self._state.robot_mode != RobotMode.RUNNING:
            if time.monotonic() > deadline:
                raise TimeoutError(f"robot not RUNNING after {timeout} s (mode {self._state.robot_mode})")
            self.wait_cycle(self._state.cycle, timeout=0.1)
        return self._state

    def _advance_mode_transition(self):
        if self._pending_mode is None or self._sim_time < self._pending_mode[0]:
            return
        _, target = self._pending_mode
        self._pending_mode = None
        if self._robot_mode == RobotMode.POWER_ON and target == RobotMode.RUNNING:
            # brake release from power-off goes through IDLE like the controller's own sequence
            self._set_robot_mode(RobotMode.IDLE)
            self._pending_mode = (self._sim_time + self.mode_delay, RobotMode.RUNNING)
            return
        if target == RobotMode.RUNNING:
            self._brakes_released = True
        self._set_robot_mode(target)
        self._touch()

    def _set_robot_mode(self, mode):
        if mode != self._robot_mode:
            log.info("robot mode %s -> %s", RobotMode.NAMES[self._robot_mode], RobotMode.NAMES[mode])
            self._robot_mode = mode
            self._touch()

    def _set_safety_mode(self, mode):
        if mode != self._safety_mode:
            log.info("safety mode %s -> %s", SafetyMode.NAMES[self._safety_mode], SafetyMode.NAMES[mode])
            self._safety_mode = mode
            self._touch()
            self.messages.publish(SafetyModeMessage(code=0, argument=0, safety_mode_type=mode))

    def protective_stop(self, reason="protective stop requested"):
        """Enter PROTECTIVE_STOP: decelerate the arm, fail the motions, stop the program. Unlock ≥ 5 s later."""
        with self._lock:
            if self._safety_mode != SafetyMode.NORMAL:
                return
            self._protective_stop_locked(reason)
            self._publish_status()
        self._stop_program_for(f"protective stop: {reason}")

    def _protective_stop_locked(self, reason):
        """Protective stop from inside the control loop or a locked command (program stop left to the caller)."""
        log.warning("protective stop: %s", reason)
        self._protective_stop_at = time.monotonic()
        self._set_safety_mode(SafetyMode.PROTECTIVE_STOP)
        self.messages.publish(ErrorCodeMessage(code=209, argument=0, report_level=3, data_type=0, data=0,
                                               text=f"Protective stop: {reason}"))
        self._decelerate(PROTECTIVE_STOP_DECELERATION, f"protective stop: {reason}")

    def unlock_protective_stop(self):
        """Back to NORMAL; raises UnlockTooEarly within 5 s of the stop, CommandRefused if not protective-stopped."""
        with self._lock:
            if self._safety_mode != SafetyMode.PROTECTIVE_STOP:
                raise CommandRefused(f"not in protective stop (safety mode {SafetyMode.NAMES[self._safety_mode]})")
            if time.monotonic() - self._protective_stop_at < self.unlock_delay:
                raise UnlockTooEarly("Cannot unlock protective stop until 5s after occurrence. "
                                     "Always inspect cause of protective stop before unlocking")
            self._set_safety_mode(SafetyMode.NORMAL)
            self._publish_status()

    def emergency_stop(self):
        """Robot emergency stop: the arm halts at once, power is cut, the program stops. Release, then power on."""
        with self._lock:
            if self._safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
                return
            self._set_safety_mode(SafetyMode.ROBOT_EMERGENCY_STOP)
            self._halt("emergency stop")
            self._pending_mode = None
            self._brakes_released = False
            self._freedrive = False
            self._set_robot_mode(RobotMode.POWER_OFF)
            self._publish_status()
        self._stop_program_for("emergency stop")

    def release_emergency_stop(self):
        """Release the emergency-stop button: safety NORMAL again, the arm stays powered off."""
        with self._lock:
            if self._safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
                self._set_safety_mode(SafetyMode.NORMAL)
                self._publish_status()

    # ---------------------------------------------------------------- motion commands
    def movej(self, q, a=1.4, v=1.05, t=0.0, r=0.0):
        """Joint move on synchronised trapezoids (leading axis a [rad/s²], v [rad/s]; t [s] overrides)."""
        q = kinematics.checked_vector(q, 6, "q")
        a, v, t, r = self._checked_move_parameters(a, v, t, r)
        self._check_within_limits(q, "movej target")
        with self._lock:
            self._require_motion_allowed("movej")
            motion = Motion("movej", r)
            self._enqueue(_Active(None, motion, True, target_q=q), lambda start: self._plan_movej(start, q, a, v, t))
            return motion

    def movel(self, pose, a=1.2, v=0.25, t=0.0, r=0.0):
        """Straight-line TCP move to `pose` (a [m/s²], v [m/s]; t [s] overrides); IK from the joints before it."""
        pose = kinematics.checked_vector(pose, 6, "pose")
        a, v, t, r = self._checked_move_parameters(a, v, t, r)
        with self._lock:
            self._require_motion_allowed("movel")
            start_q = self._queued_end_q()
            q_end = self._ik_checked(pose, start_q)
            motion = Motion("movel", r)
            self._enqueue(_Active(None, motion, True, target_q=q_end),
                          lambda start: self._plan_movel(start, pose, q_end, a, v, t))
            return motion

    def speedj(self, qd, a=1.4, t=0.0):
        """Joint speeds qd [rad/s] reached at acceleration a; after t s (t > 0) decelerate to rest."""
        qd = kinematics.checked_vector(qd, 6, "qd")
        a = _positive(a, "a")
        t = _non_negative(t, "t")
        if np.any(np.abs(qd) > self.model.max_joint_speed * 1.0000001):
            raise ValueError(f"qd {np.round(qd, 4).tolist()} exceeds the joint speed limits "
                             f"{np.round(self.model.max_joint_speed, 4).tolist()} rad/s")
        with self._lock:
            self._require_motion_allowed("speedj")
            start = self._speed_ramp_start("speedj", self._qd)
            return self._replace_motion(motion.JointSpeed(start, qd, a, t), "speedj", True)

    def speedl(self, xd, a=1.2, t=0.0):
        """TCP twist xd [vx vy vz wx wy wz] (base frame, m/s, rad/s) reached at acceleration a; after t s stop."""
        xd = kinematics.checked_vector(xd, 6, "xd")
        a = _positive(a, "a")
        t = _non_negative(t, "t")
        with self._lock:
            self._require_motion_allowed("speedl")
            start = self._speed_ramp_start("speedl", self._state.actual_tcp_speed)
            segment = motion.CartesianSpeed(start, xd, a, t, self._tcp_matrix, self._solve_ik)
            return self._replace_motion(segment, "speedl", True)

    def servoj(self, q, a=0.0, v=0.0, t=0.008, lookahead_time=0.1, gain=300):
        """Servo towards q, arriving t s from now (a, v accepted; lookahead_time 0.03..0.2 and gain 100..2000 checked)."""
        q = kinematics.checked_vector(q, 6, "q")
        t = _positive(t, "t")
        if not 0.03 <= float(lookahead_time) <= 0.2:
            raise ValueError(f"lookahead_time must be 0.03..0.2 s, got {lookahead_time!r}")
        if not 100 <= float(gain) <= 2000:
            raise ValueError(f"gain must be 100..2000, got {gain!r}")
        self._check_within_limits(q, "servoj target")
        with self._lock:
            self._require_motion_allowed("servoj")
            return self._replace_motion(motion.ServoTarget(q, t, self.model.max_joint_speed), "servoj", False)

    def stopj(self, a=2.0):
        """Decelerate every joint to rest at a [rad/s²] (path kept); the current and queued motions end."""
        a = _positive(a, "a")
        with self._lock:
            return self._stop_with(a, "stopj")

    def stopl(self, a=1.2):
        """Decelerate the TCP to rest at a [m/s²] (joint-space deceleration taking the TCP's stopping time)."""
        a = _positive(a, "a")
        with self._lock:
            tcp_speed = float(np.linalg.norm(self._state.actual_tcp_speed[:3]))
            joint_speed = float(np.max(np.abs(self._qd)))
            # Same stopping time as the TCP would need: T = |v_tcp| / a, applied to the joints.
            joint_deceleration = joint_speed * a / tcp_speed if tcp_speed > 1e-9 else PROTECTIVE_STOP_DECELERATION
            return self._stop_with(joint_deceleration, "stopl")

    def move_joints_by_hand(self, q):
        """Freedrive: the operator pushes the arm to q (must be within limits; freedrive must be on)."""
        q = kinematics.checked_vector(q, 6, "q")
        self._check_within_limits(q, "hand-guided joints")
        with self._lock:
            if not self._freedrive:
                raise CommandRefused("the arm can be moved by hand only in freedrive (teach) mode")
            self._q = _frozen(q)
            self._touch()
            with self._cycle_changed:
                self._state = self._snapshot(self._q, self.period)

    def set_freedrive(self, on):
        """Freedrive / teach mode on or off (on needs RUNNING + NORMAL; motions are refused while it is on)."""
        with self._lock:
            if on:
                self._require_running_normal("freedrive")
                self._halt("freedrive started")
            if bool(on) != self._freedrive:
                log.info("freedrive %s", "on" if on else "off")
            self._freedrive = bool(on)
            self._publish_status()

    # ---------------------------------------------------------------- settings
    def set_speed_slider(self, fraction):
        """Speed slider 0..1: planned trajectories advance by dt × fraction."""
        fraction = float(fraction)
        if not 0.0 <= fraction <= 1.0 or math.isnan(fraction):
            raise ValueError(f"speed slider fraction must be 0..1, got {fraction!r}")
        with self._lock:
            self._speed_slider = fraction
            self._publish_status()

    def set_tcp(self, pose):
        """TCP offset as a UR pose vector in the flange frame."""
        pose = _frozen(kinematics.checked_vector(pose, 6, "tcp pose"))
        with self._lock:
            self._tcp_offset = pose
            self._touch()

    def set_payload(self, mass, cog=None, inertia=None):
        """Payload mass [kg] (≥ 0), centre of gravity [m] in the flange frame, inertia [Ixx Iyy Izz Ixy Ixz Iyz]."""
        mass = _non_negative(mass, "mass")
        with self._lock:
            self._payload = mass
            if cog is not None:
                self._payload_cog = _frozen(kinematics.checked_vector(cog, 3, "cog"))
            if inertia is not None:
                self._payload_inertia = _frozen(kinematics.checked_vector(inertia, 6, "inertia"))
            self._publish_status()

    def set_external_force_torque(self, wrench):
        """Wrench [Fx Fy Fz Tx Ty Tz] an RTDE client feeds in (external_force_torque); reported as actual_TCP_force."""
        wrench = _frozen(kinematics.checked_vector(wrench, 6, "external_force_torque"))
        with self._lock:
            self._external_force_torque = wrench
            self._touch()

    def set_script_control_line(self, line):
        """The URScript line being executed (RTDE script_control_line); set by the runner."""
        with self._lock:
            self._script_control_line = max(0, int(line))
            self._touch()

    # ---------------------------------------------------------------- kinematics helpers
    def fk(self, q):
        """TCP pose vector (base frame, current TCP offset) at joints q."""
        return kinematics.tcp_pose(self._dh, kinematics.checked_vector(q, 6, "q"), self._tcp_offset)

    def ik(self, pose, q_near=None):
        """Joints reaching TCP `pose` nearest to q_near (default: the current joints); kinematics.IKError if none."""
        pose = kinematics.checked_vector(pose, 6, "pose")
        start = self._q if q_near is None else kinematics.checked_vector(q_near, 6, "q_near")
        return kinematics.inverse_kinematics(self._dh, pose, start, self._tcp_offset)

    def _tcp_matrix(self, q):
        return kinematics.tcp_matrix(self._dh, q, self._tcp_offset)

    def _solve_ik(self, pose, q_near):
        return kinematics.inverse_kinematics(self._dh, pose, q_near, self._tcp_offset, tolerance=1e-11,
                                             max_iterations=50)

    def _ik_checked(self, pose, q_near):
        try:
            q = self._solve_ik(pose, q_near)
        except kinematics.IKError as error:
            raise CommandRefused(str(error)) from None
        self._check_within_limits(q, "IK solution")
        return q

    # ---------------------------------------------------------------- program hooks
    def attach_program_runner(self, runner):
        """The URScript runner: has submit(source, origin), stop(), pause(), resume(), is_running."""
        self._runner = runner

    @property
    def program_runner(self):
        """The attached runner (None until attach_program_runner)."""
        return self._runner

    def set_program_state(self, running, paused=False):
        """Called by the runner when a program starts / pauses / resumes / ends: runtime_state and status bits."""
        with self._lock:
            if (bool(running), bool(paused)) != (self._program_running, self._program_paused):
                log.info("program %s", "paused" if running and paused else "running" if running else "stopped")
            self._program_running = bool(running)
            self._program_paused = bool(running) and bool(paused)
            if not running:
                self._speed_scaling = 1.0  # a stopped program leaves no pause ramp behind
            self._publish_status()

    def run_program(self, source, origin="dashboard"):
        """Hand URScript `source` to the runner; its answer (False: refused) is returned. CommandRefused if none."""
        if self._runner is None:
            raise CommandRefused("no URScript runner attached")
        return self._runner.submit(source, origin)

    def stop_program(self):
        """Stop the running program and the arm (stopj with the protective deceleration)."""
        if self._runner is not None:
            self._runner.stop()
        with self._lock:
            self._stop_with(PROTECTIVE_STOP_DECELERATION, "program stopped")
        self.set_program_state(False)

    def pause_program(self):
        """Pause the running program (the runner decides how its motion pauses)."""
        if self._runner is not None:
            self._runner.pause()
        self.set_program_state(self._program_running, True)

    def resume_program(self):
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
    def _require_running_normal(self, what):
        if self._robot_mode != RobotMode.RUNNING:
            raise CommandRefused(f"{what} refused: robot mode is {RobotMode.NAMES[self._robot_mode]}, "
                                 "not RUNNING (power on and release the brakes)")
        if self._safety_mode != SafetyMode.NORMAL:
            raise CommandRefused(f"{what} refused: safety mode is {SafetyMode.NAMES[self._safety_mode]}")

    def _require_motion_allowed(self, what):
        self._require_running_normal(what)
        if self._freedrive:
            raise CommandRefused(f"{what} refused: freedrive (teach) mode is on")

    def _checked_move_parameters(self, a, v, t, r):
        return _positive(a, "a"), _positive(v, "v"), _non_negative(t, "t"), _non_negative(r, "r")

    def _check_within_limits(self, q, what, refuse=None):
        outside = np.nonzero((q < self.model.joint_lower) | (q > self.model.joint_upper))[0]
        if outside.size:
            i = int(outside[0])
            error = refuse or CommandRefused
            raise error(f"{what}: joint {i} at {q[i]:.4f} rad is outside its limits "
                        f"[{self.model.joint_lower[i]:.4f}, {self.model.joint_upper[i]:.4f}]")

    def _queued_end_q(self):
        """Where the arm will be when a newly queued move starts: the last queued/active target, else now."""
        for entry in reversed(self._queue):
            return entry.target_q
        if self._active is not None and self._active.target_q is not None:
            return self._active.target_q
        return np.array(self._q)

    def _plan_movej(self, start_q, q, a, v, t):
        profile = motion.synchronised_joint_profile(q - start_q, v, a, t, self.model.max_joint_speed,
                                                    self.model.max_joint_acceleration)
        return motion.JointMove(start_q, q, profile)

    def _plan_movel(self, start_q, pose, q_end, a, v, t):
        start_matrix = self._tcp_matrix(start_q)
        end_matrix = kinematics.pose_to_matrix(pose)
        distance = motion.linear_distance(start_matrix, end_matrix)
        profile = motion.timed_trapezoid(distance, t, a) if t > 0 else motion.trapezoid(distance, v, a)
        return motion.LinearMove(start_matrix, end_matrix, start_q, q_end, profile, self._solve_ik)

    def _enqueue(self, entry, plan):
        """Queue a planned move; `plan(start_q)` builds its segment when it starts."""
        entry.plan = plan
        streaming = self._active is not None and self._active.target_q is None
        if streaming:
            # A speed/servo command is running: bring it to rest first, then the move starts.
            self._stop_with(PROTECTIVE_STOP_DECELERATION, entry.motion.kind, end_queue=False)
        self._queue.append(entry)
        if self._active is None:
            self._start_next(np.array(self._q), blended=False)
        self._publish_status()

    def _start_next(self, start_q, blended):
        """Start the first queued move from start_q (superposed on the current one when blended)."""
        entry = self._queue.pop(0)
        try:
            entry.segment = entry.plan(start_q)
        except (ValueError, kinematics.IKError) as error:
            entry.motion._finish(str(error))
            self._end_all(lambda queued: f"not started: an earlier move failed ({error})")
            return
        if blended:
            self._tail = self._active
        self._active = entry
        log.info("%s started (%.3f s planned)", entry.motion.kind, entry.segment.profile.duration)

    def _speed_ramp_start(self, kind, measured):
        """Where a new speedj/speedl ramp starts: the running command's own ramp when it is the same kind, else
        the measured speed.

        Clients repeat speed commands every cycle or two (ur_rtde's speed thread does): continuing the commanded
        ramp keeps them exact, whereas the measured speed already includes the speed slider (each restart would
        shrink it again) and any measurement error.
        """
        active = self._active
        if active is not None and self._tail is None and active.segment.kind == kind:
            return active.segment.commanded_speed
        return np.array(measured, dtype=float)

    def _replace_motion(self, segment, kind, follows_slider):
        """Streaming commands (speedj, speedl, servoj) take over at once from whatever runs."""
        self._end_all(lambda entry: None if entry.motion.kind == kind else f"interrupted by {kind}")
        self._tail = None
        entry = _Active(segment, Motion(kind), follows_slider)
        self._active = entry
        self._publish_status()
        return entry.motion

    def _stop_with(self, deceleration, kind, end_queue=True):
        """Replace every motion by a deceleration to rest; returns the stop's Motion."""
        if end_queue:
            self._end_all(lambda entry: f"stopped by {kind}")
        else:
            self._end_active(f"stopped by {kind}")
        entry = _Active(motion.Stop(self._qd, deceleration), Motion(kind), False)
        self._active = entry
        self._tail = None
        self._publish_status()
        return entry.motion

    def _decelerate(self, deceleration, error):
        """Safety stop: the motions fail with `error`; the arm decelerates to rest."""
        self._end_all(lambda entry: error)
        self._active = _Active(motion.Stop(self._qd, deceleration), Motion("stop"), False)
        self._tail = None

    def _halt(self, error):
        """Immediate halt (e-stop, power off): speed zero now, every motion fails."""
        self._end_all(lambda entry: error)
        self._active = None
        self._tail = None
        self._qd = _frozen(np.zeros(6))

    def _abort_motions(self, error):
        self._end_all(lambda entry: error)
        self._active = None
        self._tail = None

    def _end_active(self, error):
        for entry in (self._tail, self._active):
            if entry is not None:
                entry.motion._finish(error)

    def _end_all(self, error_of):
        for entry in [self._tail, self._active] + self._queue:
            if entry is not None:
                entry.motion._finish(error_of(entry))
        self._queue = []

    def _advance_motion(self, dt):
        """Joints after one cycle of the active motion (protective stop on limit or speed violations)."""
        q = np.array(self._q)
        if self._freedrive or self._active is None:
            return q
        planned_dt = dt * self._speed_slider * self._ramp_speed_scaling(dt)
        active = self._active
        try:
            new_q = active.segment.advance(planned_dt if active.follows_slider else dt, q)
            if self._tail is not None:
                # Blend: the rest of the previous move plus this move's displacement from its own start.
                tail = self._tail
                new_q = tail.segment.advance(planned_dt) + (new_q - active.segment.q_start)
                if tail.segment.finished:
                    self._tail = None
        except kinematics.IKError as error:
            self._protective_stop_locked(f"{active.motion.kind}: {error}")
            self._request_program_stop(f"{active.motion.kind} failed")
            return q
        if not self._motion_step_safe(q, new_q, dt, active):
            return q
        self._finish_or_blend(active, new_q)
        return new_q

    def _ramp_speed_scaling(self, dt):
        """speed_scaling after dt: towards 0 while the program is paused, towards 1 otherwise."""
        goal = 0.0 if self._program_paused else 1.0
        step = dt / PAUSE_RAMP_TIME
        self._speed_scaling = min(goal, self._speed_scaling + step) if goal > self._speed_scaling else max(
            goal, self._speed_scaling - step)
        return self._speed_scaling

    def _motion_step_safe(self, q, new_q, dt, active):
        """Joint-limit and (for Cartesian motions) joint-speed protection; protective stop when violated."""
        outside = np.nonzero((new_q < self.model.joint_lower) | (new_q > self.model.joint_upper))[0]
        reason = None
        if outside.size:
            i = int(outside[0])
            reason = f"joint {i} position limit reached during {active.motion.kind}"
        elif active.segment.kind in ("movel", "speedl"):
            speeds = np.abs(new_q - q) / dt
            too_fast = np.nonzero(speeds > self.model.max_joint_speed * JOINT_SPEED_TOLERANCE)[0]
            if too_fast.size:
                i = int(too_fast[0])
                reason = (f"joint {i} speed {speeds[i]:.2f} rad/s above its limit during {active.motion.kind} "
                          "(close to a singularity)")
        if reason is None:
            return True
        self._protective_stop_locked(reason)
        self._request_program_stop(reason)
        return False

    def _request_program_stop(self, reason):
        """From inside the control loop: stop the program on another thread so the loop never waits for it."""
        threading.Thread(target=self._stop_program_for, args=(reason,), name="sim_ursim-program-stop",
                         daemon=True).start()

    def _finish_or_blend(self, active, new_q):
        """End a finished segment and start the next queued one; with r > 0 start it inside the blend zone."""
        if active.segment.finished and self._tail is None:
            active.motion._finish(None)
            self._active = None
            if self._queue:
                self._start_next(new_q, blended=False)
            return
        if active.target_q is None or active.motion.blend_radius <= 0:
            return
        if not active.in_blend_zone:
            here = self._tcp_matrix(new_q)[:3, 3]
            there = self._tcp_matrix(active.target_q)[:3, 3]
            if float(np.linalg.norm(there - here)) > active.motion.blend_radius:
                return
            # Inside the blend zone the program may go on (the URScript move returns) while the arm continues.
            active.in_blend_zone = True
            active.motion._finish(None)
        if self._queue and self._tail is None:
            self._start_next(active.target_q, blended=True)


_ZEROS6 = _frozen(np.zeros(6))
_AMBIENT_TEMPERATURES = _frozen(np.full(6, AMBIENT_TEMPERATURE))
_POWERED_TEMPERATURES = _frozen(np.full(6, POWERED_TEMPERATURE))
_JOINT_VOLTAGES = _frozen(np.full(6, MAIN_VOLTAGE))


def _positive(value, name):
    """`value` as a finite float > 0; ValueError naming `name` otherwise."""
    number = _number(value, name)
    if number <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return number


def _non_negative(value, name):
    """`value` as a finite float ≥ 0; ValueError naming `name` otherwise."""
    number = _number(value, name)
    if number < 0:
        raise ValueError(f"{name} must be ≥ 0, got {value!r}")
    return number


def _number(value, name):
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number
