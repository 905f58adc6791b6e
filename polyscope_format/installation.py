"""A program's installation, as far as a program's nodes need it: the names the installation gave to I/O pins.

A `.urp` names its installation (`<URProgram installation="default" installationRelativePath="default">`: a
`default.installation` beside the program, gzip XML with root `<Installation>`). Its `<IOs>` lists a name per pin,
e.g. `<AnalogOutputNames value="a, b"/>`: a program then refers to `analog_out[0]` as `a`. Nothing else of the
installation (TCP, payload, safety, mounting, I/O setup) is read.

>>> from xml.etree.ElementTree import fromstring
>>> installation = fromstring('<Installation><IOs><AnalogOutputNames value="a, b"/></IOs></Installation>')
>>> pin_aliases(ProgramTree(installation, {}, "default.installation"))
{'a': 'analog_out[0]', 'b': 'analog_out[1]'}
"""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from polyscope_format.urp_file import ProgramTree, read_installation

# <IOs> name list -> PolyScope's default name of those pins
NAME_LISTS = {
    "DigitalInputNames": "digital_in",
    "DigitalOutputNames": "digital_out",
    "ConfigurableInputNames": "config_in",
    "ConfigurableOutputNames": "config_out",
    "ToolDigitalInputNames": "tool_in",
    "ToolDigitalOutputNames": "tool_out",
    "AnalogInputNames": "analog_in",
    "AnalogOutputNames": "analog_out",
    "ToolAnalogInputNames": "tool_analog_in",
}


def installation_path(program: ProgramTree, program_path: str | os.PathLike[str]) -> Path:
    """Where the program's installation file is: `<installationRelativePath>.installation` beside the program."""
    relative = program.root.get("installationRelativePath") or program.root.get("installation") or "default"
    return Path(program_path).parent / (relative + ".installation")


def pin_aliases(installation: ProgramTree) -> dict[str, str]:
    """{name given in the installation: PolyScope's default pin name} for every named pin."""
    aliases: dict[str, str] = {}
    ios = installation.root.find("IOs")
    if ios is None:
        return aliases
    for tag, family in NAME_LISTS.items():
        names = ios.find(tag)
        if names is None:
            continue
        for number, name in enumerate(part.strip() for part in (names.get("value") or "").split(",")):
            if name:
                aliases[name] = f"{family}[{number}]"
    return aliases


def with_installation(program: ProgramTree, program_path: str | os.PathLike[str]) -> ProgramTree:
    """`program` knowing its installation's pin names (unchanged when there is no installation file; UrpFormatError
    for an installation that cannot be read, which PolyScope would not load the program with either)."""
    path = installation_path(program, program_path)
    if not path.is_file():
        return program
    return dataclasses.replace(program, pin_aliases=pin_aliases(read_installation(path)))
