"""URScript source -> syntax tree (sim_ursim.urscript.nodes), with lark and the grammar file urscript.lark.

Parsing only: no controller, no execution. Errors are `URScriptSyntaxError` carrying line, column and the text the
controller would publish as a runtime-exception message.
"""
import functools
from pathlib import Path

import lark
from lark import Lark, Transformer, v_args

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
    """The LALR parser, built once per process; lark's cache file (temp dir) saves the ~0.5 s build next time."""
    return Lark(
        GRAMMAR_PATH.read_text(),
        parser="lalr",
        postlex=_LineJoiner(),
        propagate_positions=True,
        maybe_placeholders=True,
        cache=True,
    )


def _number(text):
    """URScript number literal -> int when it has no point or exponent, else float."""
    if any(ch in text for ch in ".eE"):
        return float(text)
    return int(text)


def _position(meta_or_token):
    """(line, column) of a lark meta or token, 1-based."""
    return {"line": getattr(meta_or_token, "line", 0) or 0, "column": getattr(meta_or_token, "column", 0) or 0}


@v_args(meta=True)
class _ToNodes(Transformer):
    """lark tree -> nodes.*; every node gets the position of its first token."""

    def start(self, meta, children):
        return nodes.Script(children[0], **_position(meta))

    def block(self, meta, children):
        return tuple(children)

    # --- definitions
    def funcdef(self, meta, children):
        name, *rest = children
        body = rest[-1]
        params = tuple(p for p in rest[:-1] if p is not None)
        return nodes.FunctionDef(str(name), params, body, **_position(meta))

    def param(self, meta, children):
        name, default = children
        return nodes.Param(str(name), default, **_position(meta))

    def threaddef(self, meta, children):
        name, body = children
        return nodes.ThreadDef(str(name), body, **_position(meta))

    def secdef(self, meta, children):
        name, body = children
        return nodes.SecDef(str(name), body, **_position(meta))

    # --- control flow
    def if_stmt(self, meta, children):
        condition, body, *rest = children
        orelse = rest.pop() if rest else None
        branches = ((condition, body),) + tuple(rest)
        return nodes.If(branches, orelse, **_position(meta))

    def elif_clause(self, meta, children):
        return tuple(children)

    def else_clause(self, meta, children):
        return children[0]

    def while_stmt(self, meta, children):
        condition, body = children
        return nodes.While(condition, body, **_position(meta))

    def return_stmt(self, meta, children):
        return nodes.Return(children[0], **_position(meta))

    def halt_stmt(self, meta, children):
        return nodes.Halt(**_position(meta))

    def break_stmt(self, meta, children):
        return nodes.Break(**_position(meta))

    def continue_stmt(self, meta, children):
        return nodes.Continue(**_position(meta))

    def kill_stmt(self, meta, children):
        return nodes.Kill(str(children[0]), **_position(meta))

    def join_stmt(self, meta, children):
        return nodes.Join(str(children[0]), **_position(meta))

    def enter_critical(self, meta, children):
        return nodes.EnterCritical(**_position(meta))

    def exit_critical(self, meta, children):
        return nodes.ExitCritical(**_position(meta))

    # --- variables
    def global_decl(self, meta, children):
        name, value = children
        return nodes.GlobalDecl(str(name), value, **_position(meta))

    def local_decl(self, meta, children):
        name, value = children
        return nodes.LocalDecl(str(name), value, **_position(meta))

    def assign(self, meta, children):
        target, value = children
        indices = []
        while isinstance(target, (nodes.Index, nodes.MatrixIndex)):
            if isinstance(target, nodes.MatrixIndex):
                indices[:0] = [target.row_index, target.column_index]
            else:
                indices.insert(0, target.index)
            target = target.target
        if not isinstance(target, nodes.Name):
            raise URScriptSyntaxError(meta.line, meta.column, f"syntax_error_on_line:{meta.line}:cannot assign:")
        return nodes.Assign(target.name, tuple(indices), value, **_position(meta))

    def expr_stmt(self, meta, children):
        return nodes.ExprStatement(children[0], **_position(meta))

    # --- expressions
    def binary(self, meta, children):
        left, op, right = children
        return nodes.Binary(str(op), left, right, **_position(meta))

    def unary(self, meta, children):
        op, operand = children
        return nodes.Unary(str(op), operand, **_position(meta))

    def subscript(self, meta, children):
        target, *items = children
        # `p[...]` with other than one element is a pose literal; `p[i]` indexes a variable named p.
        if isinstance(target, nodes.Name) and target.name == "p" and len(items) != 1:
            return nodes.PoseExpr(tuple(items), **_position(meta))
        if len(items) == 2:
            return nodes.MatrixIndex(target, items[0], items[1], **_position(meta))
        if len(items) != 1:
            raise URScriptSyntaxError(
                meta.line, meta.column, f"syntax_error_on_line:{meta.line}:one index or a row and column expected:"
            )
        return nodes.Index(target, items[0], **_position(meta))

    def call(self, meta, children):
        name, *arguments = children
        args, kwargs = [], []
        for argument in arguments:
            if argument is None:
                continue
            if isinstance(argument, tuple):
                kwargs.append(argument)
            elif kwargs:
                raise URScriptSyntaxError(
                    meta.line, meta.column, f"syntax_error_on_line:{meta.line}:positional argument after keyword:"
                )
            else:
                args.append(argument)
        return nodes.Call(str(name), tuple(args), tuple(kwargs), **_position(meta))

    def argument(self, meta, children):
        return children[0]

    def keyword_argument(self, meta, children):
        name, value = children
        return (str(name), value)

    def run(self, meta, children):
        return nodes.Run(str(children[0]), **_position(meta))

    def number(self, meta, children):
        return nodes.Literal(_number(str(children[0])), **_position(meta))

    def string(self, meta, children):
        return nodes.Literal(str(children[0])[1:-1], **_position(meta))

    def true(self, meta, children):
        return nodes.Literal(True, **_position(meta))

    def false(self, meta, children):
        return nodes.Literal(False, **_position(meta))

    def name(self, meta, children):
        return nodes.Name(str(children[0]), **_position(meta))

    def list(self, meta, children):
        return nodes.ListExpr(tuple(c for c in children if c is not None), **_position(meta))


def _source_line(source, line):
    """The text of 1-based `line` of `source` ('' when out of range)."""
    lines = source.splitlines()
    return lines[line - 1].strip() if 0 < line <= len(lines) else ""


def parse(source: str) -> nodes.Script:
    """URScript text -> nodes.Script; raises URScriptSyntaxError (line, column, controller message) if invalid."""
    if not isinstance(source, str):
        raise ValueError(f"source must be str, got {type(source).__name__}")
    try:
        tree = _lark_parser().parse(source if source.endswith("\n") else source + "\n")
        return _ToNodes().transform(tree)
    except lark.exceptions.VisitError as error:
        if isinstance(error.orig_exc, URScriptSyntaxError):
            raise error.orig_exc from None
        raise
    except lark.exceptions.UnexpectedInput as error:
        line = getattr(error, "line", 0) or 0
        column = getattr(error, "column", 0) or 0
        if line <= 0:  # input ended inside a construct: point at the last line
            line = max(1, len(source.splitlines()))
            column = 1
        text = f"syntax_error_on_line:{line}:{_source_line(source, line)}:"
        raise URScriptSyntaxError(line, column, text) from None
