"""The dashboard server (port 29999) through ur_rtde's DashboardClient: model, power, brakes, protective-stop unlock.

Reply interpretation is kept in pure functions; the Dashboard class only carries the connection.
"""
from __future__ import annotations

import re
from collections.abc import Callable
from typing import Protocol, TypeVar, cast

import dashboard_client

from ur3dq.errors import ProtectiveStopError, RobotConnectionError, RobotError
from ur3dq.robot.primary import model_name

DASHBOARD_PORT = 29999
_MODEL_REPLY = re.compile(r"^\s*(UR\d+)(e)?\s*$", re.IGNORECASE)

_Reply = TypeVar("_Reply")


class DashboardClientProtocol(Protocol):
    """What ur3dq uses of ur_rtde's dashboard_client.DashboardClient (signatures as its bindings document them)."""

    def connect(self, timeout_ms: int = 2000) -> None: ...
    def isConnected(self) -> bool: ...
    def disconnect(self) -> None: ...
    def send(self, command: str) -> None: ...
    def receive(self) -> str: ...
    def getRobotModel(self) -> str: ...
    def powerOn(self) -> None: ...
    def powerOff(self) -> None: ...
    def brakeRelease(self) -> None: ...


def model_from_reply(reply: str | None, major_version: int) -> str:
    """The ur3dq model name of a `get robot model` reply ('UR3' → 'ur3', or 'ur3e' on a 5.x controller)."""
    match = _MODEL_REPLY.match(reply or "")
    if not match:
        raise RobotError(f"dashboard 'get robot model' answered {reply!r}, not a UR model name")
    name = match.group(1).lower()
    if name == "ur16" or match.group(2) or major_version >= 5:
        return name + "e"
    return name


def identified_model(reply: str, major_version: int, robot_type: int | None, requested: str | None) -> str:
    """The model name of a `get robot model` reply, checked against Configuration Data's robotType (None: not sent)
    and the model the user asked for (None: any); RobotError if they disagree."""
    identified = model_from_reply(reply, major_version)
    if robot_type is not None:
        from_configuration = model_name(robot_type, major_version)
        if from_configuration != identified:
            raise RobotError(f"the dashboard says {identified} but Configuration Data says {from_configuration}")
    if requested is not None and requested.lower() != identified:
        raise RobotError(f"model {requested!r} was requested but the controller is a {identified}")
    return identified


def serial_from_reply(reply: str | None) -> str | None:
    """The serial number in a `get serial number` reply (digits, e.g. '20185500000'), or None if it holds none."""
    text = (reply or "").strip()
    return text if text.isdigit() else None


def program_command_refusal(reply: str, success_prefix: str) -> str | None:
    """None if a `pause` / `play` reply starts with `success_prefix` ('Pausing program', 'Starting program'), else
    the controller's reply (its reason)."""
    if reply.strip().lower().startswith(success_prefix.lower()):
        return None
    return reply.strip() or "no reply"


def unlock_refusal(reply: str) -> str | None:
    """None if an `unlock protective stop` reply means success, else the controller's reason (str)."""
    if reply.strip().lower().startswith("protective stop releasing"):
        return None
    return reply.strip() or "no reply"


class Dashboard:
    """A ur_rtde DashboardClient connected to `host`, reconnected once when a command finds it dropped."""

    def __init__(self, host: str, port: int = DASHBOARD_PORT, timeout_ms: int = 2500) -> None:
        self.host, self.port, self._timeout_ms = host, port, timeout_ms
        self._client = self._connected_client()

    def robot_model_reply(self) -> str:
        """The raw reply to `get robot model` (e.g. 'UR3')."""
        return self._call(lambda client: client.getRobotModel())

    def serial_number(self) -> str | None:
        """The controller's serial number, or None where the dashboard has no such command (before PolyScope 5.6)."""
        return serial_from_reply(self._ask("get serial number"))

    def program_state(self) -> str:
        """The reply to `programState`: the runtime state and the loaded program ('PLAYING prog.urp')."""
        return str(self._ask("programState")).strip()

    def power_on(self) -> None:
        """Send `power on` (the caller watches the robot mode reach IDLE)."""
        self._call(lambda client: client.powerOn())

    def power_off(self) -> None:
        """Send `power off` (the caller watches the robot mode reach POWER_OFF)."""
        self._call(lambda client: client.powerOff())

    def brake_release(self) -> None:
        """Send `brake release` (the caller watches the robot mode reach RUNNING)."""
        self._call(lambda client: client.brakeRelease())

    def unlock_protective_stop(self) -> None:
        """Send `unlock protective stop`; ProtectiveStopError with the controller's reason if it refuses."""
        reply = self._ask("unlock protective stop")
        refusal = unlock_refusal(reply)
        if refusal is not None:
            raise ProtectiveStopError(f"the controller refused to unlock the protective stop: {refusal}")

    def pause(self) -> None:
        """Send `pause`; RobotError with the controller's reply if it refuses (no program running)."""
        refusal = program_command_refusal(self._ask("pause"), "Pausing program")
        if refusal is not None:
            raise RobotError(f"the controller refused to pause: {refusal}")

    def play(self) -> None:
        """Send `play` (resumes a paused program, or starts the loaded one: send it only to a paused program);
        RobotError with the controller's reply if it refuses."""
        refusal = program_command_refusal(self._ask("play"), "Starting program")
        if refusal is not None:
            raise RobotError(f"the controller refused to resume: {refusal}")

    def close(self) -> None:
        """Disconnect (idempotent)."""
        try:
            self._client.disconnect()
        except RuntimeError:
            pass

    def _ask(self, command: str) -> str:
        """The reply line to one dashboard `command`, sent as is (for commands ur_rtde gates or interprets itself)."""
        def ask(client: DashboardClientProtocol) -> str:
            client.send(command + "\n")
            return client.receive()

        return self._call(ask)

    def _connected_client(self) -> DashboardClientProtocol:
        """A new DashboardClient that has read the server's greeting."""
        # ur_rtde ships no type information: the client is typed by the Protocol above from here on.
        client = cast(DashboardClientProtocol, dashboard_client.DashboardClient(self.host, self.port))
        try:
            client.connect(self._timeout_ms)
        except UnicodeDecodeError:
            raise RobotConnectionError(f"the dashboard server at {self.host}:{self.port} sent a greeting that is "
                                       "not text: is it a UR controller?") from None
        except RuntimeError as error:
            raise RobotConnectionError(f"cannot reach the dashboard server at {self.host}:{self.port}: {error}") \
                from None
        return client

    def _call(self, command: Callable[[DashboardClientProtocol], _Reply]) -> _Reply:
        """command(client), retried once on a fresh connection if the old one was dropped (dashboard commands
        are idempotent: sending one twice leaves the controller as sending it once)."""
        if self._client.isConnected():
            try:
                return command(self._client)
            except UnicodeDecodeError:
                raise self._garbage_error() from None
            except RuntimeError:
                pass
        self.close()
        self._client = self._connected_client()
        try:
            return command(self._client)
        except UnicodeDecodeError:
            raise self._garbage_error() from None
        except RuntimeError as error:
            raise RobotConnectionError(f"dashboard command to {self.host} failed: {error}") from None

    def _garbage_error(self) -> RobotError:
        """The error for a dashboard reply that is not text (ur_rtde decodes it as UTF-8 and fails)."""
        return RobotError(f"the dashboard server at {self.host}:{self.port} answered with bytes that are not text")
