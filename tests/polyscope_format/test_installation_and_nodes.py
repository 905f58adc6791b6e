"""An installation's pin names, and the node vocabulary ur3dq's import and sim_ursim's playback share: If chains,
children, fields, pins."""
import gzip

import pytest

from polyscope_format.installation import installation_path, pin_aliases, with_installation
from polyscope_format.nodes import (
    PIN_FUNCTIONS,
    field_text,
    grouped_if_chains,
    if_branches,
    if_kind,
    node_children,
    split_pin,
)
from polyscope_format.urp_file import UrpFormatError, read_installation, read_urp
from urp_samples import program_xml, set_digital, tree, write_urp

INSTALLATION = (b'<Installation><IOs><ToolDigitalOutputNames value="gripper, "/>'
                b'<AnalogOutputNames value="a, b"/><DigitalInputNames value=""/></IOs></Installation>')


def test_an_installation_s_names_map_to_polyscope_s_pin_names(tmp_path):
    program = read_urp(write_urp(tmp_path / "cell.urp", program_xml(set_digital("gripper"))))
    assert installation_path(program, tmp_path / "cell.urp") == tmp_path / "default.installation"
    assert with_installation(program, tmp_path / "cell.urp").pin_aliases == {}   # none beside it: no names
    (tmp_path / "default.installation").write_bytes(gzip.compress(INSTALLATION))
    assert pin_aliases(read_installation(tmp_path / "default.installation")) == {
        "gripper": "tool_out[0]", "a": "analog_out[0]", "b": "analog_out[1]"}
    assert with_installation(program, tmp_path / "cell.urp").pin_aliases["gripper"] == "tool_out[0]"


def test_an_unreadable_installation_is_the_program_s_problem(tmp_path):
    program = read_urp(write_urp(tmp_path / "cell.urp", program_xml(set_digital("gripper"))))
    (tmp_path / "default.installation").write_bytes(b"\x1f\x8b\x08\x00garbage")
    with pytest.raises(UrpFormatError, match=r"default.installation: truncated .*; copy the file again"):
        with_installation(program, tmp_path / "cell.urp")


def _nodes(xml: str):
    program = tree(xml)
    return program, node_children(program, program.root.find("children/MainProgram"))


def test_an_if_takes_the_else_if_and_else_siblings_that_follow_it():
    _, nodes = _nodes('<If type="If"/><If type="ElseIf"/><Else/><Halt/><ElseIf/><If/><Comment/>')
    assert [[if_kind(node) or node.tag for node in group] for group in grouped_if_chains(nodes)] == [
        ["If", "ElseIf", "Else"], ["Halt"], ["ElseIf"], ["If"], ["Comment"]]


def test_an_if_s_branches_nested_in_its_children_come_before_its_siblings():
    program, nodes = _nodes('<If><children><Halt/><ElseIf/><Comment/></children></If><Else/>')
    then_nodes, branches = if_branches(nodes, node_children(program, nodes[0]))
    assert [node.tag for node in then_nodes] == ["Halt", "Comment"]
    assert [node.tag for node in branches] == ["If", "ElseIf", "Else"]


def test_children_follow_references_and_drop_placeholders():
    _, nodes = _nodes('<Halt/><Placeholder/><Halt reference="../Halt"/>')
    assert [node.tag for node in nodes] == ["Halt", "Halt"] and nodes[0] is nodes[1]


def test_fields_come_as_child_text_or_attribute_and_pins_split_by_family():
    _, (wait,) = _nodes('<Wait type="Sleep" analogValue=" 2.5 "><waitTime> 0.01 </waitTime></Wait>')
    assert (field_text(wait, "waitTime"), field_text(wait, "analogValue"), field_text(wait, "absent")) == (
        "0.01", "2.5", "")
    assert split_pin("GP_bool_out[64]") == ("GP_bool_out", 64)
    assert PIN_FUNCTIONS["tool_out"] == ("get_tool_digital_out", "set_tool_digital_out")
    with pytest.raises(ValueError, match="is not a pin name"):
        split_pin("gripper")
