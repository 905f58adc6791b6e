"""URScript lines as PolyScope writes the script of a program: two spaces of indent per block level.

>>> lines = ScriptLines()
>>> lines.line("while (True):")
>>> with lines.indented():
...     lines.line("sync()")
>>> lines.line("end")
>>> lines.text()
'while (True):\\n  sync()\\nend\\n'
"""
from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager


class ScriptLines:
    """Collects URScript lines; `indented()` nests a block."""

    INDENT = "  "

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.depth = 0

    def line(self, text: str) -> None:
        """Append one line at the current depth (a multi-line text is split and each line indented; blank lines
        stay empty)."""
        for part in text.split("\n"):
            self.lines.append(self.INDENT * self.depth + part.rstrip() if part.strip() else "")

    @contextmanager
    def indented(self) -> Iterator[None]:
        """Lines written inside the `with` block are one level deeper."""
        self.depth += 1
        try:
            yield
        finally:
            self.depth -= 1

    def text(self) -> str:
        """Every line, newline-terminated."""
        return "".join(line + "\n" for line in self.lines)
