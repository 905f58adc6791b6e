"""Read a PolyScope `.urp` file safely: (gzip-compressed) XML under hard bounds, parsed without DTDs or entities.

A `.urp` is what PolyScope's XStream serialiser writes, gzip-compressed by PolyScope 5 (3.x saved plain XML):
`<URProgram>` with `<kinematics>` and the program tree under `<children>`. An object that occurs twice is written
once and referred to by a relative XPath, `<pin reference="../../Set/pin"/>`; `ProgramTree.resolve` follows it.
A `.installation` is read the same way (root `<Installation>`).

Hostile or broken files end in `UrpFormatError`, one line naming the file and the problem, never in a hang or an
exhausted memory: the file's size, the decompressed size, the element count and the nesting depth are bounded
before anything is built, and `defusedxml` refuses DTDs and entity declarations (billion laughs, external
entities).

>>> tree = parse_urp_bytes(b'<URProgram name="p"><children><MainProgram/></children></URProgram>', "p.urp")
>>> tree.name, tree.root[0][0].tag, tree.path_of(tree.root[0][0])
('p', 'MainProgram', 'URProgram/MainProgram')
"""
from __future__ import annotations

import io
import os
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import Element, ParseError

import defusedxml.ElementTree as safe_xml
from defusedxml import DefusedXmlException

MAX_FILE_BYTES = 16 * 1024 * 1024  # a real program is kilobytes; thousands of waypoints stay far below this
MAX_XML_BYTES = 32 * 1024 * 1024  # decompressed: bounds a gzip bomb before it is parsed
MAX_ELEMENTS = 250_000
MAX_DEPTH = 200  # a waypoint's position sits ~10 levels deep; each If/Loop level adds 2
MAX_REFERENCE_HOPS = 32
GZIP_MAGIC = b"\x1f\x8b"
_STEP = re.compile(r"^([A-Za-z_][\w.\-]*)(?:\[(\d+)\])?$")


class UrpFormatError(ValueError):
    """A file that is not a readable PolyScope program or installation (corrupt, truncated, too big, hostile XML,
    a broken reference); the message names the file and what is wrong."""


@dataclass(frozen=True)
class ProgramTree:
    """A parsed `.urp`: the `<URProgram>` root and every element's parent (for references and error paths).

    `pin_aliases` maps the names the program's installation gave to I/O pins to PolyScope's default names
    (`installation.with_installation` fills it in).
    """

    root: Element
    parents: dict[Element, Element]
    source: str
    pin_aliases: dict[str, str] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """The program's name as saved (`<URProgram name=...>`), or the file's stem."""
        return self.root.get("name") or Path(self.source).stem

    def resolve(self, element: Element) -> Element:
        """The element `element` stands for: itself, or the target of its `reference` attribute (followed)."""
        for _ in range(MAX_REFERENCE_HOPS):
            reference = element.get("reference")
            if reference is None:
                return element
            element = self._follow(element, reference)
        raise UrpFormatError(f"{self.source}: references nested deeper than {MAX_REFERENCE_HOPS} at "
                             f"{self.path_of(element)}")

    def _follow(self, start: Element, reference: str) -> Element:
        current: Element | None = start
        for step in reference.split("/"):
            if current is None:
                break
            if step == "..":
                current = self.parents.get(current)
                continue
            match = _STEP.match(step)
            if match is None:
                current = None
                break
            matching = [child for child in current if child.tag == match.group(1)]
            index = int(match.group(2) or 1)
            current = matching[index - 1] if 0 < index <= len(matching) else None
        if current is None:
            raise UrpFormatError(f"{self.source}: broken reference {reference!r} at {self.path_of(start)}")
        return current

    def path_of(self, element: Element) -> str:
        """Where `element` sits in the XML, for messages: tags from the root with 1-based indices where a tag
        repeats, `children` left out (`URProgram/MainProgram/Set[3]/pin`)."""
        steps = []
        current: Element | None = element
        while current is not None:
            parent = self.parents.get(current)
            if current.tag != "children":
                label = current.tag
                if parent is not None:
                    same = [child for child in parent if child.tag == current.tag]
                    if len(same) > 1:
                        label += f"[{same.index(current) + 1}]"
                steps.append(label)
            current = parent
        return "/".join(reversed(steps))


def read_urp(path: str | os.PathLike[str]) -> ProgramTree:
    """Parse the `.urp` at `path`; UrpFormatError (one line naming the problem) when it is not a readable program."""
    return parse_urp_bytes(_read_bounded(path), str(path))


def parse_urp_bytes(content: bytes, source: str = "<urp>") -> ProgramTree:
    """Parse the bytes of a `.urp` (gzip-compressed XML, or plain XML as PolyScope 3.x saved it); `source` names it
    in messages."""
    return _parse_xml(_xml_bytes(content, source), source, "URProgram")


def read_installation(path: str | os.PathLike[str]) -> ProgramTree:
    """Parse a PolyScope `.installation` (gzip XML, root `<Installation>`) under the same bounds as a program."""
    return _parse_xml(_xml_bytes(_read_bounded(path), str(path)), str(path), "Installation")


def _xml_bytes(content: bytes, source: str) -> bytes:
    """The XML of a file: decompressed when gzip, as it is when it already is XML (PolyScope 3.x's plain files)."""
    if content.startswith(GZIP_MAGIC):
        return _decompressed(content, source)
    if content.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<"):
        return content
    raise UrpFormatError(f"{source}: not a PolyScope program (a .urp is XML, gzip-compressed by PolyScope 5; this "
                         "file is neither)")


def _read_bounded(path: str | os.PathLike[str]) -> bytes:
    """The bytes of `path`, refused before reading when it is larger than any PolyScope program."""
    try:
        size = os.path.getsize(path)
        if size > MAX_FILE_BYTES:
            raise UrpFormatError(f"{path}: {size / 1e6:.0f} MB is larger than a PolyScope program can be "
                                 f"(at most {MAX_FILE_BYTES // (1024 * 1024)} MB)")
        with open(path, "rb") as urp:
            return urp.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        raise UrpFormatError(f"{path}: cannot be read: {error.strerror or error}") from None


def _decompressed(compressed: bytes, source: str) -> bytes:
    decompressor = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
    try:
        xml = decompressor.decompress(compressed, MAX_XML_BYTES + 1)
    except zlib.error as error:
        raise UrpFormatError(f"{source}: corrupt gzip data ({error}); copy the file again") from None
    if len(xml) > MAX_XML_BYTES:
        raise UrpFormatError(f"{source}: decompresses to more than {MAX_XML_BYTES // (1024 * 1024)} MB of XML; "
                             "refused (a PolyScope program is far smaller)")
    if not decompressor.eof:
        raise UrpFormatError(f"{source}: truncated (the gzip stream ends early); copy the file again")
    return xml


def _parse_xml(xml: bytes, source: str, root_tag: str) -> ProgramTree:
    """The tree of `xml`, counting elements and depth while parsing; UrpFormatError when the root is not
    `root_tag` or a bound is passed."""
    parents: dict[Element, Element] = {}
    stack: list[Element] = []
    root: Element | None = None
    count = 0
    try:
        for event, element in safe_xml.iterparse(io.BytesIO(xml), events=("start", "end"), forbid_dtd=True):
            if event == "end":
                stack.pop()
                continue
            count += 1
            if len(stack) >= MAX_DEPTH or count > MAX_ELEMENTS:
                what = f"nested deeper than {MAX_DEPTH} levels" if len(stack) >= MAX_DEPTH else \
                    f"more than {MAX_ELEMENTS} elements"
                raise UrpFormatError(f"{source}: refused: the XML is {what} (a PolyScope program is not)")
            if stack:
                parents[element] = stack[-1]
            else:
                root = element
            stack.append(element)
    except DefusedXmlException as error:
        raise UrpFormatError(f"{source}: refused: the XML declares {_forbidden(error)}, which PolyScope never "
                             "writes") from None
    except ParseError as error:
        raise UrpFormatError(f"{source}: not a PolyScope program (its XML does not parse: {error})") from None
    if root is None or root.tag != root_tag:
        found = "empty" if root is None else f"<{root.tag}>"
        what = "program" if root_tag == "URProgram" else "installation"
        raise UrpFormatError(f"{source}: not a PolyScope {what} (the XML's root is {found}, not <{root_tag}>)")
    return ProgramTree(root, parents, source)


def _forbidden(error: DefusedXmlException) -> str:
    kind = type(error).__name__
    return {"DTDForbidden": "a DTD", "EntitiesForbidden": "entities",
            "ExternalReferenceForbidden": "an external reference"}.get(kind, kind)
