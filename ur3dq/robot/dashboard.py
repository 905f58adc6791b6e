"""The dashboard server (port 29999) through ur_rtde's DashboardClient: model, power, brakes, protective-stop unlock.

Reply interpretation is kept in pure functions; the Dashboard class only carries the connection.
"""
import re

import dashboard_client

from ur3dq.errors import ProtectiveStopError, RobotConnectionError, RobotError

DASHBOARD_PORT = 29999
_MODEL_REPLY = re.compile(r"^\s*(UR\d+)(e)?\s*$", re.IGNORECASE)


def model_from_reply(reply, major_version):
    """The ur3dq model name of a `get robot model` reply ('UR3' → 'ur3', or 'ur3e' on a 5.x controller)."""
    match = _MODEL_REPLY.match(reply or "")
    if not match:
        raise RobotError(f"dashboard 'get robot model' answered {reply!r}, not a UR model name")
    name = match.group(1).lower()
    if name == "ur16" or match.group(2) or major_version >= 5:
        return name + "e"
    return name


def unlock_refusal(reply):
    """None if an `unlock protective stop` reply means success, else the controller's reason (str)."""
    if reply.strip().lower().startswith("protective stop releasing"):
        return None
    return reply.strip() or "no reply"


class Dashboard:
    """A ur_rtde DashboardClient connected to `host`; `close()` disconnects."""

    def __init__(self, host, port=DASHBOARD_PORT, timeout_ms=2500):
        self._client = dashboard_client.DashboardClient(host, port)
        try:
            self._client.connect(timeout_ms)
        except RuntimeError as error:
            raise RobotConnectionError(f"cannot reach the dashboard server at {host}:{port}: {error}") from None

    def robot_model_reply(self):
        """The raw reply to `get robot model` (e.g. 'UR3')."""
        return self._call(self._client.getRobotModel)

    def power_on(self):
        """Send `power on` (the caller watches the robot mode reach IDLE)."""
        self._call(self._client.powerOn)

    def brake_release(self):
        """Send `brake release` (the caller watches the robot mode reach RUNNING)."""
        self._call(self._client.brakeRelease)

    def power_off(self):
        """Send `power off`."""
        self._call(self._client.powerOff)

    def unlock_protective_stop(self):
        """Send `unlock protective stop`; ProtectiveStopError with the controller's reason if it refuses."""
        try:
            self._client.send("unlock protective stop\n")
            reply = self._client.receive()
        except RuntimeError as error:
            raise RobotConnectionError(f"dashboard connection failed: {error}") from None
        refusal = unlock_refusal(reply)
        if refusal is not None:
            raise ProtectiveStopError(f"the controller refused to unlock the protective stop: {refusal}")

    def close(self):
        """Disconnect (idempotent)."""
        try:
            self._client.disconnect()
        except RuntimeError:
            pass

    def _call(self, method):
        """Call a DashboardClient method, turning its transport errors into RobotConnectionError."""
        try:
            return method()
        except RuntimeError as error:
            raise RobotConnectionError(f"dashboard connection failed: {error}") from None
