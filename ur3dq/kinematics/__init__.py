"""Kinematics of serial arms on dual quaternions: chains, the UR family, analytic and numerical IK."""
from ur3dq.kinematics.chain import SerialChain
from ur3dq.kinematics.models import MODEL_NAMES, DHParameters, URModel, robot_model, robot_model_from_dh

__all__ = ["MODEL_NAMES", "DHParameters", "SerialChain", "URModel", "robot_model", "robot_model_from_dh"]
