"""The contract between the Robot facade and its state/program backends (RTDEBackend, URXBackend), and the model
and speed limits the driver takes from the controller."""
from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from ur3dq.kinematics import robot_model_from_dh
from ur3dq.robot import state
from ur3dq.robot.io_state import IOState
from ur3dq.robot.primary import ConfigurationData, KinematicsInfo
from ur3dq.robot.primary_client import PrimaryClient

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel


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


def calibrated_model(name: str, kinematics: KinematicsInfo, tcp_offset: np.ndarray | None = None) -> URModel:
    """The ur3dq model `name` with the controller's calibrated DH and (if given) its TCP offset (UR pose vector)."""
    model = robot_model_from_dh(name, kinematics.a, kinematics.d, kinematics.alpha, kinematics.theta)
    return model.with_tcp(tcp_offset) if tcp_offset is not None else model


def effective_speed_limits(model: URModel, configuration: ConfigurationData | None) -> tuple[np.ndarray, np.ndarray]:
    """(max joint acceleration, max joint speed) arrays: the lower of the model's and the controller's values."""
    if configuration is None:
        return np.asarray(model.max_joint_acceleration, float), np.asarray(model.max_joint_speed, float)
    return (np.minimum(model.max_joint_acceleration, configuration.max_joint_acceleration),
            np.minimum(model.max_joint_speed, configuration.max_joint_speed))
