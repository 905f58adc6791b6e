"""The robot driver: `connect(host)` gives a Robot that reads state, and moves the arm only through checked,
watched URScript programs (docs/architecture.md, Contract 4)."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ur3dq.pathcheck import Cell
    from ur3dq.robot.robot import Robot


def connect(host: str, backend: str = "rtde", model: str | None = None, max_joint_travel: float = math.pi,
            connect_timeout: float = 3.0, heartbeat: bool = True, path_check: bool | Cell | None = None) -> Robot:
    """A Robot connected to the controller at `host`; use it with `with` (it closes its connections).

    Parameters
    ----------
    host : str
        The controller's address (a robot, an official URSim, or `ur3dq sim start`'s simulator).
    backend : {"rtde", "urx"}
        The client library for state and programs: ur_rtde (default) or urx.
    model : str, optional
        e.g. "ur3": checked against what the controller reports (RobotError if it differs).
    max_joint_travel : float
        The largest joint travel one move may ask for (rad); a longer one is refused before it is sent.
    connect_timeout : float
        Seconds to wait for the controller's first state.
    heartbeat : bool
        Arm every program that moves or frees the arm on the controller's RTDE watchdog, so the arm stops within
        0.1 s if this process dies (default). False only where another client holds the RTDE input registers.
    path_check : bool or Cell, optional
        True (or a ur3dq.pathcheck Cell) refuses every motion whose whole path does not pass the path check (in
        that cell).

    Examples
    --------
    >>> from ur3dq.robot import connect
    >>> with connect("127.0.0.2") as robot:          # doctest: +SKIP
    ...     robot.movej([0.0, -1.2, 1.0, -1.4, -1.57, 0.0], v=0.5)
    """
    from ur3dq.robot.robot import Robot

    return Robot(host, backend=backend, model=model, max_joint_travel=max_joint_travel,
                 connect_timeout=connect_timeout, heartbeat=heartbeat, path_check=path_check)


def __getattr__(name: str) -> Any:
    # Robot pulls in the kinematics and both client libraries; the pure submodules (script, motion, primary...)
    # stay importable without them.
    if name == "Robot":
        from ur3dq.robot.robot import Robot

        return Robot
    raise AttributeError(f"module 'ur3dq.robot' has no attribute {name!r}")


__all__ = ["connect", "Robot"]
