"""URScript generation: lossless numbers, safe text, identifiers, program layout."""
import math
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ur3dq.robot import script

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
