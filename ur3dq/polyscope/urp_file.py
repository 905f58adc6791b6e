"""Read a PolyScope `.urp` (and its installation's pin names) with ur3dq's errors.

The reading itself is polyscope_format's (gzip or plain XML under hard bounds, no DTDs or entities, references
resolved; docs/polyscope.md); here a file that is not a readable program becomes `UrpFileError`, one of ur3dq's
store errors: one line naming the file and the problem, exit code 3 on the command line.

>>> tree = parse_urp_bytes(b'<URProgram name="p"><children><MainProgram/></children></URProgram>', "p.urp")
>>> tree.name, tree.root[0][0].tag
('p', 'MainProgram')
>>> parse_urp_bytes(b"PK\\x03\\x04", "cell.urp")
Traceback (most recent call last):
...
ur3dq.polyscope.urp_file.UrpFileError: cell.urp: not a PolyScope program (a .urp is XML, gzip-compressed by ...
"""
from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

from polyscope_format import installation, urp_file
from polyscope_format.urp_file import ProgramTree, UrpFormatError
from ur3dq.errors import StoreError


class UrpFileError(StoreError):
    """A file that is not a readable PolyScope program (corrupt, truncated, too big, hostile XML): a file problem,
    exit code 3 on the command line; the message names the file and what is wrong."""


@contextmanager
def urp_file_errors() -> Iterator[None]:
    """Turn polyscope_format's UrpFormatError raised inside the `with` block into UrpFileError (same message)."""
    try:
        yield
    except UrpFormatError as error:
        raise UrpFileError(str(error)) from None


def read_urp(path: str | os.PathLike[str]) -> ProgramTree:
    """Parse the `.urp` at `path`; UrpFileError (one line naming the problem) when it is not a readable program."""
    with urp_file_errors():
        return urp_file.read_urp(path)


def parse_urp_bytes(content: bytes, source: str = "<urp>") -> ProgramTree:
    """Parse the bytes of a `.urp` (gzip-compressed XML, or plain XML as PolyScope 3.x saved it); `source` names it
    in messages."""
    with urp_file_errors():
        return urp_file.parse_urp_bytes(content, source)


def installation_pin_aliases(program: ProgramTree, program_path: str | os.PathLike[str]) -> dict[str, str]:
    """{name the installation gave a pin: PolyScope's default name}, from the installation file beside the
    program (`<installationRelativePath>.installation`); empty when there is none. UrpFileError when it exists
    but cannot be read."""
    with urp_file_errors():
        return installation.with_installation(program, program_path).pin_aliases
