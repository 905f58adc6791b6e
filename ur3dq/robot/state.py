"""The driver's view of the controller: one immutable snapshot, and pure decoders of the controller's codes.

Enumerations follow docs/protocols.md §1 (RTDE and primary alike); both interfaces use the same robot-mode and
safety-mode numbers.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ur3dq.errors import EmergencyStopError, InvalidStateError

ROBOT_MODE_NAMES = {
    -1: "NO_CONTROLLER", 0: "DISCONNECTED", 1: "CONFIRM_SAFETY", 2: "BOOTING", 3: "POWER_OFF", 4: "POWER_ON",
    5: "IDLE", 6: "BACKDRIVE", 7: "RUNNING", 8: "UPDATING_FIRMWARE",
}
SAFETY_MODE_NAMES = {
    1: "NORMAL", 2: "REDUCED", 3: "PROTECTIVE_STOP", 4: "RECOVERY", 5: "SAFEGUARD_STOP",
    6: "SYSTEM_EMERGENCY_STOP", 7: "ROBOT_EMERGENCY_STOP", 8: "VIOLATION", 9: "FAULT", 10: "VALIDATE_JOINT_ID",
    11: "UNDEFINED_SAFETY_MODE", 12: "AUTOMATIC_MODE_SAFEGUARD_STOP", 13: "SYSTEM_THREE_POSITION_ENABLING_STOP",
}
ROBOT_MODE_IDLE = 5
ROBOT_MODE_RUNNING = 7
RUNTIME_STATE_PLAYING = 2
RUNTIME_STATES_PAUSED = frozenset({3, 4})   # PAUSING, PAUSED (RTDE runtime_state)
EMERGENCY_SAFETY_MODES = frozenset({6, 7})
PROTECTIVE_SAFETY_MODES = frozenset({3})

# Bounds no real UR arm exceeds: joints turn at most ±2 turns (±4π; 2π limits on most joints, margin for wrist 3),
# no joint is faster than 10 rad/s, no TCP is 10 m from the base. Beyond them the data is garbage, not state.
MAX_PLAUSIBLE_JOINT = 4 * np.pi + 0.1  # rad
MAX_PLAUSIBLE_JOINT_SPEED = 10.0  # rad/s
MAX_PLAUSIBLE_REACH = 10.0  # m
MAX_PLAUSIBLE_SPEED_FRACTION = 2.0

_STATUS_BIT_PROGRAM_RUNNING = 1 << 1
_SAFETY_BIT_PROTECTIVE_STOPPED = 1 << 2
_SAFETY_BIT_EMERGENCY_STOPPED = 1 << 7


@dataclass(frozen=True)
class RobotStatus:
    """One reading of the controller: joints (rad), TCP pose (UR pose vector), modes, flags and speed fractions.

    `age` is how many seconds ago the state stream last delivered fresh data (large ⇒ frozen stream).
    `program_paused` is True while a program is paused (not running, not ended). The I/O is read apart
    (Robot.io_state, ur3dq.robot.io_state).
    """

    joints: np.ndarray
    joint_speeds: np.ndarray
    tcp_pose: np.ndarray
    robot_mode: int
    safety_mode: int
    program_running: bool
    protective_stopped: bool
    emergency_stopped: bool
    speed_scaling: float
    target_speed_fraction: float
    age: float
    program_paused: bool = False

    @property
    def robot_mode_name(self) -> str:
        """The robot mode's name, e.g. 'RUNNING'."""
        return robot_mode_name(self.robot_mode)

    @property
    def safety_mode_name(self) -> str:
        """The safety mode's name, e.g. 'NORMAL'."""
        return safety_mode_name(self.safety_mode)


def robot_mode_name(mode: int) -> str:
    """Name of a robot-mode code (RTDE robot_mode / primary robotMode), 'UNKNOWN(n)' if unlisted."""
    return ROBOT_MODE_NAMES.get(int(mode), f"UNKNOWN({int(mode)})")


def safety_mode_name(mode: int) -> str:
    """Name of a safety-mode code (RTDE safety_mode / masterboard safetyMode), 'UNKNOWN(n)' if unlisted."""
    return SAFETY_MODE_NAMES.get(int(mode), f"UNKNOWN({int(mode)})")


def program_running_from(runtime_state: int, robot_status_bits: int) -> bool:
    """True if RTDE says a program runs: runtime_state PLAYING or robot_status_bits bit 1."""
    return int(runtime_state) == RUNTIME_STATE_PLAYING or bool(int(robot_status_bits) & _STATUS_BIT_PROGRAM_RUNNING)


def program_paused_from(runtime_state: int) -> bool:
    """True if RTDE's runtime_state says the program is pausing or paused."""
    return int(runtime_state) in RUNTIME_STATES_PAUSED


def protective_stopped_from(safety_status_bits: int, safety_mode: int) -> bool:
    """True if RTDE reports a protective stop: safety_status_bits bit 2, or safety mode PROTECTIVE_STOP."""
    return bool(int(safety_status_bits) & _SAFETY_BIT_PROTECTIVE_STOPPED) or int(safety_mode) in PROTECTIVE_SAFETY_MODES


def emergency_stopped_from(safety_status_bits: int, safety_mode: int) -> bool:
    """True if RTDE reports an emergency stop: safety_status_bits bit 7, or a (system/robot) e-stop safety mode."""
    return bool(int(safety_status_bits) & _SAFETY_BIT_EMERGENCY_STOPPED) or int(safety_mode) in EMERGENCY_SAFETY_MODES


def unlock_needed(status: RobotStatus, host: str) -> bool:
    """Whether `status` shows a protective stop to unlock; EmergencyStopError, with its fix, during an emergency
    stop (no unlock ends that)."""
    if status.emergency_stopped:
        raise EmergencyStopError(f"{host} is emergency-stopped ({status.safety_mode_name}), which no unlock ends: "
                                 "release the e-stop button, then `ur3dq robot power-on`")
    return status.protective_stopped


def at_rest_at(status: RobotStatus, target: object, position_tolerance: float = 2e-3,
              speed_tolerance: float = 5e-3) -> bool:
    """True if every joint is within `position_tolerance` rad of `target` and slower than `speed_tolerance` rad/s."""
    return bool(
        np.max(np.abs(status.joints - np.asarray(target, dtype=float))) <= position_tolerance
        and np.max(np.abs(status.joint_speeds)) <= speed_tolerance
    )


def validated(status: RobotStatus, source: str, safety_mode_reported: bool = True) -> RobotStatus:
    """`status` unchanged if it can be true, else InvalidStateError.

    `status` unchanged if it can be true; else InvalidStateError naming `source` (e.g. 'RTDE from 10.0.0.2')
    and the first implausible field. Called before any state is used or stored. `safety_mode_reported=False`
    accepts safety mode 0 (the urx backend's "not reported yet")."""
    vectors = (("joints", status.joints, MAX_PLAUSIBLE_JOINT, 6), ("joint speeds", status.joint_speeds,
               MAX_PLAUSIBLE_JOINT_SPEED, 6), ("TCP pose", status.tcp_pose, None, 6))
    for name, values, bound, length in vectors:
        values = np.asarray(values, dtype=float)
        if values.shape != (length,) or not np.all(np.isfinite(values)):
            raise InvalidStateError(f"{source} sent invalid {name} {_shown(values)}: not {length} finite numbers")
        if bound is not None and np.max(np.abs(values)) > bound:
            raise InvalidStateError(f"{source} sent implausible {name} {_shown(values)} (beyond ±{bound:.4g})")
    if np.linalg.norm(status.tcp_pose[:3]) > MAX_PLAUSIBLE_REACH or np.max(np.abs(status.tcp_pose[3:])) > 4 * np.pi:
        raise InvalidStateError(f"{source} sent an implausible TCP pose {_shown(status.tcp_pose)}")
    if int(status.robot_mode) not in ROBOT_MODE_NAMES:
        raise InvalidStateError(f"{source} sent an unknown robot mode {status.robot_mode!r}")
    if int(status.safety_mode) not in SAFETY_MODE_NAMES and (safety_mode_reported or status.safety_mode != 0):
        raise InvalidStateError(f"{source} sent an unknown safety mode {status.safety_mode!r}")
    for name in ("speed_scaling", "target_speed_fraction"):
        value = float(getattr(status, name))
        if not (0.0 <= value <= MAX_PLAUSIBLE_SPEED_FRACTION):
            raise InvalidStateError(f"{source} sent an implausible {name.replace('_', ' ')} {value!r}")
    return status


def _shown(values: object) -> str:
    """A short text of a vector for an error message."""
    return np.array2string(np.asarray(values), precision=4, threshold=8)
