"""ur3dq: dual-quaternion kinematics, a safe driver and a shop-floor CLI for Universal Robots arms."""
from ur3dq.dualquat import DualQuaternion

__all__ = ["DualQuaternion", "robot_model"]


def __getattr__(name):
    # robot_model lives in the kinematics package; loading it lazily keeps `import ur3dq` light and free of cycles.
    if name == "robot_model":
        from ur3dq.kinematics.models import robot_model

        return robot_model
    raise AttributeError(f"module 'ur3dq' has no attribute {name!r}")
