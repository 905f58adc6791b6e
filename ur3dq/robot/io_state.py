"""The controller's I/O and program state as the driver reads them (pure data, no transport).

Digital bits follow RTDE's `actual_digital_input_bits` / `actual_digital_output_bits` and the primary
interface's masterboard data: bits 0-7 standard, 8-15 configurable, 16-17 tool.
"""
from __future__ import annotations

import dataclasses

RUNTIME_STATE_NAMES = {0: "STOPPING", 1: "STOPPED", 2: "PLAYING", 3: "PAUSING", 4: "PAUSED", 5: "RESUMING"}
# (name, first bit, count) of each group of digital pins in the controller's bit words
DIGITAL_GROUPS = (("standard", 0, 8), ("configurable", 8, 8), ("tool", 16, 2))


def io_bit(group: str, pin: int) -> int:
    """The bit of digital pin `pin` of `group` ('standard', 'configurable', 'tool') in the controller's bit words;
    ValueError naming the pins the group has.

    >>> io_bit("tool", 0) == 1 << 16
    True
    """
    for name, first, count in DIGITAL_GROUPS:
        if name == group:
            if isinstance(pin, bool) or not isinstance(pin, int) or not 0 <= pin < count:
                raise ValueError(f"{group} digital I/O pin {pin!r} does not exist (0..{count - 1})")
            return 1 << (first + pin)
    raise ValueError(f"I/O group {group!r} is not one of {', '.join(name for name, _, _ in DIGITAL_GROUPS)}")


@dataclasses.dataclass(frozen=True)
class IOState:
    """One reading of the I/O: digital input and output bit words, the standard analog inputs and outputs (the
    controller's values, volts or amperes as configured), and the program's runtime state (None when the
    interface does not report it).

    >>> state = IOState(digital_in=0b101, digital_out=1 << 16, analog_in=(0.0, 1.5), analog_out=(0.0, 0.0),
    ...                 runtime_state=2)
    >>> state.pins("standard", inputs=True)[:3], state.pins("tool", inputs=False), state.runtime_state_name
    ([True, False, True], [True, False], 'PLAYING')
    """

    digital_in: int
    digital_out: int
    analog_in: tuple[float, float]
    analog_out: tuple[float, float]
    runtime_state: int | None

    def pins(self, group: str, inputs: bool) -> list[bool]:
        """The pins of `group` ('standard', 'configurable', 'tool'): inputs or outputs, pin 0 first."""
        first, count = next((first, count) for name, first, count in DIGITAL_GROUPS if name == group)
        word = self.digital_in if inputs else self.digital_out
        return [bool(word >> (first + pin) & 1) for pin in range(count)]

    def outputs_on(self) -> list[tuple[str, int]]:
        """(group, pin) of every digital output that is on, standard first."""
        return [(name, pin) for name, _, count in DIGITAL_GROUPS for pin in range(count)
                if self.digital_out & io_bit(name, pin)]

    @property
    def runtime_state_name(self) -> str:
        """PLAYING, PAUSED, STOPPED, ... ('unknown' when the interface does not report it)."""
        if self.runtime_state is None:
            return "unknown"
        return RUNTIME_STATE_NAMES.get(self.runtime_state, f"UNKNOWN({self.runtime_state})")

    def to_dict(self) -> dict[str, object]:
        """The reading as JSON-ready values: per group, a list of booleans (pin 0 first)."""
        return {"digital_in": {name: self.pins(name, True) for name, _, _ in DIGITAL_GROUPS},
                "digital_out": {name: self.pins(name, False) for name, _, _ in DIGITAL_GROUPS},
                "analog_in": list(self.analog_in), "analog_out": list(self.analog_out),
                "runtime_state": self.runtime_state_name}
