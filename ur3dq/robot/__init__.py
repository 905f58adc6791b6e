"""The robot driver: `connect(host)` gives a Robot that reads state, and moves the arm only through checked,
watched URScript programs (docs/architecture.md, Contract 4)."""


def connect(host, backend="rtde", model=None, **options):
    """A Robot connected to the controller at `host` through `backend` ('rtde' or 'urx'); use it with `with`.

    `model` (e.g. 'ur3') is checked against what the controller reports; options go to Robot (max_joint_travel,
    connect_timeout, heartbeat=False to send motions without the heartbeat that stops them if ur3dq dies,
    path_check=True or a pathcheck Cell to refuse every motion whose whole path does not pass the path check).
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
