"""Pure serialiser for the realtime interface (port 30003): one fixed-layout package per control cycle.

A package is `int32 message_size` (total bytes) followed by doubles only; the layout grows with the software
version (docs/protocols.md §4; ur_modern_driver RTState_V3_*; Danish Technological Institute's `get_rt_packet_size`):

    3.0–3.1  1044 bytes                      3.2–3.4  1060 (+ digital outputs, program state)
    3.5–3.9 and 5.0–5.3  1108 (+ elbow position and velocity)
    3.10–3.15 and 5.4–5.10  1116 (+ safety status)
    5.11+  1220 (+ 3 reserved, payload mass, payload CoG, payload inertia)

The 1220-byte layout's first release is not documented publicly; 5.11 is where RTDE gained `payload_inertia`.
"""
import struct

import numpy as np

_SIZE = struct.Struct(">i")


def _since(version: tuple, major: int, minor: int) -> bool:
    """True when `version` is major.minor or later within the same generation (CB3 3.x or e-series 5.x+)."""
    if (int(version[0]) >= 5) != (major >= 5):
        return False
    return (int(version[0]), int(version[1])) >= (major, minor)


def _cb3_or_e_since(version: tuple, cb3_minor: int, e_minor: int) -> bool:
    """True when a CB3 version is at least 3.cb3_minor or an e-series version at least 5.e_minor."""
    return _since(version, 3, cb3_minor) or _since(version, 5, e_minor)


def realtime_fields(version: tuple) -> list[tuple[str, int]]:
    """The realtime package's fields in wire order as (name, number of doubles) for `version`."""
    fields = [
        ("time", 1),
        ("q_target", 6),
        ("qd_target", 6),
        ("qdd_target", 6),
        ("i_target", 6),
        ("m_target", 6),
        ("q_actual", 6),
        ("qd_actual", 6),
        ("i_actual", 6),
        ("i_control", 6),
        ("tool_vector_actual", 6),
        ("tcp_speed_actual", 6),
        ("tcp_force", 6),
        ("tool_vector_target", 6),
        ("tcp_speed_target", 6),
        ("digital_input_bits", 1),
        ("motor_temperatures", 6),
        ("controller_timer", 1),
        ("test_value", 1),
        ("robot_mode", 1),
        ("joint_modes", 6),
        ("safety_mode", 1),
        ("reserved_0", 6),
        ("tool_accelerometer", 3),
        ("reserved_1", 6),
        ("speed_scaling", 1),
        ("linear_momentum_norm", 1),
        ("reserved_2", 2),
        ("v_main", 1),
        ("v_robot", 1),
        ("i_robot", 1),
        ("v_actual", 6),
    ]
    if _cb3_or_e_since(version, 2, 0):
        fields += [("digital_outputs", 1), ("program_state", 1)]
    if _cb3_or_e_since(version, 5, 0):
        fields += [("elbow_position", 3), ("elbow_velocity", 3)]
    if _cb3_or_e_since(version, 10, 4):
        fields += [("safety_status", 1)]
    if _since(version, 5, 11):
        fields += [("reserved_3", 3), ("payload_mass", 1), ("payload_cog", 3), ("payload_inertia", 6)]
    return fields


def realtime_package_size(version: tuple) -> int:
    """Total bytes of one realtime package (the value of its leading int32) for `version`."""
    return _SIZE.size + 8 * sum(count for _, count in realtime_fields(version))


def realtime_values(state) -> dict[str, object]:
    """Every field realtime_fields can name, from a controller snapshot (sim_ursim.vocabulary.ControllerState)."""
    return {
        "time": state.timestamp,
        "q_target": state.target_q,
        "qd_target": state.target_qd,
        "qdd_target": state.target_qdd,
        "i_target": state.target_current,
        "m_target": state.target_moment,
        "q_actual": state.actual_q,
        "qd_actual": state.actual_qd,
        "i_actual": state.actual_current,
        "i_control": state.joint_control_output,
        "tool_vector_actual": state.actual_tcp_pose,
        "tcp_speed_actual": state.actual_tcp_speed,
        "tcp_force": state.actual_tcp_force,
        "tool_vector_target": state.target_tcp_pose,
        "tcp_speed_target": state.target_tcp_speed,
        "digital_input_bits": state.digital_input_bits,
        "motor_temperatures": state.joint_temperatures,
        "controller_timer": 0.0,
        "test_value": 0.0,
        "robot_mode": state.robot_mode,
        "joint_modes": state.joint_mode,
        "safety_mode": state.safety_mode,
        "tool_accelerometer": (0.0, 0.0, 0.0),
        "speed_scaling": state.speed_scaling,
        "linear_momentum_norm": state.actual_momentum,
        "v_main": state.actual_main_voltage,
        "v_robot": state.actual_robot_voltage,
        "i_robot": state.actual_robot_current,
        "v_actual": state.actual_joint_voltage,
        "digital_outputs": state.digital_output_bits,
        "program_state": state.runtime_state,
        "elbow_position": state.elbow_position,
        "elbow_velocity": state.elbow_velocity,
        "safety_status": state.safety_status,
        "payload_mass": state.payload,
        "payload_cog": state.payload_cog,
        "payload_inertia": state.payload_inertia,
    }


def realtime_package(version: tuple, values: dict) -> bytes:
    """Bytes of one realtime package: int32 total size, then every field of `version` as big-endian doubles
    (fields missing from `values`, i.e. the reserved ones, are zeros)."""
    doubles = []
    for name, count in realtime_fields(version):
        value = values.get(name)
        if value is None:
            doubles.extend([0.0] * count)
        elif count == 1:
            doubles.append(float(value))
        else:
            flat = [float(v) for v in np.ravel(value)]
            if len(flat) != count:
                raise ValueError(f"values[{name!r}]: expected {count} numbers, got {len(flat)}")
            doubles.extend(flat)
    return _SIZE.pack(_SIZE.size + 8 * len(doubles)) + struct.pack(f">{len(doubles)}d", *doubles)
