"""How the primary, secondary and realtime ports cut a client's byte stream into programs (pure: no socket); the
same over real sockets is in test_primary_server.py."""
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_ursim.primary.script_intake import MAX_PENDING_BYTES, MAX_PENDING_LINES, IntakeOverflow, ScriptAssembler

BLOCKS = [
    "def first():\n  if True:\n    textmsg(\"a\")\n  elif False:\n    textmsg(\"b\")\n  else:\n    sleep(1)\n"
    "  end\nend\n",
    "sec watcher():\n  while False:\n    sync()\n  end\nend\n",
    "def threaded():\n  thread worker():\n    sleep(0.1)\n  end\n  t = run worker()\n  join t\nend\n",
    "def tricky():\n  textmsg(\"end\")  # the word end inside a string and this comment: end\n"
    "  global reg_offset_int = # int register offset\n0    global x = 1\nend\n",
]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(BLOCKS), min_size=1, max_size=5), st.data())
def test_blocks_come_out_whole_however_the_bytes_are_split(blocks, data):
    stream = "".join(blocks).encode()
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=8)))
    assembler = ScriptAssembler()
    programs = []
    for start, end in zip([0] + cuts, cuts + [len(stream)]):
        programs += assembler.feed(stream[start:end])
    assert programs == blocks
    assert not assembler.pending


def test_statement_lines_of_one_chunk_form_one_program():
    assert ScriptAssembler().feed(b"set_standard_digital_out(0, True)\nset_standard_digital_out(1, True)\n") == [
        "set_standard_digital_out(0, True)\nset_standard_digital_out(1, True)\n"]


def test_an_expression_continues_on_the_next_chunk_until_its_brackets_close():
    assembler = ScriptAssembler()
    assert assembler.feed(b"movej([0.1, 0.2,\n") == []
    assert assembler.feed(b"  0.3, 0.4, 0.5, 0.6], a=1.4)\n") == ["movej([0.1, 0.2,\n  0.3, 0.4, 0.5, 0.6], a=1.4)\n"]


def test_statements_before_a_block_run_before_it_and_an_unfinished_line_waits():
    assembler = ScriptAssembler()
    programs = assembler.feed(b"textmsg(\"one\")\ndef two():\n  sleep(1)\nend\ntextmsg(\"thr")
    assert programs == ["textmsg(\"one\")\n", "def two():\n  sleep(1)\nend\n"]
    assert assembler.pending
    assert assembler.feed(b"ee\")\r\n") == ["textmsg(\"three\")\n"]


def test_blank_lines_and_comments_between_programs_are_not_programs():
    assert ScriptAssembler().feed(b"\n# a comment\n   \n") == []


def test_the_intake_refuses_an_incomplete_program_beyond_its_bounds():
    bracket = ScriptAssembler()
    bracket.feed(b"textmsg((\n")
    with pytest.raises(IntakeOverflow, match="unclosed bracket"):
        for _ in range(MAX_PENDING_LINES + 1):
            bracket.feed(b"1,\n")
    block = ScriptAssembler()
    with pytest.raises(IntakeOverflow, match="unclosed block"):
        block.feed(b"def f():\n" + b"  textmsg(1)\n" * (MAX_PENDING_LINES + 1))
    endless = ScriptAssembler()
    with pytest.raises(IntakeOverflow, match="one line"):
        endless.feed(b"x" * (MAX_PENDING_BYTES + 1))
    big = ScriptAssembler()  # a large but complete program is not refused
    body = b"  textmsg(\"" + b"y" * 100 + b"\")\n"
    assert big.feed(b"def big():\n" + body * 20000 + b"end\n") == [
        "def big():\n" + body.decode() * 20000 + "end\n"]
