"""A program's installation, as far as an import needs it: the names the installation gave to I/O pins.

A `.urp` names its installation (`<URProgram installation="default" installationRelativePath="default">`: a
`default.installation` beside the program, gzip XML with root `<Installation>`). Its `<IOs>` lists a name per pin,
e.g. `<AnalogOutputNames value="a, b"/>`: a program then refers to `analog_out[0]` as `a`. Nothing else of the
installation (TCP, payload, safety, mounting) is read.
"""
from __future__ import annotations

import os
from pathlib import Path

from ur3dq.polyscope.urp_file import ProgramTree, parse_xml, read_bounded, xml_bytes

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


def installation_pin_aliases(program: ProgramTree, program_path: str | os.PathLike[str]) -> dict[str, str]:
    """{name the installation gave a pin: PolyScope's default name}, from the installation file beside the
    program (`<installationRelativePath>.installation`); empty when there is none. UrpFileError when it exists
    but cannot be read."""
    relative = program.root.get("installationRelativePath") or program.root.get("installation") or "default"
    path = Path(program_path).parent / (relative + ".installation")
    if not path.is_file():
        return {}
    installation = parse_xml(xml_bytes(read_bounded(path), str(path)), str(path), "Installation")
    aliases: dict[str, str] = {}
    ios = installation.root.find("IOs")
    for tag, family in NAME_LISTS.items():
        names = ios.find(tag) if ios is not None else None
        if names is None:
            continue
        for number, name in enumerate(part.strip() for part in (names.get("value") or "").split(",")):
            if name:
                aliases[name] = f"{family}[{number}]"
    return aliases
