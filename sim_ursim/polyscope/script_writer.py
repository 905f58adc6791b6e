"""ScriptWriter: URScript lines with PolyScope's indentation and `$ N "label"` line markers; number formatting."""
import math

from polyscope_format.script_lines import ScriptLines


class ScriptWriter(ScriptLines):
    """Collects URScript lines; `indented()` nests a block, `marker(label)` writes PolyScope's `$ N "label"` line.

    >>> writer = ScriptWriter()
    >>> writer.marker("Wait: 0.5"); writer.line("sleep(0.5)")
    >>> writer.text()
    '$ 1 "Wait: 0.5"\\nsleep(0.5)\\n'
    """

    def __init__(self, first_marker: int = 1) -> None:
        super().__init__()
        self.next_marker = first_marker

    def marker(self, label: str) -> None:
        """PolyScope's line marker for the program tree (the interpreter reads it as a comment)."""
        self.line(f"$ {self.next_marker} \"{safe_text(label)}\"")
        self.next_marker += 1


def safe_text(text: str) -> str:
    """`text` made safe inside a URScript string literal, which has no escapes: double quotes become single ones,
    line breaks spaces."""
    return text.replace('"', "'").replace("\r", " ").replace("\n", " ")


def string_literal(text: str) -> str:
    """A URScript string literal holding `text` (see safe_text)."""
    return f"\"{safe_text(text)}\""


def number(value: float) -> str:
    """A finite float as URScript reads it back exactly (Python's shortest round-trip repr)."""
    if not math.isfinite(value):
        raise ValueError(f"{value!r} is not a finite number")
    return repr(float(value))


def number_list(values: list[float], pose: bool = False) -> str:
    """`[a, b, ...]`, or `p[...]` for a pose."""
    return ("p[" if pose else "[") + ", ".join(number(v) for v in values) + "]"
