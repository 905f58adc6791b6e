"""ur3dq/slots.py: a frozen slotted dataclass built past __init__ holds exactly the values given, field by field,
stays frozen, and is told when a value is missing or extra."""
import dataclasses

import pytest

from ur3dq.slots import slot_builder


@dataclasses.dataclass(frozen=True, slots=True)
class _Checked:
    name: str
    count: int = 0
    note: str = ""

    def __post_init__(self):
        if self.count < 0:
            raise ValueError("count must be ≥ 0")


def test_the_built_instance_holds_the_values_in_field_order():
    build = slot_builder(_Checked)
    built = build("a", 3, "n")
    assert built == _Checked("a", 3, "n") and type(built) is _Checked
    assert build("b", -1, "").count == -1   # no __post_init__: the caller vouched for the values
    with pytest.raises(dataclasses.FrozenInstanceError):
        built.name = "c"


def test_every_field_must_be_given():
    build = slot_builder(_Checked)
    with pytest.raises(TypeError):
        build("a", 3)
    with pytest.raises(TypeError):
        build("a", 3, "n", "extra")
