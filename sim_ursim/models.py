"""Emulated UR arm models and controller software versions.

DH rows are the nominal standard-DH tables of docs/conventions.md; a calibration adds per-joint deltas, as a
real arm's controller does (its primary interface reports the calibrated table in Kinematics Info).
"""
import math
import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)

# name: (d1, a2, a3, d4, d5, d6, robot_type, e_series, max speeds in deg/s for the six joints)
_NOMINAL = {
    "ur3": (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819, 3, False, (180, 180, 180, 360, 360, 360)),
    "ur5": (0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823, 1, False, (180,) * 6),
    "ur10": (0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922, 2, False, (120, 120, 180, 180, 180, 180)),
    "ur3e": (0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921, 3, True, (180, 180, 180, 360, 360, 360)),
    "ur5e": (0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996, 1, True, (180,) * 6),
    "ur10e": (0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655, 2, True, (120, 120, 180, 180, 180, 180)),
    "ur16e": (0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655, 4, True, (120, 120, 180, 180, 180, 180)),
}
MODEL_NAMES = tuple(_NOMINAL)

ROBOT_TYPE_NAMES = {1: "UR5", 2: "UR10", 3: "UR3", 4: "UR16"}

# PolyScope acceleration ceiling reported in ConfigurationData of a URSim 5.24 dump (docs/protocols.md §5.2).
MAX_JOINT_ACCELERATION = 40.0

DH_KEYS = ("a", "d", "alpha", "theta")


class SoftwareVersion(NamedTuple):
    """Controller software version major.minor.bugfix.build, as PolyscopeVersion and the RTDE/primary version report."""

    major: int
    minor: int
    bugfix: int
    build: int

    def __str__(self):
        return f"{self.major}.{self.minor}.{self.bugfix}.{self.build}"

    @property
    def is_e_series(self):
        """True for PolyScope 5.x and later (e-series controllers)."""
        return self.major >= 5

    def at_least(self, major, minor, bugfix=0):
        """True when this version is major.minor.bugfix or newer (build ignored)."""
        return (self.major, self.minor, self.bugfix) >= (major, minor, bugfix)


DEFAULT_CB3_VERSION = SoftwareVersion(3, 15, 8, 106339)
DEFAULT_E_SERIES_VERSION = SoftwareVersion(5, 11, 1, 108318)
_BUILD_DATES = {DEFAULT_CB3_VERSION: "Jun 20 2022", DEFAULT_E_SERIES_VERSION: "Dec 08 2021"}


def parse_version(text):
    """A SoftwareVersion from "M.m", "M.m.b" or "M.m.b.build" (missing parts are 0); ValueError otherwise."""
    if isinstance(text, SoftwareVersion):
        return text
    if not isinstance(text, str) or not re.fullmatch(r"\d+\.\d+(\.\d+){0,2}", text.strip()):
        raise ValueError(f"version must look like 3.15.8 or 5.11.1.108318, got {text!r}")
    parts = [int(p) for p in text.strip().split(".")] + [0, 0]
    version = SoftwareVersion(*parts[:4])
    if version.major not in (3, 5):
        raise ValueError(f"version {text!r}: only CB3 (3.x) and e-series (5.x) controllers are emulated")
    return version


def build_date(version):
    """The build date PolyscopeVersion prints for `version`.

    A fixed plausible date for versions we have no record of.
    """
    return _BUILD_DATES.get(version, "Jan 01 2022")


@dataclass(frozen=True)
class RobotModel:
    """One emulated arm: DH rows (metres, radians), joint limits (rad), max speeds (rad/s) and identity."""

    name: str
    a: np.ndarray
    d: np.ndarray
    alpha: np.ndarray
    theta: np.ndarray
    joint_lower: np.ndarray
    joint_upper: np.ndarray
    max_joint_speed: np.ndarray
    max_joint_acceleration: np.ndarray
    robot_type: int
    e_series: bool
    serial_number: str
    calibrated: bool = False
    dh_deltas: dict = field(default_factory=dict)

    @property
    def display_name(self):
        """The name `get robot model` answers: UR3, UR5, UR10 or UR16 (e-series included, as the controller does)."""
        return ROBOT_TYPE_NAMES[self.robot_type]

    @property
    def dh(self):
        """The (a, d, alpha, theta) arrays of the six standard-DH rows actually used by the simulator's FK."""
        return self.a, self.d, self.alpha, self.theta


def _checked_deltas(calibration):
    """Per-row DH deltas {a,d,alpha,theta: 6 floats}; missing keys are zeros; ValueError names a bad key or length."""
    deltas = {key: np.zeros(6) for key in DH_KEYS}
    for key, values in (calibration or {}).items():
        if key not in DH_KEYS:
            raise ValueError(f"calibration key {key!r} unknown; expected some of {', '.join(DH_KEYS)}")
        array = np.asarray(values, dtype=float)
        if array.shape != (6,) or not np.all(np.isfinite(array)):
            raise ValueError(f"calibration[{key!r}] must be 6 finite numbers, got {values!r}")
        deltas[key] = array
    return deltas


def robot_model(name="ur3", calibration=None, serial_number=None):
    """The emulated model `name` (ur3 ur5 ur10 ur3e ur5e ur10e ur16e), DH = nominal + calibration deltas."""
    key = str(name).lower()
    if key not in _NOMINAL:
        raise ValueError(f"model {name!r} unknown; choose one of {', '.join(MODEL_NAMES)}")
    d1, a2, a3, d4, d5, d6, robot_type, e_series, speeds_deg = _NOMINAL[key]
    deltas = _checked_deltas(calibration)
    # UR3 / UR3e wrist 3 turns without limit (UR specifications: "Wrist 3: Infinite"); every other joint ±2π.
    upper = np.full(6, 2 * math.pi)
    if key in ("ur3", "ur3e"):
        upper[5] = math.inf
    serial = serial_number or f"20{'20' if e_series else '18'}{robot_type}{'5' if e_series else '3'}00001"
    return RobotModel(
        name=key,
        a=np.array([0.0, a2, a3, 0.0, 0.0, 0.0]) + deltas["a"],
        d=np.array([d1, 0.0, 0.0, d4, d5, d6]) + deltas["d"],
        alpha=np.array(ALPHA) + deltas["alpha"],
        theta=np.zeros(6) + deltas["theta"],
        joint_lower=-upper,
        joint_upper=upper,
        max_joint_speed=np.radians(speeds_deg),
        max_joint_acceleration=np.full(6, MAX_JOINT_ACCELERATION),
        robot_type=robot_type,
        e_series=e_series,
        serial_number=serial,
        calibrated=any(np.any(v != 0) for v in deltas.values()),
        dh_deltas=deltas,
    )


def default_version(model):
    """The software version a model runs unless told otherwise: 3.15.8 on CB3 arms, 5.11.1 on e-series."""
    return DEFAULT_E_SERIES_VERSION if model.e_series else DEFAULT_CB3_VERSION


def check_version_fits(model, version):
    """ValueError when a CB3 arm is given a 5.x version or an e-series arm a 3.x one."""
    if model.e_series != version.is_e_series:
        kind = "e-series (5.x)" if model.e_series else "CB3 (3.x)"
        raise ValueError(f"version {version} does not fit model {model.name}: it needs a {kind} version")
