"""PolyScope's XML text: elements written as its XStream serialiser writes them, numbers as Java prints doubles.

The layout follows the programs PolyScope saved (URCL's test programs): no XML declaration, two spaces of indent
per level, `<tag attr="value"/>` for an empty element, text content on the element's line, attributes in the order
given. Doubles are Java's `Double.toString`: the shortest digits that read back, `1.0`, `-0.425`, `1.0E-4`,
`8.844411260213857E-8` (scientific below 10⁻³ and from 10⁷ on). The same tree always gives the same bytes.

>>> java_double(0.5), java_double(1e-4), java_double(-8.844411260213857e-08), java_double(2.0)
('0.5', '1.0E-4', '-8.844411260213857E-8', '2.0')
>>> text(element("Wait", {"type": "Sleep"}, [element("waitTime", text="0.01")]))
'<Wait type="Sleep">\\n  <waitTime>0.01</waitTime>\\n</Wait>\\n'
"""
from __future__ import annotations

import gzip
import math
from collections.abc import Iterable, Mapping
from decimal import Decimal
from xml.etree.ElementTree import Element

_ESCAPES = str.maketrans({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "\n": "&#10;", "\r": "&#13;",
                          "\t": "&#9;"})
_TEXT_ESCAPES = str.maketrans({"&": "&amp;", "<": "&lt;", ">": "&gt;", "\r": "&#13;"})


def java_double(value: float) -> str:
    """`value` as Java's Double.toString writes it (shortest round-trip digits)."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{value!r} is not a finite number")
    if value == 0:
        return "-0.0" if math.copysign(1.0, value) < 0 else "0.0"
    sign, digits, exponent = Decimal(repr(value)).as_tuple()
    assert isinstance(exponent, int)
    figures = "".join(str(d) for d in digits).rstrip("0") or "0"
    point = len(digits) + exponent   # the decimal point sits after this many of the digits
    prefix = "-" if sign else ""
    if 1e-3 <= abs(value) < 1e7:
        if point <= 0:
            return f"{prefix}0.{'0' * -point}{figures}"
        whole, fraction = figures[:point].ljust(point, "0"), figures[point:]
        return f"{prefix}{whole}.{fraction or '0'}"
    return f"{prefix}{figures[0]}.{figures[1:] or '0'}E{point - 1}"


def doubles(values: Iterable[float]) -> str:
    """A list of doubles as PolyScope writes vectors: `a, b, c`."""
    return ", ".join(java_double(value) for value in values)


def element(tag: str, attributes: Mapping[str, str] | None = None, children: Iterable[Element] = (),
            text: str | None = None) -> Element:
    """An element with `attributes` (kept in this order), `children` and `text`."""
    node = Element(tag, dict(attributes or {}))
    node.extend(children)
    node.text = text
    return node


def text(node: Element, depth: int = 0) -> str:
    """The XML text of `node` and everything under it, PolyScope's layout."""
    indent = "  " * depth
    attributes = "".join(f' {name}="{str(value).translate(_ESCAPES)}"' for name, value in node.attrib.items())
    if len(node) == 0:
        if node.text is None:
            return f"{indent}<{node.tag}{attributes}/>\n"
        return f"{indent}<{node.tag}{attributes}>{node.text.translate(_TEXT_ESCAPES)}</{node.tag}>\n"
    inner = "".join(text(child, depth + 1) for child in node)
    return f"{indent}<{node.tag}{attributes}>\n{inner}{indent}</{node.tag}>\n"


def file_bytes(root: Element, compressed: bool) -> bytes:
    """The bytes of a `.urp` holding `root`: gzip with no time stamp or file name (PolyScope 5), or the plain XML
    (PolyScope 3.x); the same tree always gives the same bytes."""
    data = text(root).encode("utf-8")
    return gzip.compress(data, compresslevel=9, mtime=0) if compressed else data
