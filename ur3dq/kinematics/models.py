"""The Universal Robots family: DH parameters, joint limits, maximum joint speeds, calibrated DH, and fast FK.

Frames (docs/conventions.md): base = the controller's base frame (DH frame 0; ROS ``base_link`` is this frame
turned π about z), flange = DH frame 6, TCP = flange · tcp. Metres, radians, seconds.

Sources of the numbers:
* DH: docs/conventions.md (checked against ``ur_analytic_ik`` for every model).
* Maximum joint speeds: Universal_Robots_ROS2_Description ``config/<model>/joint_limits.yaml`` (taken from the UR
  user manuals): UR3/UR3e 180°/s base-shoulder-elbow and 360°/s wrists; UR5/UR5e 180°/s every joint; UR10/UR10e/
  UR16e 120°/s base and shoulder, 180°/s the others.
* Joint ranges: ±2π on every joint, as the controller allows (the ROS description's ±π on the elbow is a planning
  restriction, not a controller limit); the wrist 3 of the UR3 and of the UR3e turns without limit: ±inf (UR's
  technical specifications of both: "Wrist 3: Infinite"; the ROS description's ±360° on the UR3e is, again, a
  planning choice). sim_ursim emulates the same limits.
* Maximum joint acceleration: not in the manuals; 40 rad/s² on every joint is what the controller itself reports
  (primary interface Configuration Data, jointMaxAcceleration, URSim dump in docs/protocols.md) and the cap
  ur_rtde puts on ``movej``'s ``a`` (``UR_JOINT_ACCELERATION_MAX``).

FK of a nominal model is the compiled closed form (ur3dq.kinematics.ur_ik.closed_form_poses: joints 2–4 are
parallel, so their rotations add up); a calibrated model (small DH deltas breaking that structure) goes through its
:class:`~ur3dq.kinematics.chain.SerialChain`, the dual-quaternion reference. The kernels (and numba) load on the
first FK or IK call, so building a model (e.g. for a command that only reads the store) does not load them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import JointLimitError
from ur3dq.kinematics import ur_ik
from ur3dq.kinematics.chain import SerialChain, thesis_to_dh_flange
from ur3dq.kinematics.inputs import joint_floats

JOINT_NAMES = ("base", "shoulder", "elbow", "wrist 1", "wrist 2", "wrist 3")
NOMINAL_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
MAX_JOINT_ACCELERATION = 40.0  # rad/s², see the module docstring

_DEG = math.pi / 180.0
# name: (d1, a2, a3, d4, d5, d6), max joint speeds in °/s, wrist 3 unlimited
_FAMILY = {
    "ur3": ((0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819), (180, 180, 180, 360, 360, 360), True),
    "ur5": ((0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823), (180,) * 6, False),
    "ur10": ((0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922), (120, 120, 180, 180, 180, 180), False),
    "ur3e": ((0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921), (180, 180, 180, 360, 360, 360), True),
    "ur5e": ((0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996), (180,) * 6, False),
    "ur10e": ((0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655), (120, 120, 180, 180, 180, 180), False),
    "ur16e": ((0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655), (120, 120, 180, 180, 180, 180), False),
}
MODEL_NAMES = tuple(_FAMILY)
DH_DELTA_KEYS = ("a", "d", "alpha", "theta")
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])   # the flange's own pose as a tool


def _frozen(values: Any) -> np.ndarray:
    """A read-only float copy (model attributes are values that must not change under a cached solver)."""
    array = np.array(values, dtype=float)
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class DHParameters:
    """Standard DH columns of 6 joints: joint i = rz(θ_i + q_i)·tz(d_i)·tx(a_i)·rx(α_i); θ is the joint offset."""

    a: np.ndarray
    d: np.ndarray
    alpha: np.ndarray
    theta: np.ndarray

    @classmethod
    def nominal(cls, name: str) -> DHParameters:
        """The nominal (catalogue) DH of a UR model."""
        d1, a2, a3, d4, d5, d6 = _FAMILY[name][0]
        return cls(
            a=_frozen([0.0, a2, a3, 0.0, 0.0, 0.0]),
            d=_frozen([d1, 0.0, 0.0, d4, d5, d6]),
            alpha=_frozen(NOMINAL_ALPHA),
            theta=_frozen(np.zeros(6)),
        )

    def with_deltas(self, deltas: dict[str, Any]) -> DHParameters:
        """These parameters plus calibration deltas {'a','d','alpha','theta': 6 values each, missing keys = 0}."""
        if not isinstance(deltas, dict):
            raise ValueError(f"dh_deltas: expected a dict with keys {DH_DELTA_KEYS}, got {type(deltas).__name__}")
        unknown = sorted(set(deltas) - set(DH_DELTA_KEYS))
        if unknown:
            raise ValueError(f"dh_deltas: unknown key {unknown[0]!r} (expected some of {', '.join(DH_DELTA_KEYS)})")
        columns = {}
        for key in DH_DELTA_KEYS:
            delta = dqarray.as_array(deltas.get(key, np.zeros(6)), 6, f"dh_deltas[{key!r}]")
            if delta.shape != (6,):
                raise ValueError(f"dh_deltas[{key!r}]: expected 6 values, got shape {delta.shape}")
            columns[key] = _frozen(getattr(self, key) + delta)
        return DHParameters(**columns)

    def is_nominal_structure(self) -> bool:
        """True when a1 = a4 = a5 = a6 = d2 = d3 = 0, α is nominal and θ = 0 exactly (the closed form applies)."""
        return (
            not any(self.a[[0, 3, 4, 5]])
            and not any(self.d[[1, 2]])
            and tuple(self.alpha) == NOMINAL_ALPHA
            and not any(self.theta)
        )


class URModel:
    """A UR arm: DH, limits, speeds, TCP; ``fk``/``fk_batch`` here, IK delegated to :mod:`ur3dq.kinematics.ur_ik`."""

    def __init__(self, name: str, dh: DHParameters, max_joint_speed: Any, joint_lower: Any, joint_upper: Any,
                 max_joint_acceleration: Any = None, tcp: DualQuaternion | None = None, calibrated: bool = False
                 ) -> None:
        """Assemble a model; prefer :func:`robot_model`, which fills every argument from the catalogue."""
        self.name = name
        self.dh = dh
        self.max_joint_speed = _frozen(max_joint_speed)
        self.joint_lower = _frozen(joint_lower)
        self.joint_upper = _frozen(joint_upper)
        acceleration = (MAX_JOINT_ACCELERATION,) * 6 if max_joint_acceleration is None else max_joint_acceleration
        self.max_joint_acceleration = _frozen(acceleration)
        self.tcp = DualQuaternion.identity() if tcp is None else tcp
        self.calibrated = calibrated
        self._closed_form = dh.is_nominal_structure()
        self._tool = np.array(self.tcp.to_array(), dtype=float)   # the TCP's coefficients, as the kernels take them
        # What a calibrated arm's analytic IK starts from before Newton on the full chain: the family's catalogue
        # lengths. A controller's own table cannot serve: UR's factory calibration moves hundreds of metres into
        # cancelling d2/d3 offsets across nearly parallel axes (docs/conventions.md), so its a2, a3 mean nothing.
        # An arm outside the catalogue seeds from its own table.
        nominal = DHParameters.nominal(name) if name in _FAMILY and not self._closed_form else dh
        self.seed_lengths = tuple(float(v) for v in (nominal.d[0], nominal.a[1], nominal.a[2], nominal.d[3],
                                                     nominal.d[4], nominal.d[5]))
        _check_analytic(dh, self.seed_lengths)
        self._flange_chain = SerialChain.from_dh(dh.a, dh.d, dh.alpha, dh.theta)
        self.chain = self._flange_chain.with_tool(self.tcp)
        self._sealed = True

    def __setattr__(self, name: str, value: Any) -> None:
        # Models are values: solvers cache per model object, so a changed TCP or DH must make a new model.
        if getattr(self, "_sealed", False):
            raise AttributeError(f"URModel is immutable; build a new one (with_tcp, robot_model) to change {name!r}")
        object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        calibrated = ", calibrated" if self.calibrated else ""
        return f"URModel({self.name!r}{calibrated}, tcp={self.tcp.to_ur_pose().round(6).tolist()})"

    def with_tcp(self, tcp: Any) -> URModel:
        """The same arm with a TCP offset in the flange frame: a DualQuaternion or a UR pose vector [x,y,z,rx,ry,rz]."""
        if isinstance(tcp, DualQuaternion):
            if not tcp.is_unit():
                raise ValueError("tcp: not a unit dual quaternion (a rigid transform is required)")
            offset = tcp
        else:
            try:
                offset = DualQuaternion.from_ur_pose(tcp)
            except ValueError as error:   # from_ur_pose names its argument "pose"; here it is the TCP
                raise ValueError(f"tcp: {str(error).removeprefix('pose: ')}") from None
        return URModel(self.name, self.dh, self.max_joint_speed, self.joint_lower, self.joint_upper,
                       self.max_joint_acceleration, offset, self.calibrated)

    # ------------------------------------------------------------------------------------------------------ FK
    def fk(self, q: Any) -> DualQuaternion:
        """TCP pose in the base frame at joint angles ``q`` (6, radians)."""
        values = joint_floats(q)
        if not self._closed_form:
            return self.chain.fk_of_floats(values)
        return self._nominal_pose(values, self._tool)

    def _nominal_pose(self, q: tuple[float, ...], tool: np.ndarray) -> DualQuaternion:
        """The pose of ``tool`` (8 coefficients in the flange frame) at 6 validated floats, by the closed form."""
        return DualQuaternion._from_tuple(ur_ik.closed_form_pose(self, q, tool))

    def fk_flange(self, q: Any) -> DualQuaternion:
        """Flange pose (DH frame 6, TCP offset ignored) in the base frame."""
        values = joint_floats(q)
        if not self._closed_form:
            return self._flange_chain.fk_of_floats(values)
        return self._nominal_pose(values, _IDENTITY)

    def fk_errors(self, joints: Any, poses: Any, tcp_offsets: Any) -> tuple[list[float], list[float]]:
        """([metres], [radians]) per row i: how far the TCP pose poses[i] (8,) lies from this arm's FK of joints[i]
        (6,) with the TCP offset tcp_offsets[i] (a UR pose vector in the flange frame) in place of its own; one
        batch per distinct offset (the planners' check of every planned target)."""
        metres, radians = [0.0] * len(poses), [0.0] * len(poses)
        # rows share a few offset objects (all alive in tcp_offsets): their floats once each
        by_object: dict[int, list[int]] = {}
        for index, offset in enumerate(tcp_offsets):
            by_object.setdefault(id(offset), []).append(index)
        groups: dict[tuple[float, ...], list[int]] = {}
        for indices in by_object.values():
            groups.setdefault(tuple(map(float, tcp_offsets[indices[0]])), []).extend(indices)
        for offset, indices in groups.items():
            reached = self.with_tcp(offset).fk_batch(np.array([joints[i] for i in indices]))
            wanted = dqarray.normalise(np.array([poses[i] for i in indices], dtype=float))
            distance = dqarray.pose_distance(reached, wanted)
            for i, m, r in zip(indices, *(values.tolist() for values in distance), strict=False):
                metres[i], radians[i] = m, r
        return metres, radians

    def fk_batch(self, joint_matrix: Any) -> np.ndarray:
        """TCP poses (N, 8) [rw rx ry rz dw dx dy dz] of N joint configurations (N, 6), vectorised over N."""
        joint_matrix = dqarray.as_array(joint_matrix, 6, "joint_matrix")
        if joint_matrix.ndim != 2:
            raise ValueError(f"joint_matrix: expected shape (N, 6), got {joint_matrix.shape}")
        if not self._closed_form:
            return self.chain.fk_batch(joint_matrix)
        return ur_ik.closed_form_poses(self, np.ascontiguousarray(joint_matrix, dtype=float), self._tool)

    def frames(self, q: Any) -> np.ndarray:
        """(7, 8) DH frames 0..6 in the base frame at ``q``; the last one includes the TCP offset."""
        return self.chain.frames(joint_floats(q))

    def joint_axes(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """(directions, points), each (6, 3): joint axes in the base frame at ``q`` (for Jacobians)."""
        return self.chain.joint_axes(joint_floats(q))

    def flange_rotation_at_zero(self) -> DualQuaternion:
        """R0: the flange's orientation at q = 0 (pure rotation); the thesis' end frame is σ_DH(q)·R0*."""
        home = self.fk_flange(np.zeros(6))
        return DualQuaternion.from_rotation_translation(home.rotation, (0.0, 0.0, 0.0))

    def thesis_chain(self, tool_point: Any = (0.0, 0.0, 0.0)) -> SerialChain:
        """The thesis' axis-angle chain (§4.2): axes in the base frame at q = 0, end frame parallel to the base at
        q = 0, and a tool point given in that frame (the thesis' example uses (0, −0.2, 0))."""
        directions, points = self._flange_chain.joint_axes(np.zeros(6))
        flange_home = self._flange_chain.home()
        home = flange_home * thesis_to_dh_flange(flange_home)
        return SerialChain.from_axes(directions, points, home, tool=DualQuaternion.from_translation(tool_point))

    # ------------------------------------------------------------------------------------------------------ IK
    def ik_all(self, pose: Any, q_ref: Any = None) -> list[np.ndarray]:
        """Every FK-verified joint solution of a TCP ``pose``; ``q_ref`` settles the wrist-singular family
        (see ur3dq.kinematics.ur_ik.ik_all)."""
        return ur_ik.ik_all(self, pose, q_ref)

    def ik(self, pose: Any, q_ref: Any, weights: Any = None) -> np.ndarray:
        """The solution (±2π variants within limits) closest to ``q_ref`` (see ur3dq.kinematics.ur_ik.ik)."""
        return ur_ik.ik(self, pose, q_ref, weights)

    def ik_batch(self, poses: Any, q_ref: Any, weights: Any = None) -> np.ndarray:
        """(N, 6) solutions closest to ``q_ref``, NaN rows where unreachable (see ur3dq.kinematics.ur_ik.ik_batch)."""
        return ur_ik.ik_batch(self, poses, q_ref, weights)

    # ------------------------------------------------------------------------------------------------- limits
    def check_joints(self, q: Any) -> np.ndarray:
        """Return ``q`` as an array after checking it: ValueError for shape/NaN, JointLimitError outside limits."""
        values = np.array(joint_floats(q))
        outside = (values < self.joint_lower) | (values > self.joint_upper)
        if outside.any():
            i = int(np.argmax(outside))
            raise JointLimitError(
                f"q: joint {i + 1} ({JOINT_NAMES[i]}) = {values[i]:.6g} rad is outside "
                f"[{self.joint_lower[i]:.6g}, {self.joint_upper[i]:.6g}] of the {self.name}"
            )
        return values


#: How far (rad) a table's α may be from the UR structure (axes 2–4 parallel, the others perpendicular to the axis
#: before) for the analytic IK to serve it: a factory calibration moves α by milliradians (it may also write a
#: perpendicular axis as +π/2 where the catalogue has −π/2, with θ offsets of π).
ALPHA_TOLERANCE = 0.05


def _check_analytic(dh: DHParameters, lengths: tuple[float, ...]) -> None:
    """ValueError saying why, for a table the analytic IK cannot serve: its closed form (``lengths`` = d1, a2, a3,
    d4, d5, d6) divides by a2·a3, and it needs axes 2–4 parallel (α2, α3, α6 within ALPHA_TOLERANCE of 0 or π) and
    axes 2, 5 and 6 perpendicular to the axis before (α1, α4, α5 within it of ±π/2)."""
    for index, name in ((1, "a2"), (2, "a3")):
        if not math.isfinite(lengths[index]) or lengths[index] == 0.0:
            raise ValueError(f"dh: {name} = {lengths[index]:g}: the analytic IK needs a nonzero upper arm (a2) and "
                             "forearm (a3)")
    for joint, (alpha, nominal) in enumerate(zip(dh.alpha, NOMINAL_ALPHA, strict=False)):
        off = abs(math.remainder(float(alpha) - nominal, math.pi))   # ±π/2 alike, 0 and π alike
        if not off <= ALPHA_TOLERANCE:
            raise ValueError(f"dh: α{joint + 1} = {float(alpha):.6g} rad is {off:.3g} rad from the UR structure: the "
                             f"analytic IK needs α2, α3, α6 within {ALPHA_TOLERANCE} rad of 0 or π (axes 2–4 parallel) "
                             "and α1, α4, α5 within it of ±π/2 (each other axis perpendicular to the one before)")


def robot_model(name: str, dh_deltas: dict[str, Any] | None = None) -> URModel:
    """The UR model ``name`` (ur3 ur5 ur10 ur3e ur5e ur10e ur16e, any case), optionally with calibration deltas
    {'a','d','alpha','theta': 6 values} added to the nominal DH as the controller's Kinematics Info reports."""
    if not isinstance(name, str) or name.strip().lower() not in _FAMILY:
        raise ValueError(f"name: unknown robot model {name!r} (known: {', '.join(MODEL_NAMES)})")
    key = name.strip().lower()
    _, speeds_deg, wrist3_unlimited = _FAMILY[key]
    dh = DHParameters.nominal(key)
    calibrated = dh_deltas is not None
    if dh_deltas is not None:
        dh = dh.with_deltas(dh_deltas)
    upper = np.full(6, 2.0 * math.pi)
    if wrist3_unlimited:
        upper[5] = math.inf
    return URModel(key, dh, np.array(speeds_deg) * _DEG, -upper, upper, calibrated=calibrated)


def robot_model_from_dh(name: str, a: Any, d: Any, alpha: Any, theta: Any) -> URModel:
    """The model ``name`` with absolute (calibrated) DH values as the controller reports them (primary interface
    Kinematics Info: DHa, DHd, DHalpha, DHtheta): the deltas from the nominal table are what gets stored."""
    if not isinstance(name, str) or name.strip().lower() not in _FAMILY:
        raise ValueError(f"name: unknown robot model {name!r} (known: {', '.join(MODEL_NAMES)})")
    nominal = DHParameters.nominal(name.strip().lower())
    reported = {"a": a, "d": d, "alpha": alpha, "theta": theta}
    deltas = {}
    for key, values in reported.items():
        values = dqarray.as_array(values, 6, key)
        if values.shape != (6,):
            raise ValueError(f"{key}: expected 6 values, got shape {values.shape}")
        deltas[key] = values - getattr(nominal, key)
    return robot_model(name, dh_deltas=deltas)
