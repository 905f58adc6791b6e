"""ur3dq: dual-quaternion kinematics, a safe driver and a shop-floor CLI for Universal Robots arms."""
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics.models import robot_model

__all__ = ["DualQuaternion", "robot_model"]
