"""Cell programs: ordered steps (waypoints, relative waypoints, I/O and wait actions), their resolution and
planning on a model, and the one URScript program that runs them (see docs/store-schema.md for the stored form).

Run a program on a connected robot with `ur3dq.program.run(robot, steps)` (ur3dq.program.runner.run).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ur3dq.program.runner import run


def __getattr__(name: str) -> Any:
    # The runner pulls in the driver's checks and the path check; the store imports the step types of this package
    # and should not load them.
    if name == "run":
        from ur3dq.program.runner import run

        return run
    raise AttributeError(f"module 'ur3dq.program' has no attribute {name!r}")


__all__ = ["run"]
