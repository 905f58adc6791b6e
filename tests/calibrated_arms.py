"""Calibrated arms for the IK tests: the factory-style tables real controllers report (sim_ursim.calibration) and
random configurations kept off the singularities, shared by the tests of every calibrated IK path."""
import math

import numpy as np

from sim_ursim.calibration import factory_calibration
from sim_ursim.models import robot_model as simulated_model
from ur3dq.kinematics import robot_model, robot_model_from_dh


def factory_model(name: str, seed: int):
    """The ur3dq model of a controller reporting sim_ursim's factory-style table for arm ``name``."""
    nominal = robot_model(name).dh
    deltas = factory_calibration(simulated_model(name).dh, seed)
    absolute = {key: np.asarray(getattr(nominal, key)) + deltas[key] for key in ("a", "d", "alpha", "theta")}
    return robot_model_from_dh(name, **absolute)


def random_configurations(count: int, seed: int) -> np.ndarray:
    """Joint vectors kept 0.05 rad away from the wrist and elbow singularities (where branches merge)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-math.pi, math.pi, (4 * count, 6))
    regular = (np.abs(np.sin(q[:, 4])) > 0.05) & (np.abs(np.sin(q[:, 2])) > 0.05)
    return q[regular][:count]
