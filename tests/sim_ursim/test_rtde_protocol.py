"""The RTDE wire format, the variable table and the input rules, without sockets."""
import math
import struct

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim_ursim.rtde import inputs, protocol, variables
from sim_ursim.rtde.protocol import PackageType

# ur_rtde 1.6.5's default receive recipe (docs/protocols.md §5.6), rebuilt here from the client's documented behaviour.
BASE37 = ("timestamp target_q target_qd target_qdd target_current target_moment actual_q actual_qd actual_current "
          "joint_control_output actual_TCP_pose actual_TCP_speed actual_TCP_force target_TCP_pose target_TCP_speed "
          "actual_digital_input_bits joint_temperatures actual_execution_time robot_mode joint_mode safety_mode "
          "actual_tool_accelerometer speed_scaling target_speed_fraction actual_momentum actual_main_voltage "
          "actual_robot_voltage actual_robot_current actual_joint_voltage actual_digital_output_bits runtime_state "
          "standard_analog_input0 standard_analog_input1 standard_analog_output0 standard_analog_output1 "
          "robot_status_bits safety_status_bits").split()
LOWER_REGISTERS = (["output_int_register_2"] + [f"output_int_register_{n}" for n in range(12, 20)]
                   + [f"output_double_register_{n}" for n in range(12, 20)])
CB3_3_15 = (3, 15, 8, 106339)
E_5_11 = (5, 11, 1, 108318)

names_strategy = st.lists(st.from_regex(r"[a-z_0-9]{1,30}", fullmatch=True), min_size=1, max_size=40)


def test_package_header_counts_itself_and_carries_the_type():
    package = protocol.pack_package(PackageType.CONTROL_PACKAGE_START)
    assert package == b"\x00\x03S"
    assert protocol.split_package(bytearray(package)) == (PackageType.CONTROL_PACKAGE_START, b"", 3)


def test_split_package_waits_for_the_whole_package():
    package = protocol.pack_protocol_version_request(2)
    assert protocol.split_package(bytearray(package[:4])) is None
    split = protocol.split_package(bytearray(package + b"\x00"))
    assert split == (PackageType.REQUEST_PROTOCOL_VERSION, b"\x00\x02", 5)


def test_split_package_rejects_a_size_smaller_than_the_header():
    with pytest.raises(protocol.ProtocolError, match="smaller than the 3-byte header"):
        protocol.split_package(bytearray(b"\x00\x02V"))


def test_pack_package_refuses_oversized_payload():
    with pytest.raises(ValueError, match="payload"):
        protocol.pack_package(PackageType.TEXT_MESSAGE, b"x" * 70000)


def test_trailing_comma_of_ur_rtde_is_ignored_but_an_inner_empty_name_is_kept():
    assert protocol.parse_variable_names("timestamp,actual_q,") == ["timestamp", "actual_q"]
    assert protocol.parse_variable_names("a,,b") == ["a", "", "b"]


@given(st.sampled_from([1, 2]), st.floats(min_value=1, max_value=500), names_strategy)
def test_setup_outputs_request_round_trip(version, frequency, names):
    package = protocol.pack_setup_outputs_request(names, frequency, version)
    package_type, payload, _ = protocol.split_package(bytearray(package))
    assert package_type == PackageType.CONTROL_PACKAGE_SETUP_OUTPUTS
    parsed_frequency, parsed_names = protocol.parse_setup_outputs_request(payload, version)
    assert parsed_names == names
    assert parsed_frequency == (frequency if version == 2 else None)


def test_setup_outputs_request_protocol_2_layout_is_double_then_names():
    payload = protocol.pack_setup_outputs_request(["timestamp"], 125.0, 2)[3:]
    assert payload == struct.pack(">d", 125.0) + b"timestamp"


def test_names_list_over_2048_bytes_is_accepted_like_a_controller():
    assert len(protocol.parse_setup_inputs_request(b"a," * 1100)) == 1100


@given(st.integers(0, 255), st.lists(st.sampled_from(sorted(protocol.TYPE_CODES) + ["NOT_FOUND"]), min_size=1))
def test_setup_replies_round_trip(recipe_id, types):
    outputs_v2 = protocol.pack_setup_outputs_reply(recipe_id, types, 2)[3:]
    assert protocol.parse_setup_outputs_reply(outputs_v2, 2) == (recipe_id, types)
    outputs_v1 = protocol.pack_setup_outputs_reply(recipe_id, types, 1)[3:]
    assert protocol.parse_setup_outputs_reply(outputs_v1, 1) == (None, types)
    inputs = protocol.pack_setup_inputs_reply(recipe_id, types)[3:]
    assert protocol.parse_setup_inputs_reply(inputs) == (recipe_id, types)


def test_controller_version_reply_is_four_uint32():
    package = protocol.pack_controller_version_reply(3, 15, 8, 106339)
    assert package[:3] == b"\x00\x13v"
    assert protocol.parse_controller_version_reply(package[3:]) == (3, 15, 8, 106339)


def test_accepted_reply_echoes_the_request_type():
    assert protocol.pack_accepted_reply(PackageType.CONTROL_PACKAGE_PAUSE, True) == b"\x00\x04P\x01"
    assert protocol.parse_accepted_reply(b"\x00") is False


def test_recipe_struct_follows_the_rtde_type_sizes():
    layout = protocol.recipe_struct(["BOOL", "UINT8", "UINT32", "UINT64", "INT32", "DOUBLE", "VECTOR3D", "VECTOR6D",
                                     "VECTOR6INT32", "VECTOR6UINT32"])
    assert layout.size == 1 + 1 + 4 + 8 + 4 + 8 + 24 + 48 + 24 + 24


def test_recipe_struct_names_a_type_without_layout():
    with pytest.raises(ValueError, match=r"types\[1\]: 'NOT_FOUND'"):
        protocol.recipe_struct(["DOUBLE", "NOT_FOUND"])


@given(st.integers(0, 255), st.floats(allow_nan=False), st.lists(st.integers(-2**31, 2**31 - 1), min_size=6,
                                                                  max_size=6), st.integers(0, 2**64 - 1))
def test_data_package_round_trip(recipe_id, number, joints, word):
    types = ["DOUBLE", "VECTOR6INT32", "UINT64"]
    layout = protocol.recipe_struct(types)
    flat = [number, *joints, word]
    package = protocol.pack_data_package(layout, recipe_id, flat)
    package_type, payload, _ = protocol.split_package(bytearray(package))
    assert package_type == PackageType.DATA_PACKAGE
    parsed_id, values = protocol.parse_data_package(payload, layout)
    assert parsed_id == recipe_id
    assert protocol.group_values(types, values) == [number, tuple(joints), word]


def test_protocol_1_output_data_package_has_no_recipe_id():
    layout = protocol.recipe_struct(["DOUBLE"])
    package = protocol.pack_data_package(layout, None, [1.5])
    assert package == b"\x00\x0bU" + struct.pack(">d", 1.5)
    assert protocol.parse_data_package(package[3:], layout, has_recipe_id=False) == (None, (1.5,))


def test_data_package_of_the_wrong_size_is_a_protocol_error():
    with pytest.raises(protocol.ProtocolError, match="recipe needs 8"):
        protocol.parse_data_package(b"\x01\x00\x00", protocol.recipe_struct(["DOUBLE"]))


@given(st.text(max_size=100), st.text(max_size=20), st.integers(0, 3))
def test_text_message_protocol_2_round_trip(message, source, level):
    package = protocol.pack_text_message(message, source, level, 2)
    assert protocol.parse_text_message(package[3:], 2) == (message.encode()[:255].decode("utf-8", "replace"),
                                                            source.encode()[:255].decode("utf-8", "replace"), level)


def test_text_message_protocol_1_from_controller_is_level_then_text():
    package = protocol.pack_text_message("hello", "RTDE", protocol.MessageLevel.WARNING, 1)
    assert package == b"\x00\x09M\x02hello"
    assert protocol.parse_text_message(package[3:], 1, from_controller=True) == ("hello", "", 2)


def test_truncated_text_message_is_a_protocol_error():
    with pytest.raises(protocol.ProtocolError, match="shorter"):
        protocol.parse_text_message(b"\x09abc")


@pytest.mark.parametrize("requested, control, decimation", [(125, 125, 1), (500, 500, 1), (125, 500, 4),
                                                            (100, 500, 5), (300, 500, 1), (1000, 500, 1),
                                                            (10, 125, 12), (0.5, 125, 250)])
def test_output_decimation_is_floor_of_rate_ratio_and_caps_at_the_control_rate(requested, control, decimation):
    assert protocol.output_decimation(requested, control) == decimation


@pytest.mark.parametrize("bad", [0, -5, math.nan, math.inf])
def test_output_decimation_rejects_a_bad_frequency(bad):
    assert not protocol.is_valid_frequency(bad)
    with pytest.raises(ValueError, match="frequency"):
        protocol.output_decimation(bad, 125)


# --- the variable table --------------------------------------------------------------------------------------------

def test_every_output_of_ur_rtde_default_recipe_for_3_15_is_found():
    names = BASE37 + ["payload", "payload_cog", "payload_inertia"] + LOWER_REGISTERS
    assert len(names) == 57
    assert [n for n in names if variables.output_type(n, CB3_3_15) == "NOT_FOUND"] == []


def test_every_output_of_ur_rtde_default_recipe_for_5_11_is_found():
    names = BASE37 + ["ft_raw_wrench", "payload", "payload_cog", "payload_inertia"] + LOWER_REGISTERS
    assert len(names) == 58
    assert [n for n in names if variables.output_type(n, E_5_11) == "NOT_FOUND"] == []


@pytest.mark.parametrize("name, version, expected", [
    ("ft_raw_wrench", CB3_3_15, "NOT_FOUND"),  # e-series only
    ("ft_raw_wrench", (5, 8, 0, 0), "NOT_FOUND"),
    ("ft_raw_wrench", (5, 9, 0, 0), "VECTOR6D"),
    ("payload_inertia", (3, 14, 0, 0), "NOT_FOUND"),
    ("payload_inertia", (5, 11, 0, 0), "VECTOR6D"),
    ("payload", (5, 5, 0, 0), "NOT_FOUND"),
    ("payload", (5, 5, 1, 0), "DOUBLE"),
    ("safety_status", (3, 9, 0, 0), "NOT_FOUND"),
    ("safety_status", (3, 10, 0, 0), "INT32"),
    ("output_int_register_24", (3, 8, 0, 0), "NOT_FOUND"),
    ("output_int_register_24", (3, 9, 0, 0), "INT32"),
    ("output_int_register_23", (3, 4, 0, 0), "INT32"),
    ("input_bit_register_64", (5, 3, 0, 0), "BOOL"),
    ("input_bit_register_63", E_5_11, "NOT_FOUND"),  # the bit range 0..63 is only readable as two UINT32 words
    ("output_int_register_48", E_5_11, "NOT_FOUND"),
    ("actual_current_as_torque", E_5_11, "NOT_FOUND"),
    ("actual_current_as_torque", (5, 23, 0, 0), "VECTOR6D"),
    ("tcp_offset", (3, 11, 0, 0), "NOT_FOUND"),
    ("tcp_offset", (3, 12, 0, 0), "VECTOR6D"),
    ("tcp_offset", (5, 5, 1, 0), "VECTOR6D"),
    ("actual_current_window", E_5_11, "VECTOR6D"),  # in URCL's exhaustive CI recipe against URSim 5.9.4
    ("actual_current_window", (5, 8, 0, 0), "NOT_FOUND"),
    ("joint_mode", CB3_3_15, "VECTOR6INT32"),
    ("runtime_state", CB3_3_15, "UINT32"),
    ("no_such_variable", E_5_11, "NOT_FOUND"),
])
def test_output_types_are_version_gated(name, version, expected):
    assert variables.output_type(name, version) == expected


@pytest.mark.parametrize("name, version, expected", [
    ("speed_slider_mask", CB3_3_15, "UINT32"),
    ("tool_digital_output", CB3_3_15, "UINT8"),
    ("input_int_register_47", (3, 8, 0, 0), "NOT_FOUND"),
    ("input_int_register_47", E_5_11, "INT32"),
    ("actual_q", E_5_11, "NOT_FOUND"),  # an output is not an input
])
def test_input_types_are_version_gated(name, version, expected):
    assert variables.input_type(name, version) == expected


def test_the_ros2_driver_output_recipe_is_served_from_3_14_and_5_9():
    """Universal_Robots_ROS2_Driver's resources/rtde_output_recipe.txt (it requires CB3 3.14 / e-series 5.9)."""
    names = ("timestamp actual_q actual_qd speed_scaling target_speed_fraction runtime_state actual_TCP_force "
             "actual_TCP_pose target_TCP_pose tcp_offset actual_digital_input_bits actual_digital_output_bits "
             "standard_analog_input0 standard_analog_input1 standard_analog_output0 standard_analog_output1 "
             "analog_io_types tool_mode tool_analog_input_types tool_analog_input0 tool_analog_input1 "
             "tool_output_voltage tool_output_current tool_temperature robot_mode safety_mode robot_status_bits "
             "safety_status_bits actual_current").split()
    for version in ((3, 14, 0, 0), (5, 9, 0, 0)):
        assert [n for n in names if variables.output_type(n, version) == "NOT_FOUND"] == []


def test_every_output_reader_yields_as_many_values_as_its_type_holds():
    state = _state()
    for variable in variables.OUTPUTS.values():
        values = variable.read(state)
        assert len(values) == len(protocol.TYPE_CODES[variable.type]), variable.name
    layout = protocol.recipe_struct([v.type for v in variables.OUTPUTS.values()])
    layout.pack(*variables.read_flat_values(variables.output_readers(list(variables.OUTPUTS)), state))


def test_bits_to_word_is_lsb_first():
    bits = np.zeros(64, dtype=bool)
    bits[[32, 33, 63]] = True
    assert variables.bits_to_word(bits, 32, 32) == 0b11 | (1 << 31)
    assert variables.bits_to_word(bits, 0, 32) == 0


@pytest.mark.parametrize("pose, expected", [
    ([0, 0, 0, 0, 0, 0], (0, 0, 9.82)),  # tool z up: gravity reaction along +z
    ([0, 0, 0, math.pi, 0, 0], (0, 0, -9.82)),  # tool z down
    ([0, 0, 0, 0, math.pi / 2, 0], (-9.82, 0, 0)),  # tool x axis points along base -z
])
def test_tool_accelerometer_is_gravity_reaction_in_the_tool_frame(pose, expected):
    assert np.allclose(variables.tool_accelerometer(np.array(pose, dtype=float)), expected, atol=1e-12)


# --- input rules ---------------------------------------------------------------------------------------------------

def test_digital_writes_use_the_last_mask_for_a_package_without_one():
    values = {"standard_digital_output_mask": 0b100, "standard_digital_output": 0b100}
    assert inputs.digital_output_writes(values, {"standard_digital_output"}) == {"standard": (0b100, 0b100)}
    assert inputs.digital_output_writes(values, {"speed_slider_mask"}) == {}


def test_speed_slider_applies_only_with_mask_one():
    assert inputs.speed_slider_write({"speed_slider_mask": 1, "speed_slider_fraction": 0.4},
                                     {"speed_slider_fraction"}) == 0.4
    assert inputs.speed_slider_write({"speed_slider_mask": 0, "speed_slider_fraction": 0.4},
                                     {"speed_slider_mask", "speed_slider_fraction"}) is None


def test_analog_writes_follow_mask_and_type_bits():
    values = {"standard_analog_output_mask": 0b01, "standard_analog_output_type": 0b01,
              "standard_analog_output_0": 0.3, "standard_analog_output_1": 123.0}
    assert inputs.analog_output_writes(values, set(values)) == [(0, 0.3, True)]


def test_register_writes_name_bank_kind_and_index():
    values = {"input_int_register_42": 7, "input_double_register_3": 1.5, "input_bit_register_70": True,
              "input_bit_registers32_to_63": 5}
    assert sorted(inputs.register_writes(values, set(values))) == sorted([
        ("int", 42, 7), ("double", 3, 1.5), ("bit", 70, True), ("word", 32, 5)])


# --- helpers -------------------------------------------------------------------------------------------------------

def _state():
    """A ControllerState built by a real controller (Contract 3) in its first cycle."""
    from sim_ursim.controller import Controller

    return Controller(model="ur3").state()
