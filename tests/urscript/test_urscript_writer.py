"""The URScript writer (ur3dq.urscript): lossless numbers, safe text, identifiers, statements, program layout."""
import math
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ur3dq import urscript as script

finite_floats = st.floats(allow_nan=False, allow_infinity=False)


@given(finite_floats)
def test_format_number_reads_back_exactly(value):
    text = script.format_number(value)
    assert float(text) == value
    assert "e" not in text.lower() and "inf" not in text and "nan" not in text


@given(finite_floats)
def test_format_number_is_a_urscript_literal(value):
    assert re.fullmatch(r"-?\d+\.\d+", script.format_number(value))


def test_format_number_keeps_digits_urx_would_round():
    assert script.format_number(1e-7) == "0.0000001"
    assert script.format_number(0.1234567891234) == "0.1234567891234"
    assert script.format_number(2) == "2.0"


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, "x", None, "1.5", True])
def test_format_number_rejects_non_finite(bad):
    with pytest.raises(ValueError, match="speed"):
        script.format_number(bad, "speed")


def test_format_vector_and_pose():
    assert script.format_vector([0, -1.5, 1e-7, 2, 3, 4]) == "[0.0, -1.5, 0.0000001, 2.0, 3.0, 4.0]"
    assert script.format_pose([0.1, 0.2, 0.3, 0, 0, 3.14]) == "p[0.1, 0.2, 0.3, 0.0, 0.0, 3.14]"


def test_format_vector_names_the_bad_element():
    with pytest.raises(ValueError, match=r"q\[2\]"):
        script.format_vector([0, 0, math.nan, 0, 0, 0], name="q")
    with pytest.raises(ValueError, match="6 values"):
        script.format_vector([0, 0, 0], name="q")


@given(st.text(max_size=100))
def test_sanitised_text_cannot_break_out_of_its_literal(text):
    literal = script.sanitise_text(text)
    assert literal.startswith('"') and literal.endswith('"')
    inner = literal[1:-1]
    assert '"' not in inner and "\\" not in inner and "\n" not in inner
    assert all(0x20 <= ord(char) < 0x7F for char in inner)
    assert len(inner) == len(text)


def test_sanitised_text_keeps_plain_text_and_replaces_the_rest():
    assert script.sanitise_text("pick 1") == '"pick 1"'
    assert script.sanitise_text('a"); powerdown() #') == '"a?); powerdown() #"'
    assert script.sanitise_text("pieza\ncafé") == '"pieza?caf?"'


def test_sanitised_text_rejects_non_strings_and_overlong_text():
    with pytest.raises(ValueError, match="string"):
        script.sanitise_text(5)
    with pytest.raises(ValueError, match="at most"):
        script.sanitise_text("x" * 300)


@pytest.mark.parametrize("bad", ["1abc", "a b", "", "a;b", "x" * 64, None])
def test_check_identifier_rejects(bad):
    with pytest.raises(ValueError, match="identifier"):
        script.check_identifier(bad)


def test_new_program_names_are_distinct_identifiers():
    first, second = script.new_program_name("move"), script.new_program_name("move")
    assert first != second
    assert script.check_identifier(first) == first and first.startswith("ur3dq_move_")


def test_movej_statement():
    assert (script.movej_statement([0, -1.5707963267948966, 0, -1.5707963267948966, 0, 0], 1.4, 1.05)
            == "movej([0.0, -1.5707963267948966, 0.0, -1.5707963267948966, 0.0, 0.0], a=1.4, v=1.05, r=0.0)")


def test_movej_program_blends_all_but_the_last_target():
    text = script.movej_program("p1", [[0] * 6, [0.1] * 6, [0.2] * 6], a=1.0, v=0.5, blend=0.02)
    lines = text.splitlines()
    assert lines[0] == "def p1():" and lines[-1] == "end" and text.endswith("end\n")
    assert [line.rsplit("r=", 1)[1] for line in lines[1:-1]] == ["0.02)", "0.02)", "0.0)"]


def test_program_rejects_multiline_statements_and_empty_bodies():
    with pytest.raises(ValueError, match="single line"):
        script.program("p", ["movej([0,0,0,0,0,0])\npowerdown()"])
    with pytest.raises(ValueError, match="at least one"):
        script.program("p", [])


def test_other_statements():
    assert script.stopj_statement(2) == "stopj(2.0)"
    assert script.set_tcp_statement([0, 0, 0.2, 0, 0, 0]) == "set_tcp(p[0.0, 0.0, 0.2, 0.0, 0.0, 0.0])"
    assert script.textmsg_statement('hi "x"') == 'textmsg("hi ?x?")'
    assert script.freedrive_statements(10) == ["freedrive_mode()", "sleep(10.0)", "end_freedrive_mode()"]


def test_comment_text_keeps_comments_single_line_ascii():
    assert script.comment_text("café\n#2\tok") == "caf??#2?ok"
    assert len(script.comment_text("x" * 500)) == 100 and script.comment_text("x" * 500).endswith("...")


def test_move_statements():
    q = [0, -1.5, 1, 0, 0, 0.25]
    assert script.move_statement("movel", q, 1.2, 0.25, 0.01, t=0) == (
        "movel([0.0, -1.5, 1.0, 0.0, 0.0, 0.25], a=1.2, v=0.25, t=0, r=0.01)")
    assert script.move_statement("movep", q, 1.2, 0.05) == (
        "movep([0.0, -1.5, 1.0, 0.0, 0.0, 0.25], a=1.2, v=0.05, r=0.0)")
    with pytest.raises(ValueError, match="move function"):
        script.move_statement("servoj", q, 1, 1)
    with pytest.raises(ValueError, match="v must be finite"):
        script.move_statement("movej", q, 1, math.inf)


def test_io_register_and_message_statements():
    assert script.set_digital_out_statement("tool", 1, True) == "set_tool_digital_out(1, True)"
    assert script.set_digital_out_statement("configurable", 3, False) == "set_configurable_digital_out(3, False)"
    assert script.set_analog_out_statement(1, 0.25) == "set_standard_analog_out(1, 0.25)"
    assert script.sleep_statement(2) == "sleep(2.0)"
    assert script.write_output_integer_register_statement(22, -4) == "write_output_integer_register(22, -4)"
    assert script.key_message_statement("ur3dq_step:", 3) == 'textmsg("ur3dq_step:", 3)'
    assert script.rtde_set_watchdog_statement("input_int_register_20", 10, "stop") == (
        'rtde_set_watchdog("input_int_register_20", 10.0, "stop")')
    with pytest.raises(ValueError, match="I/O family"):
        script.set_digital_out_statement("analog", 0, True)
    with pytest.raises(ValueError, match="whole number"):
        script.set_digital_out_statement("tool", "1); powerdown(", True)


def test_wait_for_a_digital_input_runs_the_timeout_statements_inside_its_loop():
    lines = script.wait_for_digital_input_statements("standard", 3, True, 2.5, ["halt"])
    assert lines[:3] == ["ur3dq_waited = 0.0", "while get_standard_digital_in(3) != True:",
                         "  if ur3dq_waited >= 2.5:"]
    assert lines[3] == "    halt" and lines[-1] == "end"


def test_program_header_loop_and_first_statement():
    body = script.repeat(3, ["movej([0.0, 0.0, 0.0, 0.0, 0.0, 0.0], a=1.4, v=1.05, r=0.0)"])
    text = script.program("p", body, header=["made\nby a test"])
    assert text == ("# made?by a test\ndef p():\n  ur3dq_loop = 0\n  while ur3dq_loop < 3:\n"
                    "    movej([0.0, 0.0, 0.0, 0.0, 0.0, 0.0], a=1.4, v=1.05, r=0.0)\n"
                    "    ur3dq_loop = ur3dq_loop + 1\n  end\nend\n")
    armed = script.first_statement_added(text, "p", "sync()")
    assert armed.splitlines()[1:3] == ["def p():", "  sync()"]
    with pytest.raises(ValueError, match="exactly one line"):
        script.first_statement_added(text, "q", "sync()")
    with pytest.raises(ValueError, match="loops"):
        script.repeat(0, ["sync()"])
