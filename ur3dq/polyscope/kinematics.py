"""The `<kinematics>` of a PolyScope program: which UR model and calibration a program (or a waypoint) was saved
with, the ur3dq model that matches it, and how far another arm would put the TCP at the same joint angles.

A program stores its robot's calibrated standard DH as saved (`deltaTheta`, `a`, `d`, `alpha`, six values each);
PolyScope 5 also keeps one per waypoint. An uncalibrated arm or URSim writes the catalogue values with
`status="NOT_INITIALIZED"`.

>>> from ur3dq.kinematics import robot_model
>>> saved = SavedKinematics.of_model(robot_model("ur5e"))
>>> saved.model_name(), saved.is_nominal()
('ur5e', True)
"""
from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from xml.etree.ElementTree import Element

import numpy as np

from ur3dq import dqarray
from ur3dq.kinematics import MODEL_NAMES, robot_model
from ur3dq.kinematics.chain import SerialChain
from ur3dq.kinematics.models import DHParameters, URModel, robot_model_from_dh

NOMINAL_TOLERANCE = 1e-9     # DH values this close to the catalogue are the catalogue (files round α to 1e-9)
MODEL_TOLERANCE_M = 0.005    # a calibrated arm puts its flange this close to where its model's goes
# where the flanges are compared: stretched out, folded, and wrists turned (each catalogue model differs from every
# other by centimetres in at least one of them)
PROBE_JOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.3, -1.3, 1.4, -1.7, -1.57, 0.4],
                         [-1.0, -2.0, -1.0, 1.0, 1.0, -2.0], [2.0, -0.5, 2.5, 0.5, 2.0, 1.0]])
COLUMNS = ("deltaTheta", "a", "d", "alpha")


@dataclass(frozen=True)
class SavedKinematics:
    """DH columns as a program saved them (each 6 floats): joint offsets θ, a, d, α; and its calibration flags."""

    theta: tuple[float, ...]
    a: tuple[float, ...]
    d: tuple[float, ...]
    alpha: tuple[float, ...]
    status: str = "NOT_INITIALIZED"
    valid_checksum: bool = False

    @classmethod
    def of_model(cls, model: URModel) -> SavedKinematics:
        """The kinematics of a ur3dq model (nominal: PolyScope's uncalibrated form; calibrated: `LINEARIZED`)."""
        dh = model.dh
        theta, a, d, alpha = (tuple(float(v) for v in column) for column in (dh.theta, dh.a, dh.d, dh.alpha))
        return cls(theta, a, d, alpha, status="LINEARIZED" if model.calibrated else "NOT_INITIALIZED")

    @classmethod
    def read(cls, element: Element | None) -> SavedKinematics | None:
        """The kinematics in `element` (`<kinematics>` or a waypoint's `<Kinematics>`); None when absent or
        incomplete (PolyScope 3.x programs may carry none)."""
        if element is None:
            return None
        columns: list[tuple[float, ...]] = []
        for tag in COLUMNS:
            child = element.find(tag)
            try:
                values = tuple(float(part) for part in (child.get("value") or "").split(",")) \
                    if child is not None else ()
            except ValueError:
                return None
            if len(values) != 6 or not all(math.isfinite(v) for v in values):
                return None
            columns.append(values)
        theta, a, d, alpha = columns
        return cls(theta, a, d, alpha, status=element.get("status", "NOT_INITIALIZED"),
                   valid_checksum=element.get("validChecksum", "false").lower() == "true")

    def model_name(self) -> str | None:
        """The catalogue model whose flange these DH put where that model's does (within 5 mm at a few joint
        configurations), or None. (The columns themselves may not resemble the catalogue's: a factory calibration
        trades a2, a3, d2..d4 and θ against each other by up to hundreds of metres.)"""
        return _closest_model(self.theta, self.a, self.d, self.alpha)

    def is_nominal(self, name: str | None = None) -> bool:
        """True when these are the catalogue DH of `name` (default: the model they are closest to)."""
        name = name or self.model_name()
        if name is None:
            return False
        nominal = DHParameters.nominal(name)
        return all(abs(value - float(reference)) <= NOMINAL_TOLERANCE
                   for mine, theirs in ((self.theta, nominal.theta), (self.a, nominal.a), (self.d, nominal.d),
                                        (self.alpha, nominal.alpha))
                   for value, reference in zip(mine, theirs))

    def model(self, name: str) -> URModel:
        """The ur3dq model `name` with these DH: the catalogue model when they are its values, else calibrated."""
        if self.is_nominal(name):
            return robot_model(name)
        return robot_model_from_dh(name, self.a, self.d, self.alpha, self.theta)


@functools.lru_cache(maxsize=64)   # PolyScope 5 repeats the program's kinematics in every waypoint
def _closest_model(theta: tuple[float, ...], a: tuple[float, ...], d: tuple[float, ...],
                   alpha: tuple[float, ...]) -> str | None:
    here = flange_positions(theta, a, d, alpha)
    best, best_error = None, MODEL_TOLERANCE_M
    for name in MODEL_NAMES:
        nominal = DHParameters.nominal(name)
        there = flange_positions(*(tuple(column) for column in (nominal.theta, nominal.a, nominal.d, nominal.alpha)))
        error = float(np.max(np.linalg.norm(here - there, axis=1)))
        if error < best_error:
            best, best_error = name, error
    return best


@functools.lru_cache(maxsize=64)
def flange_positions(theta: tuple[float, ...], a: tuple[float, ...], d: tuple[float, ...],
                     alpha: tuple[float, ...]) -> np.ndarray:
    """(len(PROBE_JOINTS), 3) flange positions of the standard DH columns at PROBE_JOINTS (read-only)."""
    positions = dqarray.translation(SerialChain.from_dh(a, d, alpha, theta).fk_batch(PROBE_JOINTS))
    positions.flags.writeable = False
    return positions


def largest_tcp_difference(saved_on: URModel, other: URModel, joints: Sequence[Sequence[float]],
                           tcp_offsets: Sequence[Sequence[float]]) -> float:
    """The largest distance (m) between the TCP positions the two arms give at the same joint angles, over the
    recorded `joints` (each with its TCP offset); 0 without joints."""
    largest = 0.0
    for q, tcp in zip(joints, tcp_offsets):
        here = saved_on.with_tcp(tcp).fk(q).translation
        there = other.with_tcp(tcp).fk(q).translation
        largest = max(largest, float(np.linalg.norm(np.asarray(here) - np.asarray(there))))
    return largest
