"""The simulated controller's vocabulary: modes, status bits, the state snapshot and the refusals.

The servers (dashboard, primary, RTDE, control channel), the URScript interpreter and the controller all speak it;
none of them needs the controller's machinery to name a mode or catch a refusal. Enumeration values are the
controller's own (docs/protocols.md §1 and §5.4).
"""
import dataclasses

import numpy as np


class RobotMode:
    """robot_mode enumeration (docs/protocols.md §1)."""

    NO_CONTROLLER, DISCONNECTED, CONFIRM_SAFETY, BOOTING, POWER_OFF, POWER_ON, IDLE, BACKDRIVE, RUNNING = range(-1, 8)
    NAMES = {-1: "NO_CONTROLLER", 0: "DISCONNECTED", 1: "CONFIRM_SAFETY", 2: "BOOTING", 3: "POWER_OFF",
             4: "POWER_ON", 5: "IDLE", 6: "BACKDRIVE", 7: "RUNNING", 8: "UPDATING_FIRMWARE"}


class SafetyMode:
    """safety_mode / safety_status enumeration (docs/protocols.md §1)."""

    NORMAL, REDUCED, PROTECTIVE_STOP, RECOVERY, SAFEGUARD_STOP = 1, 2, 3, 4, 5
    SYSTEM_EMERGENCY_STOP, ROBOT_EMERGENCY_STOP, VIOLATION, FAULT = 6, 7, 8, 9
    NAMES = {1: "NORMAL", 2: "REDUCED", 3: "PROTECTIVE_STOP", 4: "RECOVERY", 5: "SAFEGUARD_STOP",
             6: "SYSTEM_EMERGENCY_STOP", 7: "ROBOT_EMERGENCY_STOP", 8: "VIOLATION", 9: "FAULT",
             10: "VALIDATE_JOINT_ID", 11: "UNDEFINED_SAFETY_MODE"}


class RuntimeState:
    """runtime_state enumeration (docs/protocols.md §1)."""

    STOPPING, STOPPED, PLAYING, PAUSING, PAUSED, RESUMING = range(6)


class JointMode:
    """joint_mode enumeration (docs/protocols.md §1)."""

    BACKDRIVE, POWER_OFF, MOTOR_INITIALISATION, BOOTING, RUNNING, IDLE = 238, 239, 246, 247, 253, 255


class ControlMode:
    """Primary RobotModeData controlMode."""

    POSITION, TEACH, FORCE, TORQUE = range(4)


# safety_status_bits (docs/protocols.md §5.4)
SAFETY_BIT_NORMAL, SAFETY_BIT_REDUCED, SAFETY_BIT_PROTECTIVE_STOPPED = 1 << 0, 1 << 1, 1 << 2
SAFETY_BIT_ROBOT_EMERGENCY_STOPPED, SAFETY_BIT_EMERGENCY_STOPPED, SAFETY_BIT_STOPPED_DUE_TO_SAFETY = (
    1 << 6, 1 << 7, 1 << 10)
# robot_status_bits
STATUS_BIT_POWER_ON, STATUS_BIT_PROGRAM_RUNNING, STATUS_BIT_TEACH_BUTTON = 1 << 0, 1 << 1, 1 << 2

PROTECTIVE_STOP_UNLOCK_DELAY = 5.0  # s: "Cannot unlock protective stop until 5s after occurrence"
PROTECTIVE_STOP_DECELERATION = 10.0  # rad/s² on every joint: a controlled (category 2) stop


class CommandRefused(RuntimeError):
    """The controller refused a command in its present state (the message says why)."""


class UnlockTooEarly(CommandRefused):
    """`unlock protective stop` came less than 5 s after the stop."""


def safety_status_bits(safety_mode: int) -> int:
    """safety_status_bits word for a safety mode (normal, protective stop, robot e-stop; others map to their bit)."""
    if safety_mode == SafetyMode.NORMAL:
        return SAFETY_BIT_NORMAL
    if safety_mode == SafetyMode.PROTECTIVE_STOP:
        return SAFETY_BIT_PROTECTIVE_STOPPED | SAFETY_BIT_STOPPED_DUE_TO_SAFETY
    if safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
        return SAFETY_BIT_ROBOT_EMERGENCY_STOPPED | SAFETY_BIT_EMERGENCY_STOPPED | SAFETY_BIT_STOPPED_DUE_TO_SAFETY
    return (1 << (safety_mode - 1)) | SAFETY_BIT_STOPPED_DUE_TO_SAFETY


def runtime_state_of(running: bool, paused: bool) -> int:
    """runtime_state for a program that is (not) running and (not) paused."""
    if not running:
        return RuntimeState.STOPPED
    return RuntimeState.PAUSED if paused else RuntimeState.PLAYING


def frozen_array(array: object) -> np.ndarray:
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


def replaced_state(state: ControllerState, **fields) -> ControllerState:
    """A copy of the frozen snapshot `state` with `fields` changed, without re-running the dataclass __init__ (a
    command commits often: ur_rtde streams servoj and register writes at the control rate)."""
    copy = object.__new__(ControllerState)
    copy.__dict__.update(state.__dict__)
    copy.__dict__.update(fields)
    return copy
