"""The controller's I/O: digital and analog outputs/inputs and the general-purpose registers.

Every setter replaces the stored array (copy-on-write), so a controller snapshot can hold the arrays without
copying them. Indices are checked: a bad index or value raises ValueError naming it. After every write, `on_change`
(set by the controller to its commit) runs outside the I/O lock, so the write is in the controller's state() when
the setter returns.
"""
import contextlib
import threading
from collections.abc import Callable, Iterator

import numpy as np

REGISTER_COUNT = 48
BIT_REGISTER_COUNT = 128
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1


def _frozen(array: np.ndarray) -> np.ndarray:
    """`array` made read-only, so snapshots can share it safely."""
    array.setflags(write=False)
    return array


def _checked_index(index: object, count: int, name: str) -> int:
    """`index` as an int in [0, count); ValueError naming `name` otherwise."""
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < count:
        raise ValueError(f"{name} index must be an integer 0..{count - 1}, got {index!r}")
    return int(index)


def set_bits(bits: int, mask: int, values: int) -> int:
    """`bits` with the bits selected by `mask` replaced by those of `values` (RTDE mask semantics)."""
    return (bits & ~mask) | (values & mask)


class IOState:
    """Digital outputs (8 standard, 8 configurable, 2 tool), inputs, 2 analog outs/ins, and the register banks."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.version = 0  # bumped by every write, so the controller knows when its snapshot is stale
        self.on_change: Callable[[], None] | None = None
        self._batches = threading.local()  # per thread: open batch() depth, and whether a write waits to notify
        self.standard_digital_outputs = 0  # bit n = DO n
        self.configurable_digital_outputs = 0
        self.tool_digital_outputs = 0
        self.standard_digital_inputs = 0
        self.configurable_digital_inputs = 0
        self.tool_digital_inputs = 0
        self.analog_outputs = _frozen(np.zeros(2))
        self.analog_output_types = 0  # bit n = AO n is a voltage output (else current)
        self.analog_inputs = _frozen(np.zeros(2))
        self.tool_analog_inputs = _frozen(np.zeros(2))
        self.input_int_registers = _frozen(np.zeros(REGISTER_COUNT, dtype=np.int64))
        self.output_int_registers = _frozen(np.zeros(REGISTER_COUNT, dtype=np.int64))
        self.input_double_registers = _frozen(np.zeros(REGISTER_COUNT))
        self.output_double_registers = _frozen(np.zeros(REGISTER_COUNT))
        self.input_bit_registers = _frozen(np.zeros(BIT_REGISTER_COUNT, dtype=bool))
        self.output_bit_registers = _frozen(np.zeros(BIT_REGISTER_COUNT, dtype=bool))

    @contextlib.contextmanager
    def _writing(self) -> Iterator[None]:
        """One write: under the lock with the version bumped, then `on_change` once the lock is released (at the
        end of the calling thread's `batch()` when one is open)."""
        with self._lock:
            self.version += 1
            yield
        if getattr(self._batches, "depth", 0):
            self._batches.pending = True
        elif self.on_change is not None:
            self.on_change()

    @contextlib.contextmanager
    def batch(self) -> Iterator[None]:
        """The calling thread's writes inside notify `on_change` once, at the end (an RTDE input package writes many
        registers; each write alone would commit the controller's snapshot)."""
        batches = self._batches
        batches.depth = getattr(batches, "depth", 0) + 1
        try:
            yield
        finally:
            batches.depth -= 1
            if batches.depth == 0 and getattr(batches, "pending", False):
                batches.pending = False
                if self.on_change is not None:
                    self.on_change()

    # digital outputs ------------------------------------------------------------------------------------------
    def set_standard_digital_out(self, index: int, value: bool) -> None:
        """Standard digital output DO`index` (0..7) on or off."""
        bit = 1 << _checked_index(index, 8, "standard digital output")
        with self._writing():
            self.standard_digital_outputs = set_bits(self.standard_digital_outputs, bit, bit if value else 0)

    def set_configurable_digital_out(self, index: int, value: bool) -> None:
        """Configurable digital output CO`index` (0..7) on or off."""
        bit = 1 << _checked_index(index, 8, "configurable digital output")
        with self._writing():
            self.configurable_digital_outputs = set_bits(self.configurable_digital_outputs, bit, bit if value else 0)

    def set_tool_digital_out(self, index: int, value: bool) -> None:
        """Tool digital output TO`index` (0..1) on or off."""
        bit = 1 << _checked_index(index, 2, "tool digital output")
        with self._writing():
            self.tool_digital_outputs = set_bits(self.tool_digital_outputs, bit, bit if value else 0)

    def apply_digital_output_masks(self, standard: tuple[int, int] = (0, 0), configurable: tuple[int, int] = (0, 0),
                                   tool: tuple[int, int] = (0, 0)) -> None:
        """Write (mask, values) pairs to the three digital output groups at once, as an RTDE input package does."""
        with self._writing():
            self.standard_digital_outputs = set_bits(self.standard_digital_outputs, *standard) & 0xFF
            self.configurable_digital_outputs = set_bits(self.configurable_digital_outputs, *configurable) & 0xFF
            self.tool_digital_outputs = set_bits(self.tool_digital_outputs, *tool) & 0x3

    def set_standard_digital_in(self, index: int, value: bool) -> None:
        """Simulated wiring: standard digital input DI`index` (0..7) high or low (for tests)."""
        bit = 1 << _checked_index(index, 8, "standard digital input")
        with self._writing():
            self.standard_digital_inputs = set_bits(self.standard_digital_inputs, bit, bit if value else 0)

    @property
    def digital_output_bits(self) -> int:
        """RTDE actual_digital_output_bits: 0-7 standard, 8-15 configurable, 16-17 tool."""
        return (self.standard_digital_outputs | (self.configurable_digital_outputs << 8)
                | (self.tool_digital_outputs << 16))

    @property
    def digital_input_bits(self) -> int:
        """RTDE actual_digital_input_bits: 0-7 standard, 8-15 configurable, 16-17 tool."""
        return (self.standard_digital_inputs | (self.configurable_digital_inputs << 8)
                | (self.tool_digital_inputs << 16))

    def versioned_snapshot(self) -> tuple[int, dict]:
        """(version, snapshot_fields()) read together: no write falls between them."""
        with self._lock:
            return self.version, self.snapshot_fields()

    def snapshot_fields(self) -> dict:
        """The controller snapshot's I/O fields (ControllerState names), read now."""
        return dict(
            digital_input_bits=self.digital_input_bits,
            configurable_digital_input_bits=self.configurable_digital_inputs,
            tool_digital_input_bits=self.tool_digital_inputs,
            digital_output_bits=self.digital_output_bits,
            standard_digital_output_bits=self.standard_digital_outputs,
            configurable_digital_output_bits=self.configurable_digital_outputs,
            tool_digital_output_bits=self.tool_digital_outputs,
            analog_io_types=self.analog_io_types,
            standard_analog_input0=float(self.analog_inputs[0]), standard_analog_input1=float(self.analog_inputs[1]),
            standard_analog_output0=float(self.analog_outputs[0]),
            standard_analog_output1=float(self.analog_outputs[1]),
            tool_analog_input0=float(self.tool_analog_inputs[0]), tool_analog_input1=float(self.tool_analog_inputs[1]),
            standard_analog_inputs=self.analog_inputs, standard_analog_outputs=self.analog_outputs,
            tool_analog_inputs=self.tool_analog_inputs,
            input_int_registers=self.input_int_registers, output_int_registers=self.output_int_registers,
            input_double_registers=self.input_double_registers, output_double_registers=self.output_double_registers,
            input_bit_registers=self.input_bit_registers, output_bit_registers=self.output_bit_registers,
        )

    # analog ---------------------------------------------------------------------------------------------------
    def set_analog_out(self, index: int, value: float, voltage: bool | None = None) -> None:
        """Standard analog output AO`index` (0..1) to `value` (ratio 0..1); optionally switch it to voltage/current."""
        index = _checked_index(index, 2, "standard analog output")
        value = float(value)
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"analog output {index} value must be a ratio 0..1, got {value}")
        with self._writing():
            outputs = self.analog_outputs.copy()
            outputs[index] = value
            self.analog_outputs = _frozen(outputs)
            if voltage is not None:
                bit = 1 << index
                self.analog_output_types = set_bits(self.analog_output_types, bit, bit if voltage else 0)

    @property
    def analog_io_types(self) -> int:
        """RTDE analog_io_types: bits 0-1 AI0/AI1, bits 2-3 AO0/AO1; 1 = voltage (inputs are current here)."""
        return self.analog_output_types << 2

    # registers ------------------------------------------------------------------------------------------------
    def set_int_register(self, bank: str, index: int, value: int) -> None:
        """Integer register `index` (0..47) of bank "input" or "output" to a signed 32-bit `value`."""
        index = _checked_index(index, REGISTER_COUNT, f"{bank} integer register")
        value = int(value)
        if not INT32_MIN <= value <= INT32_MAX:
            raise ValueError(f"{bank} integer register {index} value must fit in int32, got {value}")
        self._replace(f"{_checked_bank(bank)}_int_registers", index, value)

    def set_double_register(self, bank: str, index: int, value: float) -> None:
        """Double register `index` (0..47) of bank "input" or "output"."""
        index = _checked_index(index, REGISTER_COUNT, f"{bank} double register")
        self._replace(f"{_checked_bank(bank)}_double_registers", index, float(value))

    def set_bit_register(self, bank: str, index: int, value: bool) -> None:
        """Bit register `index` (0..127) of bank "input" or "output"."""
        index = _checked_index(index, BIT_REGISTER_COUNT, f"{bank} bit register")
        self._replace(f"{_checked_bank(bank)}_bit_registers", index, bool(value))

    def set_bit_register_word(self, bank: str, first: int, word: int) -> None:
        """32 bit registers first..first+31 (first = 0 or 32) from a UINT32, as RTDE input_bit_registersX_to_Y."""
        if first not in (0, 32):
            raise ValueError(f"bit register word must start at 0 or 32, got {first!r}")
        name = f"{_checked_bank(bank)}_bit_registers"
        with self._writing():
            bits = getattr(self, name).copy()
            bits[first:first + 32] = [(int(word) >> n) & 1 for n in range(32)]
            setattr(self, name, _frozen(bits))

    def bit_register_word(self, bank: str, first: int) -> int:
        """Bit registers first..first+31 (first = 0 or 32) packed into a UINT32, bit n = register first+n."""
        if first not in (0, 32):
            raise ValueError(f"bit register word must start at 0 or 32, got {first!r}")
        bits = getattr(self, f"{_checked_bank(bank)}_bit_registers")[first:first + 32]
        return int(np.dot(bits.astype(np.uint64), (np.uint64(1) << np.arange(32, dtype=np.uint64))))

    def _replace(self, name: str, index: int, value: object) -> None:
        with self._writing():
            array = getattr(self, name).copy()
            array[index] = value
            setattr(self, name, _frozen(array))


def _checked_bank(bank: str) -> str:
    """"input" or "output"; ValueError otherwise."""
    if bank not in ("input", "output"):
        raise ValueError(f"register bank must be 'input' or 'output', got {bank!r}")
    return bank
