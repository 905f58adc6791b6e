"""The robot driver: `connect(host)` gives a Robot that reads state, and moves the arm only through checked,
watched URScript programs (docs/architecture.md, Contract 4)."""


def connect(host, backend: str="rtde", model=None, **options):
    """A Robot connected to the controller at `host`; use it with `with`.

    Parameters
    ----------
    host : str
        The controller's address (a robot, an official URSim, or `ur3dq sim start`'s address).
    backend : {"rtde", "urx"}
        The state/program backend: ur_rtde or python-urx.
    model : str, optional
        E.g. "ur3": checked against what the controller reports.
    **options
        Passed to Robot: max_joint_travel (rad per move), connect_timeout (s), heartbeat=False (send motions
        without the heartbeat that stops them if ur3dq dies), path_check=True or a pathcheck Cell (refuse every
        motion whose whole path does not pass the path check).

    Examples
    --------
    >>> from ur3dq.robot import connect
    >>> with connect("127.0.0.2") as robot:                          # doctest: +SKIP
    ...     robot.movej([0.0, -1.2, 1.0, -1.4, -1.57, 0.0], v=0.5)
    ...     print(robot.tcp_pose_vector())
    """
    from ur3dq.robot.robot import Robot

    return Robot(host, backend=backend, model=model, **options)


def __getattr__(name):
    # Robot pulls in the kinematics and both client libraries; the pure submodules (script, motion, primary...)
    # stay importable without them.
    if name == "Robot":
        from ur3dq.robot.robot import Robot

        return Robot
    raise AttributeError(f"module 'ur3dq.robot' has no attribute {name!r}")


__all__ = ["connect", "Robot"]
