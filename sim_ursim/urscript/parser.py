"""URScript source -> syntax tree (sim_ursim.urscript.nodes), with lark and the grammar file urscript.lark.

Parsing only: no controller, no execution. Errors are `URScriptSyntaxError` carrying line, column and the text the
controller would publish as a runtime-exception message.
"""
import functools
from pathlib import Path

import lark
from lark import Lark, Transformer

from sim_ursim.urscript import nodes

GRAMMAR_PATH = Path(__file__).with_name("urscript.lark")

# After one of these tokens a newline cannot end the statement, so the expression continues on the next line.
_CONTINUES_AFTER = frozenset(
    {"OR", "XOR", "AND", "NOT", "EQUALITY", "RELATION", "ADD_OP", "MUL_OP", "EQUAL", "COMMA", "LPAR", "LSQB"}
)
_OPENING = frozenset({"LPAR", "LSQB"})
_CLOSING = frozenset({"RPAR", "RSQB"})


class URScriptSyntaxError(ValueError):
    """A script the controller would refuse to compile; `text` is the runtime-exception message text."""

    def __init__(self, line, column, text):
        super().__init__(f"line {line}, column {column}: {text}")
        self.line = line
        self.column = column
        self.text = text


class _LineJoiner:
    """Postlexer: drops newlines inside brackets and after an operator, so expressions span lines."""

    always_accept = ("_NL",)

    def process(self, stream):
        """Yield the tokens of `stream` minus the newlines that do not end a statement."""
        depth = 0
        previous_type = "_NL"
        for token in stream:
            if token.type == "_NL":
                if depth > 0 or previous_type in _CONTINUES_AFTER or previous_type == "_NL":
                    continue
            elif token.type in _OPENING:
                depth += 1
            elif token.type in _CLOSING:
                depth = max(0, depth - 1)
            previous_type = token.type
            yield token


@functools.lru_cache(maxsize=1)
def _lark_parser():
    """The LALR parser, built once per process; lark's cache file (temp dir) saves the ~0.5 s build next time.

    Nodes are built while parsing (lark's `transformer=` option): no intermediate tree and no propagated
    positions, which made a 48 KB program (URCL's External Control script) take twice as long to start.
    """
    return Lark(
        GRAMMAR_PATH.read_text(),
        parser="lalr",
        postlex=_LineJoiner(),
        maybe_placeholders=True,
        transformer=_ToNodes(),
        cache=True,
    )


def _number(text):
    """URScript number literal -> int when it has no point or exponent, else float."""
    if any(ch in text for ch in ".eE"):
        return float(text)
    return int(text)


def _at(first):
    """Position keywords {line, column} (1-based) of a token or node: a node starts at its first token."""
    return {"line": first.line, "column": first.column}


def _syntax_error(first, text):
    """URScriptSyntaxError at the position of `first` (token or node) with the controller's message `text`."""
    return URScriptSyntaxError(first.line, first.column, f"syntax_error_on_line:{first.line}:{text}:")


class _ToNodes(Transformer):
    """Parse callbacks: lark rule -> nodes.*. Each receives the rule's kept tokens and already built nodes; the
    grammar names the keyword or bracket that starts a rule, so the first child always carries the node's position.
    A parenthesised expression starts at its first token inside the parenthesis."""

    def start(self, children):
        (block,) = children
        return nodes.Script(block, **(_at(block[0]) if block else {}))

    def block(self, children):
        return tuple(children)

    # --- definitions
    def funcdef(self, children):
        keyword, name, *rest = children
        params = tuple(p for p in rest[:-1] if p is not None)
        return nodes.FunctionDef(str(name), params, rest[-1], **_at(keyword))

    def param(self, children):
        name, default = children
        return nodes.Param(str(name), default, **_at(name))

    def threaddef(self, children):
        keyword, name, body = children
        return nodes.ThreadDef(str(name), body, **_at(keyword))

    def secdef(self, children):
        keyword, name, body = children
        return nodes.SecDef(str(name), body, **_at(keyword))

    # --- control flow
    def if_stmt(self, children):
        keyword, condition, body, *rest = children
        orelse = rest.pop() if rest else None
        branches = ((condition, body),) + tuple(rest)
        return nodes.If(branches, orelse, **_at(keyword))

    def elif_clause(self, children):
        _, condition, body = children
        return (condition, body)

    def else_clause(self, children):
        return children[1]

    def while_stmt(self, children):
        keyword, condition, body = children
        return nodes.While(condition, body, **_at(keyword))

    def return_stmt(self, children):
        keyword, value = children
        return nodes.Return(value, **_at(keyword))

    def halt_stmt(self, children):
        return nodes.Halt(**_at(children[0]))

    def break_stmt(self, children):
        return nodes.Break(**_at(children[0]))

    def continue_stmt(self, children):
        return nodes.Continue(**_at(children[0]))

    def kill_stmt(self, children):
        keyword, name = children
        return nodes.Kill(str(name), **_at(keyword))

    def join_stmt(self, children):
        keyword, name = children
        return nodes.Join(str(name), **_at(keyword))

    def enter_critical(self, children):
        return nodes.EnterCritical(**_at(children[0]))

    def exit_critical(self, children):
        return nodes.ExitCritical(**_at(children[0]))

    # --- variables
    def global_decl(self, children):
        keyword, name, value = children
        return nodes.GlobalDecl(str(name), value, **_at(keyword))

    def local_decl(self, children):
        keyword, name, value = children
        return nodes.LocalDecl(str(name), value, **_at(keyword))

    def assign(self, children):
        target, value = children
        first = target
        indices: list[object] = []
        while isinstance(target, (nodes.Index, nodes.MatrixIndex)):
            if isinstance(target, nodes.MatrixIndex):
                indices[:0] = [target.row_index, target.column_index]
            else:
                indices.insert(0, target.index)
            target = target.target
        if not isinstance(target, nodes.Name):
            raise _syntax_error(first, "cannot assign")
        return nodes.Assign(target.name, tuple(indices), value, **_at(first))

    def expr_stmt(self, children):
        (expr,) = children
        return nodes.ExprStatement(expr, **_at(expr))

    # --- expressions
    def binary(self, children):
        left, op, right = children
        return nodes.Binary(str(op), left, right, **_at(left))

    def unary(self, children):
        op, operand = children
        return nodes.Unary(str(op), operand, **_at(op))

    def subscript(self, children):
        target, *items = children
        # `p[...]` with other than one element is a pose literal; `p[i]` indexes a variable named p.
        if isinstance(target, nodes.Name) and target.name == "p" and len(items) != 1:
            return nodes.PoseExpr(tuple(items), **_at(target))
        if len(items) == 2:
            return nodes.MatrixIndex(target, items[0], items[1], **_at(target))
        if len(items) != 1:
            raise _syntax_error(target, "one index or a row and column expected")
        return nodes.Index(target, items[0], **_at(target))

    def call(self, children):
        name, *arguments = children
        args, kwargs = [], []
        for argument in arguments:
            if argument is None:
                continue
            if isinstance(argument, tuple):
                kwargs.append(argument)
            elif kwargs:
                raise _syntax_error(name, "positional argument after keyword")
            else:
                args.append(argument)
        return nodes.Call(str(name), tuple(args), tuple(kwargs), **_at(name))

    def argument(self, children):
        return children[0]

    def keyword_argument(self, children):
        name, value = children
        return (str(name), value)

    def run(self, children):
        keyword, name = children
        return nodes.Run(str(name), **_at(keyword))

    def number(self, children):
        (token,) = children
        return nodes.Literal(_number(str(token)), **_at(token))

    def string(self, children):
        (token,) = children
        return nodes.Literal(str(token)[1:-1], **_at(token))

    def true(self, children):
        return nodes.Literal(True, **_at(children[0]))

    def false(self, children):
        return nodes.Literal(False, **_at(children[0]))

    def name(self, children):
        (token,) = children
        return nodes.Name(str(token), **_at(token))

    def list(self, children):
        bracket, *items = children
        return nodes.ListExpr(tuple(c for c in items if c is not None), **_at(bracket))


def _source_line(source, line):
    """The text of 1-based `line` of `source` ('' when out of range)."""
    lines = source.splitlines()
    return lines[line - 1].strip() if 0 < line <= len(lines) else ""


def parse(source: str) -> nodes.Script:
    """URScript text -> nodes.Script; raises URScriptSyntaxError (line, column, controller message) if invalid."""
    if not isinstance(source, str):
        raise ValueError(f"source must be str, got {type(source).__name__}")
    return _parse_text(source)


# Clients send the same large program at every connection (URCL's External Control script, ur_rtde's control
# script: tens of kB, ~0.1 s to parse); the nodes are immutable, so a program seen recently is not parsed again.
@functools.lru_cache(maxsize=8)
def _parse_text(source):
    """parse() of a str, remembered for the last few distinct programs (errors are raised again each time)."""
    try:
        return _lark_parser().parse(source if source.endswith("\n") else source + "\n")
    except lark.exceptions.UnexpectedInput as error:
        line = getattr(error, "line", 0) or 0
        column = getattr(error, "column", 0) or 0
        if line <= 0:  # input ended inside a construct: point at the last line
            line = max(1, len(source.splitlines()))
            column = 1
        text = f"syntax_error_on_line:{line}:{_source_line(source, line)}:"
        raise URScriptSyntaxError(line, column, text) from None
