"""Cutting the URScript byte stream of ports 30001–30003 into programs (pure; no sockets).

A controller runs what a client sends as soon as it is complete (docs/protocols.md §3.6):
- a `def name():` / `sec name():` … `end` block — complete when its `end` closes it (nested `if`, `while`,
  `thread`, `def`, `for` blocks counted; `elif`/`else` neither open nor close);
- otherwise one or more top-level statement lines; an expression with unclosed brackets continues on the next line.
Top-level statement lines that arrive in the same chunk form one program, so a client writing
"set_standard_digital_out(0, True)\\nset_standard_digital_out(1, True)\\n" gets both outputs set, instead of the second
line aborting the first (how the real controller splits such writes is not documented).

What a connection may hold while a program is incomplete is bounded (MAX_PENDING_BYTES, MAX_PENDING_LINES): a
client that exceeds it (an unclosed bracket or block followed by endless lines, an endless line) gets
IntakeOverflow, and the server drops it, as a controller drops a client it cannot serve; well-behaved clients are
not slowed by it.
"""
import re

# A block header: keyword at the start of the line (ur_rtde's `$5.4`-style version tags already removed by the
# client), ending with ':' before any comment.
_BLOCK_OPENER = re.compile(r"^\s*(def|sec|thread|if|while|for)\b[^#]*:\s*(#.*)?$")
_BLOCK_END = re.compile(r"^\s*end\s*(#.*)?$")
_PROGRAM_START = re.compile(r"^\s*(def|sec)\b")
_STRING = re.compile(r'"[^"]*"|\'[^\']*\'')
_COMMENT = re.compile(r"#.*$")

MAX_PENDING_BYTES = 4 * 1024 * 1024  # an incomplete program may hold this much text (real programs: tens of kB)
MAX_PENDING_LINES = 50_000  # ... and this many lines (each held line costs memory beyond its bytes)


class IntakeOverflow(ValueError):
    """A client sent more than the intake holds without completing a program (the message says how much)."""


def _code_of(line: str) -> str:
    """The line without string literals and comment, for bracket counting and block detection."""
    return _COMMENT.sub("", _STRING.sub('""', line))


def _bracket_balance(line: str) -> int:
    """Open minus closed ( and [ brackets on a line (strings and comments ignored)."""
    code = _code_of(line)
    return code.count("(") + code.count("[") - code.count(")") - code.count("]")


def is_block_opener(line: str) -> bool:
    """True for a line that opens a block closed by `end` (def, sec, thread, if, while, for … :)."""
    return bool(_BLOCK_OPENER.match(_code_of(line)))


def is_block_end(line: str) -> bool:
    """True for a line holding only `end` (and maybe a comment)."""
    return bool(_BLOCK_END.match(line))


class ScriptAssembler:
    """Accumulates received bytes; `feed` returns the programs completed by this chunk, in arrival order."""

    def __init__(self) -> None:
        self._partial_line = ""
        self._block_lines: list[str] = []
        self._depth = 0
        self._statement_lines: list[str] = []
        self._bracket_depth = 0
        self._held_bytes = 0  # text held in _block_lines and _statement_lines

    @property
    def pending(self) -> bool:
        """True while an incomplete program or line is buffered."""
        return bool(self._partial_line or self._block_lines or self._statement_lines)

    def feed(self, data: bytes) -> list[str]:
        """Add received bytes (ASCII/UTF-8; undecodable bytes replaced) and return the completed program texts."""
        text = self._partial_line + data.decode("utf-8", errors="replace").replace("\r\n", "\n")
        *lines, self._partial_line = text.split("\n")
        programs = []
        for line in lines:
            programs.extend(self._take_line(line))
        self._check_bounds()
        # Statement lines complete at the end of a chunk (unless an expression is still open).
        if self._bracket_depth <= 0:
            programs.extend(self._take_statements())
        return programs

    def _check_bounds(self) -> None:
        """IntakeOverflow when the incomplete program (or line) exceeds MAX_PENDING_BYTES / MAX_PENDING_LINES."""
        held = self._held_bytes + len(self._partial_line)
        lines = len(self._block_lines) + len(self._statement_lines)
        if held > MAX_PENDING_BYTES or lines > MAX_PENDING_LINES:
            what = "an unclosed block" if self._block_lines else "an unclosed bracket" if lines else "one line"
            raise IntakeOverflow(f"{held} bytes in {lines + 1} lines without completing a program ({what}); the "
                                 f"limit is {MAX_PENDING_BYTES} bytes / {MAX_PENDING_LINES} lines")

    def _take_statements(self) -> list[str]:
        """The held statement lines as one program (a list of zero or one program texts)."""
        if not self._statement_lines:
            return []
        program = "\n".join(self._statement_lines) + "\n"
        self._statement_lines, self._bracket_depth = [], 0
        self._held_bytes = 0
        return [program]

    def _take_line(self, line: str) -> list[str]:
        """Process one complete line; returns the programs it completes (statements held before a block, the block)."""
        if self._depth > 0:
            self._block_lines.append(line)
            self._held_bytes += len(line) + 1
            if is_block_end(line):
                self._depth -= 1
            elif is_block_opener(line):
                self._depth += 1
            if self._depth == 0:
                program = "\n".join(self._block_lines) + "\n"
                self._block_lines, self._held_bytes = [], 0
                return [program]
            self._check_bounds()
            return []
        if self._bracket_depth <= 0 and _PROGRAM_START.match(line) and is_block_opener(line):
            held = self._take_statements()
            self._block_lines = [line]
            self._held_bytes = len(line) + 1
            self._depth = 1
            return held
        if not self._statement_lines and not _code_of(line).strip():
            return []  # blank lines and comments between programs
        self._statement_lines.append(line)
        self._held_bytes += len(line) + 1
        self._bracket_depth += _bracket_balance(line)
        self._check_bounds()
        return []
