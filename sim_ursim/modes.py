"""Robot mode and safety mode of the simulated arm, and their timed transitions.

POWER_OFF → (power on) POWER_ON → after `mode_delay` IDLE → (brake release) after `mode_delay` RUNNING; a brake
release from POWER_OFF goes through POWER_ON and IDLE like the controller's own sequence. Safety: NORMAL,
PROTECTIVE_STOP (unlock no sooner than `unlock_delay` after the stop, as the controller insists), and
ROBOT_EMERGENCY_STOP (power cut; release, then power on again).

Not thread-safe on its own: the controller calls it under its lock. Stopping the arm and the program on a safety
event is the controller's part; this class only keeps and changes the modes and publishes the safety messages.
"""
import logging
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .messages import ErrorCodeMessage, SafetyModeMessage
from .vocabulary import (
    CommandRefused,
    JointMode,
    RobotMode,
    SafetyMode,
    UnlockTooEarly,
    frozen_array,
    safety_status_bits,
)

# A protective stop's error code is reported at WARNING level (2; URCL's ReportLevel), as URCL's
# sendScriptBlocking(fail_on_warnings=false) expects of the stop `protective_stop()` raises.
PROTECTIVE_STOP_REPORT_LEVEL = 2

log = logging.getLogger("sim_ursim.controller")

_POWERED = (RobotMode.POWER_ON, RobotMode.IDLE, RobotMode.RUNNING)
AMBIENT_TEMPERATURE = 25.0
POWERED_TEMPERATURE = 32.0
MAIN_VOLTAGE = 48.0
_AMBIENT_TEMPERATURES = frozen_array(np.full(6, AMBIENT_TEMPERATURE))
_POWERED_TEMPERATURES = frozen_array(np.full(6, POWERED_TEMPERATURE))
_JOINT_VOLTAGES = frozen_array(np.full(6, MAIN_VOLTAGE))
_NO_VOLTAGES = frozen_array(np.zeros(6))


class ModeMachine:
    """The arm's robot mode, safety mode and brakes; `publish(message)` sends the safety messages (30001)."""

    def __init__(self, mode_delay: float, unlock_delay: float, publish: Callable[[object], None]):
        self.mode_delay = float(mode_delay)
        self.unlock_delay = float(unlock_delay)
        self._publish = publish
        self.robot_mode = RobotMode.POWER_OFF
        self.safety_mode = SafetyMode.NORMAL
        self.brakes_released = False
        self._pending: tuple[float, int] | None = None  # (sim time, robot mode) of a power-on/brake-release step
        self._protective_stop_at: float | None = None  # time.monotonic() of the last protective stop

    # ------------------------------------------------------------------------------------------------ queries
    @property
    def powered(self) -> bool:
        """True in POWER_ON, IDLE and RUNNING."""
        return self.robot_mode in _POWERED

    @property
    def joint_mode(self) -> int:
        """joint_mode of every joint for the present robot mode."""
        return {RobotMode.RUNNING: JointMode.RUNNING, RobotMode.IDLE: JointMode.IDLE,
                RobotMode.POWER_ON: JointMode.MOTOR_INITIALISATION}.get(self.robot_mode, JointMode.POWER_OFF)

    @property
    def transition_pending(self) -> bool:
        """True while a power-on or brake-release step waits for its time."""
        return self._pending is not None

    def snapshot_fields(self) -> dict[str, Any]:
        """The snapshot fields that follow the modes alone (ControllerState names)."""
        powered, safety = self.powered, self.safety_mode
        return dict(
            robot_mode=self.robot_mode, safety_mode=safety, safety_status=safety,
            safety_status_bits=safety_status_bits(safety), joint_mode=(self.joint_mode,) * 6,
            power_on=powered, brakes_released=self.brakes_released,
            protective_stopped=safety == SafetyMode.PROTECTIVE_STOP,
            emergency_stopped=safety == SafetyMode.ROBOT_EMERGENCY_STOP,
            joint_temperatures=_POWERED_TEMPERATURES if powered else _AMBIENT_TEMPERATURES,
            actual_joint_voltage=_JOINT_VOLTAGES if powered else _NO_VOLTAGES,
            actual_robot_voltage=MAIN_VOLTAGE if powered else 0.0,
        )

    def require_running_normal(self, what: str) -> None:
        """CommandRefused naming `what` unless RUNNING in NORMAL safety mode."""
        if self.robot_mode != RobotMode.RUNNING:
            raise CommandRefused(f"{what} refused: robot mode is {RobotMode.NAMES[self.robot_mode]}, "
                                 "not RUNNING (power on and release the brakes)")
        if self.safety_mode != SafetyMode.NORMAL:
            raise CommandRefused(f"{what} refused: safety mode is {SafetyMode.NAMES[self.safety_mode]}")

    # ------------------------------------------------------------------------------------------------ power
    def power_on(self, now: float) -> None:
        """POWER_OFF → POWER_ON → (mode_delay after sim time `now`) IDLE. Refused during an emergency stop."""
        if self.safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
            raise CommandRefused("cannot power on: the emergency stop is active (release it first)")
        if self.robot_mode == RobotMode.POWER_OFF:
            self._set_robot_mode(RobotMode.POWER_ON)
            self._pending = (now + self.mode_delay, RobotMode.IDLE)

    def brake_release(self, now: float) -> None:
        """Release the brakes: → RUNNING after mode_delay (powering on first from POWER_OFF)."""
        if self.safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
            raise CommandRefused("cannot release brakes: the emergency stop is active")
        if self.robot_mode == RobotMode.RUNNING:
            return
        if self.robot_mode == RobotMode.POWER_OFF:
            self._set_robot_mode(RobotMode.POWER_ON)
        delay = self.mode_delay * (2 if self.robot_mode == RobotMode.POWER_ON else 1)
        self._pending = (now + delay, RobotMode.RUNNING)

    def power_off(self) -> None:
        """Power cut at once: brakes engage, robot mode POWER_OFF, no transition pending."""
        self._pending = None
        self.brakes_released = False
        self._set_robot_mode(RobotMode.POWER_OFF)

    def advance(self, now: float) -> bool:
        """Take the pending transition when sim time `now` reaches it; True when a mode changed."""
        if self._pending is None or now < self._pending[0]:
            return False
        _, target = self._pending
        self._pending = None
        if self.robot_mode == RobotMode.POWER_ON and target == RobotMode.RUNNING:
            # brake release from power-off goes through IDLE like the controller's own sequence
            self._set_robot_mode(RobotMode.IDLE)
            self._pending = (now + self.mode_delay, RobotMode.RUNNING)
            return True
        if target == RobotMode.RUNNING:
            self.brakes_released = True
        self._set_robot_mode(target)
        return True

    # ------------------------------------------------------------------------------------------------ safety
    def enter_protective_stop(self, reason: str, code: tuple = (209, 0)) -> None:
        """PROTECTIVE_STOP now, announced with the error code `code` = (code, argument), C209A0 unless the cause
        has its own (the caller stops the arm and the program)."""
        log.warning("protective stop: %s (C%dA%d)", reason, code[0], code[1])
        self._protective_stop_at = time.monotonic()
        self._set_safety_mode(SafetyMode.PROTECTIVE_STOP)
        self._publish(ErrorCodeMessage(code=code[0], argument=code[1], report_level=PROTECTIVE_STOP_REPORT_LEVEL,
                                       data_type=0, data=0,
                                       text=f"Protective stop: {reason}"))

    def unlock_protective_stop(self, enforce_delay: bool = True) -> None:
        """Back to NORMAL; UnlockTooEarly within unlock_delay of the stop (unless not `enforce_delay`),
        CommandRefused if not protective-stopped."""
        if self.safety_mode != SafetyMode.PROTECTIVE_STOP:
            raise CommandRefused(f"not in protective stop (safety mode {SafetyMode.NAMES[self.safety_mode]})")
        if enforce_delay and time.monotonic() - (self._protective_stop_at or 0.0) < self.unlock_delay:
            raise UnlockTooEarly("Cannot unlock protective stop until 5s after occurrence. "
                                 "Always inspect cause of protective stop before unlocking")
        self._set_safety_mode(SafetyMode.NORMAL)

    def emergency_stop(self) -> bool:
        """ROBOT_EMERGENCY_STOP and power off; False (nothing changes) when it is already active."""
        if self.safety_mode == SafetyMode.ROBOT_EMERGENCY_STOP:
            return False
        self._set_safety_mode(SafetyMode.ROBOT_EMERGENCY_STOP)
        self.power_off()
        return True

    def release_emergency_stop(self) -> bool:
        """Safety NORMAL again after an emergency stop (the arm stays powered off); False when none was active."""
        if self.safety_mode != SafetyMode.ROBOT_EMERGENCY_STOP:
            return False
        self._set_safety_mode(SafetyMode.NORMAL)
        return True

    def _set_robot_mode(self, mode: int) -> None:
        if mode != self.robot_mode:
            log.info("robot mode %s -> %s", RobotMode.NAMES[self.robot_mode], RobotMode.NAMES[mode])
            self.robot_mode = mode

    def _set_safety_mode(self, mode: int) -> None:
        if mode != self.safety_mode:
            log.info("safety mode %s -> %s", SafetyMode.NAMES[self.safety_mode], SafetyMode.NAMES[mode])
            self.safety_mode = mode
            self._publish(SafetyModeMessage(code=0, argument=0, safety_mode_type=mode))
