"""Realtime (30003) package bytes: sizes per version, urx 0.11's own unpacking, field offsets of the documented
layout (docs/protocols.md §4), elbow kinematics checked by hand."""
import struct

import numpy as np
import pytest
from urx.urrtmon import URRTMonitor

from sim_ursim.primary import realtime
from test_primary_packets import snapshot


def package(version, state=None):
    return realtime.realtime_package(version, realtime.realtime_values(state or snapshot()))


@pytest.mark.parametrize(
    "version, size",
    [
        ((3, 0, 0, 0), 1044),
        ((3, 1, 0, 0), 1044),
        ((3, 2, 0, 0), 1060),
        ((3, 4, 0, 0), 1060),
        ((3, 5, 0, 0), 1108),
        ((3, 9, 0, 0), 1108),
        ((3, 10, 0, 0), 1116),
        ((3, 15, 8, 0), 1116),
        ((5, 0, 0, 0), 1108),
        ((5, 4, 0, 0), 1116),
        ((5, 11, 1, 0), 1220),
    ],
)
def test_package_size_per_version(version, size):
    data = package(version)
    assert len(data) == size == realtime.realtime_package_size(version)
    assert struct.unpack_from(">i", data)[0] == size


def test_urx_realtime_struct_reads_time_joints_force_and_target_tool_vector():
    state = snapshot()
    data = package((3, 15, 8, 0), state)
    values = URRTMonitor.rtstruct692.unpack(data[4:4 + URRTMonitor.rtstruct692.size])
    assert values[0] == state.timestamp
    assert list(values[1:7]) == list(state.target_q)
    assert list(values[31:37]) == list(state.actual_q)
    assert list(values[67:73]) == list(state.actual_tcp_force)
    assert list(values[73:79]) == list(state.target_tcp_pose)


def doubles(data):
    return struct.unpack(f">{(len(data) - 4) // 8}d", data[4:])


def test_documented_offsets_of_the_3_15_package():
    state = snapshot(robot_mode=5, safety_mode=3, safety_status=3, runtime_state=2, speed_scaling=0.5,
                     digital_output_bits=0x103)
    values = doubles(package((3, 15, 8, 0), state))
    assert list(values[55:61]) == list(state.actual_tcp_pose)  # field 11, tool vector actual
    assert values[85] == state.digital_input_bits
    assert list(values[86:92]) == list(state.joint_temperatures)
    assert values[94] == 5  # robot mode
    assert list(values[95:101]) == [253.0] * 6
    assert values[101] == 3  # safety mode
    assert values[117] == 0.5  # speed scaling
    assert values[130] == 0x103  # digital outputs
    assert values[131] == 2  # program state = runtime state PLAYING
    assert values[138] == 3  # safety status (3.10+)


def test_e_series_5_11_appends_payload():
    state = snapshot(payload=1.25, payload_cog=np.array([0.01, 0.02, 0.03]), payload_inertia=np.arange(6.0))
    values = doubles(package((5, 11, 1, 0), state))
    assert values[142] == 1.25
    assert list(values[143:146]) == [0.01, 0.02, 0.03]
    assert list(values[146:152]) == list(range(6))


def test_elbow_fields_follow_program_state_from_3_5():
    state = snapshot()
    values = doubles(package((3, 5, 0, 0), state))
    assert list(values[132:135]) == list(state.elbow_position)
    assert list(values[135:138]) == list(state.elbow_velocity)


def test_a_vector_of_the_wrong_length_is_named():
    values = realtime.realtime_values(snapshot())
    values["q_actual"] = [0.0] * 5
    with pytest.raises(ValueError, match="q_actual"):
        realtime.realtime_package((3, 15, 8, 0), values)
