"""URScript parser: grammar coverage, precedence, line continuation, positions in errors."""
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_ursim.urscript import nodes
from sim_ursim.urscript.parser import URScriptSyntaxError, parse


def only_expression(source):
    """The expression of a one-statement script `x = <source>`."""
    (statement,) = parse(f"x = {source}\n").body
    return statement.value


def signed_number(node):
    """The value of a number literal, possibly negated by unary minus."""
    if isinstance(node, nodes.Unary) and node.op == "-":
        return -signed_number(node.operand)
    assert isinstance(node, nodes.Literal)
    return node.value


def shape(node):
    """A compact nested-tuple view of an expression tree, for precedence assertions."""
    if isinstance(node, nodes.Binary):
        return (node.op, shape(node.left), shape(node.right))
    if isinstance(node, nodes.Unary):
        return (node.op, shape(node.operand))
    if isinstance(node, nodes.Literal):
        return node.value
    if isinstance(node, nodes.Name):
        return node.name
    raise AssertionError(f"unexpected node {node!r}")


@pytest.mark.parametrize(
    "source, expected",
    [
        ("1 + 2 * 3", ("+", 1, ("*", 2, 3))),
        ("(1 + 2) * 3", ("*", ("+", 1, 2), 3)),
        ("1 - 2 - 3", ("-", ("-", 1, 2), 3)),
        ("8 / 4 % 3", ("%", ("/", 8, 4), 3)),
        ("-2 * 3", ("*", ("-", 2), 3)),
        ("a or b and c", ("or", "a", ("and", "b", "c"))),
        ("a or b xor c", ("or", "a", ("xor", "b", "c"))),
        ("a xor b and c", ("xor", "a", ("and", "b", "c"))),
        ("not a == b", ("not", ("==", "a", "b"))),
        ("not a and b", ("and", ("not", "a"), "b")),
        ("a + 1 < b * 2", ("<", ("+", "a", 1), ("*", "b", 2))),
        ("a <= b != c >= d", ("!=", ("<=", "a", "b"), (">=", "c", "d"))),
    ],
)
def test_operator_precedence(source, expected):
    assert shape(only_expression(source)) == expected


def test_literals_numbers_strings_booleans():
    texts = ("12", "1.5", ".5", "2e3", "1.5E-2", '"hi"', "'yo'", "True", "False")
    values = [only_expression(text).value for text in texts]
    assert values == [12, 1.5, 0.5, 2000.0, 0.015, "hi", "yo", True, False]
    assert isinstance(values[0], int) and isinstance(values[3], float)


def test_urx_number_formats_and_windows_line_endings():
    body = parse("movej([1e-06, -0.5, 2E+3, 0, 0, 0], a=1.4, v=1.05)\r\n\tx = 1\r\n").body
    assert [signed_number(item) for item in body[0].expr.args[0].items][:3] == [1e-06, -0.5, 2000.0]
    assert body[1].name == "x"


@settings(deadline=None)  # what the parser makes of the text, not how fast: a loaded machine took 333 ms once
@given(st.lists(st.integers(-1000, 1000), min_size=1, max_size=8),
       st.lists(st.sampled_from([" ", "\n", "\n    ", " # note\n", "\r\n\t"]), min_size=8, max_size=8))
def test_line_breaks_inside_brackets_do_not_change_the_list(values, breaks):
    text = "[" + ",".join(f"{b}{v}" for v, b in zip(values, breaks)) + breaks[0] + "]"
    (statement,) = parse(f"x = {text}\n").body
    assert [signed_number(item) for item in statement.value.items] == values


def test_pose_literal_and_variable_named_p_indexing():
    pose = only_expression("p[0.1, 0.2, 0.3, 0, 0, 3.14]")
    assert isinstance(pose, nodes.PoseExpr) and len(pose.items) == 6
    index = only_expression("p[2]")
    assert isinstance(index, nodes.Index) and index.target == nodes.Name("p", line=1, column=5)
    (assign,) = parse("p[0] = p[0] * 2\n").body
    assert assign.name == "p" and len(assign.indices) == 1


def test_list_indexing_chains_and_element_assignment():
    (assign,) = parse("m[1][2] = [1, [2, 3]][1][0]\n").body
    assert assign.name == "m" and [i.value for i in assign.indices] == [1, 2]
    assert isinstance(assign.value, nodes.Index) and isinstance(assign.value.target, nodes.Index)


def test_matrix_element_read_and_assignment():
    element = only_expression("m[1, 0]")
    assert isinstance(element, nodes.MatrixIndex)
    assert (element.row_index.value, element.column_index.value) == (1, 0)
    (assign,) = parse("m[0, 1] = 5\n").body
    assert [i.value for i in assign.indices] == [0, 1]


def test_tuple_syntax_from_urx_is_a_list():
    call = only_expression("set_payload(1.0, (0.1, 0.2, 0.3))")
    assert isinstance(call.args[1], nodes.ListExpr) and len(call.args[1].items) == 3


def test_calls_with_keyword_arguments():
    call = only_expression("movej([0, 0, 0, 0, 0, 0], a=1.4, v=1.05, r=0)")
    assert call.name == "movej" and len(call.args) == 1
    assert [name for name, _ in call.kwargs] == ["a", "v", "r"]


def test_keyword_before_positional_argument_is_an_error():
    with pytest.raises(URScriptSyntaxError):
        parse("movej(a=1, [0, 0, 0, 0, 0, 0])\n")


def test_def_program_with_default_arguments_threads_and_control_flow():
    source = """def prog():
  global counter = 0
  def add(a, b=2):
    local result = a + b
    return result
  end
  thread worker():
    while True:
      counter = counter + 1
      if counter > 3:
        break
      elif counter == 2:
        continue
      else:
        sync()
      end
    end
  end
  handle = run worker()
  join handle
  kill handle
  enter_critical
  exit_critical
  halt
end
"""
    (program,) = parse(source).body
    assert isinstance(program, nodes.FunctionDef) and program.name == "prog"
    kinds = [type(s).__name__ for s in program.body]
    assert kinds == ["GlobalDecl", "FunctionDef", "ThreadDef", "Assign", "Join", "Kill", "EnterCritical",
                     "ExitCritical", "Halt"]
    add = program.body[1]
    assert [p.name for p in add.params] == ["a", "b"] and add.params[1].default.value == 2
    loop = program.body[2].body[0]
    branches = loop.body[1]
    assert len(branches.branches) == 2 and branches.orelse is not None
    assert isinstance(program.body[3].value, nodes.Run)


def test_sec_program():
    (program,) = parse('sec check():\n  textmsg("sec")\nend\n').body
    assert isinstance(program, nodes.SecDef) and program.name == "check"


def test_expression_continues_inside_brackets_and_after_an_operator():
    (statement,) = parse("x = (1 +\n     2) *\n    3\n").body
    assert shape(statement.value) == ("*", ("+", 1, 2), 3)
    (call,) = parse("movej([0, 0, 0,\n  0, 0, 0],\n  a=1.0)\n").body
    assert len(call.expr.args[0].items) == 6


def test_statements_may_share_a_line_and_comments_are_ignored():
    body = parse("x = 1 y = 2 # comment\n\n   # only a comment\nz = x + y\n").body
    assert [s.name for s in body] == ["x", "y", "z"]


def test_ur_rtde_register_offset_injection_form():
    """ur_rtde injects the offset after the comment's newline: `= # comment\\n0    global next = ...`."""
    source = ("    global reg_offset_float = # float register offset\n"
              "24    global reg_offset_int = # int register offset\n"
              "24    global force_mode_type = 2\n")
    body = parse(source).body
    assert [(s.name, s.value.value) for s in body] == [
        ("reg_offset_float", 24), ("reg_offset_int", 24), ("force_mode_type", 2)]


def test_one_line_if():
    (statement,) = parse("if x > 1: y = 2 else: y = 3 end\n").body
    assert isinstance(statement, nodes.If) and statement.orelse[0].name == "y"


def test_return_without_value_before_end():
    (function,) = parse("def f():\n  return\nend\n").body
    assert function.body[0].value is None


def test_positions_are_one_based_line_and_column():
    (function,) = parse("def f():\n  textmsg(1)\nend\n").body
    call = function.body[0].expr
    assert (call.line, call.column) == (2, 3)


@pytest.mark.parametrize(
    "source, line, column",
    [
        ("x = = 1\n", 1, 5),
        ("def f():\n  y = 1\n  z = (2 + \nend\n", 4, 1),
        ("def f():\n  if x:\n    y = 1\nend\n", 4, 4),  # input ends after the `end` that closed the `if`
        ("x = 1\ny = 2 +* 3\n", 2, 8),
    ],
)
def test_syntax_errors_report_line_and_column(source, line, column):
    with pytest.raises(URScriptSyntaxError) as caught:
        parse(source)
    assert (caught.value.line, caught.value.column) == (line, column)
    assert caught.value.text.startswith(f"syntax_error_on_line:{caught.value.line}:")


def test_unterminated_def_is_a_syntax_error():
    with pytest.raises(URScriptSyntaxError):
        parse("def f():\n  x = 1\n")


def test_assignment_target_must_be_a_variable():
    with pytest.raises(URScriptSyntaxError) as caught:
        parse("f() = 1\n")
    assert caught.value.line == 1


def test_source_must_be_text():
    with pytest.raises(ValueError, match="source must be str"):
        parse(b"x = 1\n")


@pytest.mark.parametrize(
    "source, kind, column",
    [
        ("  halt\n", nodes.Halt, 3),
        ("  break\n", nodes.Break, 3),
        ("  continue\n", nodes.Continue, 3),
        ("  enter_critical\n", nodes.EnterCritical, 3),
        ("  exit_critical\n", nodes.ExitCritical, 3),
        ("  return\n", nodes.Return, 3),
        ("  kill t\n", nodes.Kill, 3),
        ("  join t\n", nodes.Join, 3),
        ("  global g = 1\n", nodes.GlobalDecl, 3),
        ("  local l = 1\n", nodes.LocalDecl, 3),
        ("  while True:\n  end\n", nodes.While, 3),
        ("  if True:\n  end\n", nodes.If, 3),
        ("  def f():\n  end\n", nodes.FunctionDef, 3),
        ("  thread t():\n  end\n", nodes.ThreadDef, 3),
        ("  sec s():\n  end\n", nodes.SecDef, 3),
        ("  x[1] = 2\n", nodes.Assign, 3),
    ],
)
def test_a_statement_starts_at_its_keyword_or_target(source, kind, column):
    (statement,) = parse(source).body
    assert isinstance(statement, kind) and (statement.line, statement.column) == (1, column)


@pytest.mark.parametrize(
    "text, kind, column",
    [
        ("True", nodes.Literal, 5),
        ("False", nodes.Literal, 5),
        ("[]", nodes.ListExpr, 5),
        ("[1, 2]", nodes.ListExpr, 5),
        ("(1, 2)", nodes.ListExpr, 5),
        ("run t()", nodes.Run, 5),
        ("-a", nodes.Unary, 5),
        ("a + b", nodes.Binary, 5),
        ("(a + b) * c", nodes.Binary, 6),  # a parenthesised expression starts inside its parenthesis
        ("p[0, 0, 0, 0, 0, 0]", nodes.PoseExpr, 5),
        ("f(k=1)", nodes.Call, 5),
    ],
)
def test_an_expression_starts_at_its_first_token(text, kind, column):
    value = only_expression(text)
    assert isinstance(value, kind) and (value.line, value.column) == (1, column)


def test_a_program_parsed_again_gives_the_same_nodes_and_the_same_error():
    source = "def f():\n  x = [1, 2]\n  textmsg(x)\nend\n"
    assert parse(source) == parse(source)
    for _ in range(2):
        with pytest.raises(URScriptSyntaxError, match="line 2"):
            parse("x = 1\ny = = 2\n")
