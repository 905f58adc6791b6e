"""ur3dq: dual-quaternion kinematics, a safe driver and a shop-floor CLI for Universal Robots arms."""

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ur3dq.dualquat import DualQuaternion
    from ur3dq.kinematics.models import robot_model
    from ur3dq.program.offline_check import check_program

__all__ = ["DualQuaternion", "check_program", "robot_model"]


def __getattr__(name: str) -> Any:
    # Imported on first use (PEP 562), not with the package: the command line must set its BLAS thread count
    # (ur3dq.cli) before anything here imports numpy.
    if name == "DualQuaternion":
        from ur3dq.dualquat import DualQuaternion
        return DualQuaternion
    if name == "check_program":
        from ur3dq.program.offline_check import check_program
        return check_program
    if name == "robot_model":
        from ur3dq.kinematics.models import robot_model
        return robot_model
    raise AttributeError(f"module 'ur3dq' has no attribute {name!r}")
