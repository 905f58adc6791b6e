"""What RTDE input values do to the controller: masks, speed slider, analog outputs, registers.

A client's inputs keep their last value (RTDE guide), so each package is applied together with the client's
earlier values of the partner fields: a package that changes only `standard_digital_output` still uses the last
`standard_digital_output_mask` the client sent. Only the groups a package touches are written.
"""
import re
from collections.abc import Collection, Mapping
from typing import Any

_DIGITAL_GROUPS = ("standard", "configurable", "tool")
_REGISTER = re.compile(r"input_(int|double|bit)_register_(\d+)$")
_BIT_WORDS = {"input_bit_registers0_to_31": 0, "input_bit_registers32_to_63": 32}


def digital_output_writes(values: Mapping[str, Any], changed: Collection[str]) -> dict[str, tuple[int, int]]:
    """{group: (mask, bits)} for each digital output group (standard/configurable/tool) a package touched."""
    writes = {}
    for group in _DIGITAL_GROUPS:
        mask_name, bits_name = f"{group}_digital_output_mask", f"{group}_digital_output"
        if mask_name in changed or bits_name in changed:
            writes[group] = (int(values.get(mask_name, 0)), int(values.get(bits_name, 0)))
    return writes


def speed_slider_write(values: Mapping[str, Any], changed: Collection[str]) -> float | None:
    """The new slider fraction when the package touched the slider and speed_slider_mask is 1, else None."""
    if "speed_slider_mask" not in changed and "speed_slider_fraction" not in changed:
        return None
    if int(values.get("speed_slider_mask", 0)) != 1:
        return None
    return float(values.get("speed_slider_fraction", 0.0))


def analog_output_writes(values: Mapping[str, Any], changed: Collection[str]) -> list[tuple[int, float, bool]]:
    """[(index, ratio, is_voltage)] of the analog outputs a touched group writes.

    The outputs are those standard_analog_output_mask selects.
    """
    names = ("standard_analog_output_mask", "standard_analog_output_type", "standard_analog_output_0",
             "standard_analog_output_1")
    if not any(name in changed for name in names):
        return []
    mask = int(values.get("standard_analog_output_mask", 0))
    kinds = int(values.get("standard_analog_output_type", 0))
    return [(index, float(values.get(f"standard_analog_output_{index}", 0.0)), bool(kinds >> index & 1))
            for index in (0, 1) if mask >> index & 1]


def register_writes(values: Mapping[str, Any], changed: Collection[str]) -> list[tuple[str, int, Any]]:
    """[(kind, index, value)] for every input register named in the package (kind: int, double, bit, word)."""
    writes = []
    for name in changed:
        match = _REGISTER.match(name)
        if match:
            writes.append((match.group(1), int(match.group(2)), values[name]))
        elif name in _BIT_WORDS:
            writes.append(("word", _BIT_WORDS[name], int(values[name])))
    return writes


def apply_inputs(controller, values: Mapping[str, Any], changed: Collection[str]) -> None:
    """Apply one input package: `values` = the client's latest value of every input, `changed` = names it carried."""
    changed = set(changed)
    fraction = speed_slider_write(values, changed)
    if fraction is not None:
        controller.set_speed_slider(fraction)
    with controller.io.batch():  # one commit of the controller's snapshot for the whole package
        _apply_io(controller.io, values, changed)
    if "external_force_torque" in changed:
        controller.set_external_force_torque(values["external_force_torque"])


def _apply_io(io, values: Mapping[str, Any], changed: Collection[str]) -> None:
    """The package's digital/analog outputs and input registers, written to `io`."""
    digital = digital_output_writes(values, changed)
    if digital:
        io.apply_digital_output_masks(**digital)
    for index, ratio, voltage in analog_output_writes(values, changed):
        io.set_analog_out(index, ratio, voltage=voltage)
    for kind, index, value in register_writes(values, changed):
        if kind == "int":
            io.set_int_register("input", index, value)
        elif kind == "double":
            io.set_double_register("input", index, value)
        elif kind == "bit":
            io.set_bit_register("input", index, value)
        else:
            io.set_bit_register_word("input", index, value)
