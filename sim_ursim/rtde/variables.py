"""Every RTDE variable: official name, type, the software version that introduced it, and where its value lives.

Names, types and versions follow UR's RTDE guide ("Introduced in version" column) and URCL's type list, as
collected in docs/protocols.md §5.4 / §5.5. A version pair (CB3, e-series) of None means the platform never had it.
An output reader maps a ControllerState (Contract 3) to the variable's flat values, in wire order.
Names UR's guide lists without a version get the earliest version a source shows them present (comments below;
docs/ursim.md); quantities the simulator does not model (TCP acceleration, energy, encoders) read as the constant of
an idle, contact-free cell.
"""
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim_ursim.kinematics import rotation_vector_to_matrix

Version3 = tuple[int, int, int]
RTDE_FIRST = ((3, 4, 0), (5, 0, 0))  # RTDE exists since CB3 3.4 and on every e-series version
UPPER_REGISTERS = ((3, 9, 0), (5, 3, 0))
STANDARD_GRAVITY = 9.82  # m/s²: URScript set_gravity's default vector is [0, 0, 9.82] (base frame, pointing up)


@dataclass(frozen=True)
class Variable:
    """One RTDE field: official name, RTDE type name, and the (CB3, e-series) versions that introduced it."""

    name: str
    type: str
    introduced_cb3: Version3 | None
    introduced_e_series: Version3 | None
    read: Callable | None = None  # outputs only: read(state) -> sequence of flat values in wire order

    def available_in(self, version):
        """True when a controller running `version` (major, minor, bugfix, ...) offers this variable."""
        introduced = self.introduced_e_series if version[0] >= 5 else self.introduced_cb3
        return introduced is not None and tuple(version[:3]) >= introduced


# --- readers: each returns the variable's values flattened, as Python numbers --------------------------------------

def _vector(field):
    """Reader of a state array field (VECTOR3D/6D) as a list of floats."""
    return lambda state: getattr(state, field).tolist()


def _double(field):
    """Reader of a float state field."""
    return lambda state: (float(getattr(state, field)),)


def _integer(field):
    """Reader of an integer/bit-word state field."""
    return lambda state: (int(getattr(state, field)),)


def _constant(*values):
    """Reader of a quantity the simulator does not model (euromap, tool power); the nominal value of an idle cell."""
    return lambda state: values


def _register(field, index, cast):
    """Reader of one element of a register bank (input/output int/double/bit registers)."""
    return lambda state: (cast(getattr(state, field)[index]),)


def bits_to_word(bits, first, count):
    """uint of `count` booleans bits[first:first+count], bit 0 = bits[first] (LSB first)."""
    word = 0
    for offset in range(count):
        if bits[first + offset]:
            word |= 1 << offset
    return word


def _bit_word(field, first):
    """Reader of 32 bit registers packed into a UINT32 (bit 0 = register `first`)."""
    return lambda state: (bits_to_word(getattr(state, field), first, 32),)


def tool_accelerometer(tcp_pose, gravity=STANDARD_GRAVITY):
    """Accelerometer of a resting tool in the TCP frame.

    The gravity reaction (0, 0, +g in base) rotated into the tool.
    """
    rotation = rotation_vector_to_matrix(tcp_pose[3:6])
    return tuple((rotation.T @ np.array([0.0, 0.0, gravity])).tolist())


class _ToolAccelerometer:
    """Reader of actual_tool_accelerometer, recomputed only when the snapshot carries a new TCP pose array.

    Snapshot arrays are read-only and the controller reuses the same array while the arm rests, so identity is a
    safe cache key (the cached array is kept referenced, so its id cannot be reused).
    """

    def __init__(self):
        self._cache = (None, None)  # (pose array, values): one tuple, swapped atomically between streamer threads

    def __call__(self, state):
        pose = state.actual_tcp_pose
        cached_pose, values = self._cache
        if pose is not cached_pose:
            values = tool_accelerometer(pose)
            self._cache = (pose, values)
        return values


def _tcp_force_scalar(state):
    return (float(np.linalg.norm(state.actual_tcp_force[:3])),)


def _powered(on_value, off_value=0.0):
    """Reader of a quantity the controller does not model that exists only while the arm is powered."""
    return lambda state: (on_value if state.power_on else off_value,)


def _tool_mode(state):
    # Tool board mode follows the arm's power: 253 RUNNING when powered, 239 POWER_OFF otherwise (primary §3.5).
    return (253 if state.power_on else 239,)


def _gravity(state):
    # Same convention as set_gravity: the vector opposite to free fall, in the base frame (the base stands upright).
    return (0.0, 0.0, STANDARD_GRAVITY)


# --- the tables ----------------------------------------------------------------------------------------------------

def _out(name, type_name, read, introduced=RTDE_FIRST):
    return Variable(name, type_name, introduced[0], introduced[1], read)


_OUTPUT_LIST = [
    _out("timestamp", "DOUBLE", _double("timestamp")),
    _out("target_q", "VECTOR6D", _vector("target_q")),
    _out("target_qd", "VECTOR6D", _vector("target_qd")),
    _out("target_qdd", "VECTOR6D", _vector("target_qdd")),
    _out("target_current", "VECTOR6D", _vector("target_current")),
    _out("target_moment", "VECTOR6D", _vector("target_moment")),
    _out("actual_q", "VECTOR6D", _vector("actual_q")),
    _out("actual_qd", "VECTOR6D", _vector("actual_qd")),
    _out("actual_current", "VECTOR6D", _vector("actual_current")),
    _out("joint_control_output", "VECTOR6D", _vector("joint_control_output")),
    _out("actual_TCP_pose", "VECTOR6D", _vector("actual_tcp_pose")),
    _out("actual_TCP_speed", "VECTOR6D", _vector("actual_tcp_speed")),
    _out("actual_TCP_force", "VECTOR6D", _vector("actual_tcp_force")),
    _out("target_TCP_pose", "VECTOR6D", _vector("target_tcp_pose")),
    _out("target_TCP_speed", "VECTOR6D", _vector("target_tcp_speed")),
    _out("actual_digital_input_bits", "UINT64", _integer("digital_input_bits")),
    _out("joint_temperatures", "VECTOR6D", _vector("joint_temperatures")),
    _out("actual_execution_time", "DOUBLE", _double("execution_time")),
    _out("robot_mode", "INT32", _integer("robot_mode")),
    _out("joint_mode", "VECTOR6INT32", lambda state: tuple(int(mode) for mode in state.joint_mode)),
    _out("safety_mode", "INT32", _integer("safety_mode")),
    _out("safety_status", "INT32", _integer("safety_status"), ((3, 10, 0), (5, 4, 0))),
    _out("actual_tool_accelerometer", "VECTOR3D", _ToolAccelerometer()),
    _out("speed_scaling", "DOUBLE", _double("speed_scaling")),
    _out("target_speed_fraction", "DOUBLE", _double("target_speed_fraction")),
    _out("actual_momentum", "DOUBLE", _double("actual_momentum")),
    _out("actual_main_voltage", "DOUBLE", _double("actual_main_voltage")),
    _out("actual_robot_voltage", "DOUBLE", _double("actual_robot_voltage")),
    _out("actual_robot_current", "DOUBLE", _double("actual_robot_current")),
    _out("actual_joint_voltage", "VECTOR6D", _vector("actual_joint_voltage")),
    _out("actual_digital_output_bits", "UINT64", _integer("digital_output_bits")),
    _out("runtime_state", "UINT32", _integer("runtime_state")),
    _out("elbow_position", "VECTOR3D", _vector("elbow_position"), ((3, 5, 0), (5, 0, 0))),
    _out("elbow_velocity", "VECTOR3D", _vector("elbow_velocity"), ((3, 5, 0), (5, 0, 0))),
    _out("robot_status_bits", "UINT32", _integer("robot_status_bits")),
    _out("safety_status_bits", "UINT32", _integer("safety_status_bits")),
    _out("analog_io_types", "UINT32", _integer("analog_io_types")),
    _out("standard_analog_input0", "DOUBLE", _double("standard_analog_input0")),
    _out("standard_analog_input1", "DOUBLE", _double("standard_analog_input1")),
    _out("standard_analog_output0", "DOUBLE", _double("standard_analog_output0")),
    _out("standard_analog_output1", "DOUBLE", _double("standard_analog_output1")),
    _out("io_current", "DOUBLE", _powered(0.03)),
    _out("euromap67_input_bits", "UINT32", _constant(0)),
    _out("euromap67_output_bits", "UINT32", _constant(0)),
    _out("euromap67_24V_voltage", "DOUBLE", _constant(0.0)),
    _out("euromap67_24V_current", "DOUBLE", _constant(0.0)),
    _out("tool_mode", "UINT32", _tool_mode),
    _out("tool_analog_input_types", "UINT32", _constant(0)),
    _out("tool_analog_input0", "DOUBLE", _double("tool_analog_input0")),
    _out("tool_analog_input1", "DOUBLE", _double("tool_analog_input1")),
    _out("tool_output_voltage", "INT32", _constant(0)),
    _out("tool_output_current", "DOUBLE", _constant(0.0)),
    _out("tool_temperature", "DOUBLE", lambda state: (float(state.joint_temperatures[5]),)),
    _out("tcp_force_scalar", "DOUBLE", _tcp_force_scalar),
    _out("output_bit_registers0_to_31", "UINT32", _bit_word("output_bit_registers", 0)),
    _out("output_bit_registers32_to_63", "UINT32", _bit_word("output_bit_registers", 32)),
    _out("input_bit_registers0_to_31", "UINT32", _bit_word("input_bit_registers", 0)),
    _out("input_bit_registers32_to_63", "UINT32", _bit_word("input_bit_registers", 32)),
    _out("tool_output_mode", "UINT8", _constant(0)),
    _out("tool_digital_output0_mode", "UINT8", _constant(1)),
    _out("tool_digital_output1_mode", "UINT8", _constant(1)),
    _out("payload", "DOUBLE", _double("payload"), ((3, 11, 0), (5, 5, 1))),
    _out("payload_cog", "VECTOR3D", _vector("payload_cog"), ((3, 11, 0), (5, 5, 1))),
    _out("payload_inertia", "VECTOR6D", _vector("payload_inertia"), ((3, 15, 0), (5, 11, 0))),
    # Missing from UR's guide; URCL's maintainers state it exists from 3.12.0 / 5.5.1 (URCL pull request #110).
    _out("tcp_offset", "VECTOR6D", _vector("tcp_offset"), ((3, 12, 0), (5, 5, 1))),
    _out("script_control_line", "UINT32", _integer("script_control_line"), ((3, 14, 0), (5, 9, 0))),
    _out("ft_raw_wrench", "VECTOR6D", _vector("actual_tcp_force"), (None, (5, 9, 0))),
    _out("actual_current_as_torque", "VECTOR6D", _vector("target_moment"), (None, (5, 23, 0))),
    _out("target_gravity", "VECTOR3D", _gravity, (None, (5, 26, 0))),
    _out("control_step", "UINT64", _integer("cycle"), (None, (5, 26, 0))),
    # --- outputs UR's guide lists without an introduction version (docs/ursim.md "RTDE variables" gives the
    # evidence for each version chosen here) ---
    # In URCL's exhaustive CI recipe (#213) run against URSim 3.14.3 and 5.9.4; UR's own record_configuration.xml
    # (2023) requests joint_position_deviation_ratio by default.
    _out("joint_position_deviation_ratio", "DOUBLE", _constant(0.0), ((3, 14, 0), (5, 9, 0))),
    _out("actual_current_window", "VECTOR6D", _vector("actual_current"), ((3, 14, 0), (5, 9, 0))),
    # Listed by UR (RTDE_Python_Client_Library, July 2023) as outputs "the controller can provide": CB3's last line
    # and the e-series release of that time.
    _out("actual_configurable_digital_input_bits", "UINT64", _integer("configurable_digital_input_bits"),
         ((3, 15, 0), (5, 13, 0))),
    _out("actual_configurable_digital_output_bits", "UINT64", _integer("configurable_digital_output_bits"),
         ((3, 15, 0), (5, 13, 0))),
    _out("encoder0_raw", "INT32", _constant(0), ((3, 15, 0), (5, 13, 0))),  # no encoder wired to the simulated box
    _out("encoder1_raw", "INT32", _constant(0), ((3, 15, 0), (5, 13, 0))),
    # URCL's version table (#213): e-series only.
    _out("collision_detection_ratio", "DOUBLE", _constant(0.0), (None, (5, 15, 0))),  # no contact is modelled
    _out("time_scale_source", "INT32", _constant(0), (None, (5, 17, 0))),
    # URCL's RTDE client test: "added in 5.23.0 / 10.11.0".
    _out("actual_robot_energy_consumed", "DOUBLE", _constant(0.0), (None, (5, 23, 0))),
    _out("actual_robot_braking_energy_dissipated", "DOUBLE", _constant(0.0), (None, (5, 23, 0))),
    # Added to URCL's list with 5.24-era fields (#380, 2025): e-series only, 5.24 assumed.
    _out("actual_TCP_acceleration", "VECTOR6D", _constant(*(0.0,) * 6), (None, (5, 24, 0))),
    _out("target_TCP_acceleration", "VECTOR6D", _constant(*(0.0,) * 6), (None, (5, 24, 0))),
    _out("target_execution_time", "DOUBLE", _double("execution_time"), (None, (5, 24, 0))),
    _out("wrench_calc_from_currents", "VECTOR6D", _vector("actual_tcp_force"), (None, (5, 24, 0))),
    # Between target_gravity and control_step (both 5.26) in the guide's chronological order; URCL #539: 5.26.
    _out("target_base_acceleration", "VECTOR6D", _constant(*(0.0,) * 6), (None, (5, 26, 0))),  # the base stands still
    _out("target_base_wrench", "VECTOR6D", _constant(*(0.0,) * 6), (None, (5, 26, 0))),
]

for _index in range(64, 128):
    _OUTPUT_LIST.append(_out(f"output_bit_register_{_index}", "BOOL",
                             _register("output_bit_registers", _index, bool), UPPER_REGISTERS))
    _OUTPUT_LIST.append(_out(f"input_bit_register_{_index}", "BOOL",
                             _register("input_bit_registers", _index, bool), UPPER_REGISTERS))
for _index in range(48):
    _range = RTDE_FIRST if _index < 24 else UPPER_REGISTERS
    for _direction in ("output", "input"):
        _OUTPUT_LIST.append(_out(f"{_direction}_int_register_{_index}", "INT32",
                                 _register(f"{_direction}_int_registers", _index, int), _range))
        _OUTPUT_LIST.append(_out(f"{_direction}_double_register_{_index}", "DOUBLE",
                                 _register(f"{_direction}_double_registers", _index, float), _range))

OUTPUTS = {variable.name: variable for variable in _OUTPUT_LIST}


def _in(name, type_name, introduced=RTDE_FIRST):
    return Variable(name, type_name, introduced[0], introduced[1])


_INPUT_LIST = [
    _in("speed_slider_mask", "UINT32"),
    _in("speed_slider_fraction", "DOUBLE"),
    _in("standard_digital_output_mask", "UINT8"),
    _in("standard_digital_output", "UINT8"),
    _in("configurable_digital_output_mask", "UINT8"),
    _in("configurable_digital_output", "UINT8"),
    # Not in UR's guide, but ur_rtde's RTDEIOInterface uses them and controllers accept them
    # (URCL: "NOT IN OFFICIAL DOCS").
    _in("tool_digital_output_mask", "UINT8"),
    _in("tool_digital_output", "UINT8"),
    _in("standard_analog_output_mask", "UINT8"),
    _in("standard_analog_output_type", "UINT8"),
    _in("standard_analog_output_0", "DOUBLE"),
    _in("standard_analog_output_1", "DOUBLE"),
    _in("input_bit_registers0_to_31", "UINT32"),
    _in("input_bit_registers32_to_63", "UINT32"),
    _in("external_force_torque", "VECTOR6D", ((3, 3, 0), (5, 0, 0))),
]
for _index in range(64, 128):
    _INPUT_LIST.append(_in(f"input_bit_register_{_index}", "BOOL", UPPER_REGISTERS))
for _index in range(48):
    _range = RTDE_FIRST if _index < 24 else UPPER_REGISTERS
    _INPUT_LIST.append(_in(f"input_int_register_{_index}", "INT32", _range))
    _INPUT_LIST.append(_in(f"input_double_register_{_index}", "DOUBLE", _range))

INPUTS = {variable.name: variable for variable in _INPUT_LIST}


def output_type(name, version):
    """RTDE type the controller answers for output `name` at `version`, or NOT_FOUND."""
    variable = OUTPUTS.get(name)
    if variable is None or not variable.available_in(version):
        return "NOT_FOUND"
    return variable.type


def input_type(name, version):
    """RTDE type the controller answers for input `name` at `version`, or NOT_FOUND."""
    variable = INPUTS.get(name)
    if variable is None or not variable.available_in(version):
        return "NOT_FOUND"
    return variable.type


def output_readers(names):
    """The readers of a valid output recipe, in order."""
    return [OUTPUTS[name].read for name in names]


def read_flat_values(readers, state):
    """All values of a recipe for one state, flattened in wire order."""
    values = []
    for read in readers:
        values.extend(read(state))
    return values
