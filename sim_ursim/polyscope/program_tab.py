"""The pendant's program tab as dashboard `load` and `play` drive it: which program is loaded, and its script.

`load X` reads X from the programs directory (`--programs-dir`; sub-directories as `sub/X.urp`; an absolute path as
it is, or under the programs directory when it names the controller's own programs folder, `/ursim/programs/...`
in URSim, `/programs/...` on a robot). A `.urp` is parsed and translated once to refuse, at load, what could not
run (PolyScope's load error); any other file is taken as URScript. `play` generates the `.urp`'s script again, as
PolyScope does, so an External Control node fetches its program from the remote PC at that moment.

The loaded program lives on the controller (`controller.loaded_program`: its path; `loaded_program_source`: the
URScript text, or the parsed `.urp`), so every dashboard connection sees the same one.

>>> tab = ProgramTab(controller, ExternalControlSettings("127.0.0.2"))   # doctest: +SKIP
>>> tab.load("wait_program.urp")                                         # doctest: +SKIP
'Loading program: wait_program.urp'
"""
import logging
import os
from typing import Protocol
from xml.etree.ElementTree import Element

from polyscope_format.installation import with_installation
from polyscope_format.urp_file import ProgramTree, UrpFormatError, read_urp

from ..vocabulary import ControllerState
from .errors import UrpError
from .external_control import ExternalControl, ExternalControlSettings, check_supported
from .translation import program_urscript

log = logging.getLogger("sim_ursim.polyscope")

# Where controllers keep their programs, as clients name them in absolute paths (URSim's image; a robot).
CONTROLLER_PROGRAM_ROOTS = ("/ursim/programs", "/programs")
MAX_SCRIPT_BYTES = 4 * 1024 * 1024


class ProgramController(Protocol):
    """What the program tab uses of the controller (sim_ursim.controller.Controller)."""

    programs_directory: str | None
    loaded_program: str | None
    loaded_program_source: "str | ProgramTree | None"

    def state(self) -> ControllerState: ...

    def stop_program(self) -> None: ...


class ProgramTab:
    """Load and play programs on `controller` the way PolyScope does (the dashboard's program commands)."""

    def __init__(self, controller: ProgramController, external_control: ExternalControlSettings | None = None) -> None:
        self.controller = controller
        self.external_control = external_control or ExternalControlSettings()

    def resolve(self, argument: str) -> str:
        """The file a `load` argument names (see the module docstring); the path need not exist."""
        directory = self.controller.programs_directory or os.getcwd()
        if not os.path.isabs(argument):
            return os.path.join(directory, argument)
        if os.path.exists(argument):
            return argument
        for root in CONTROLLER_PROGRAM_ROOTS:
            if argument.startswith(root + "/"):
                return os.path.join(directory, argument[len(root) + 1:])
        return argument

    def load(self, argument: str) -> str:
        """Load the program `argument` names; the dashboard's reply line."""
        path = self.resolve(argument)
        if not os.path.isfile(path):
            return f"File not found: {argument}"
        try:
            program = self._read(path)
        except (UrpFormatError, OSError, UnicodeDecodeError) as error:
            log.warning("load %s: %s", argument, error)
            return f"Error while loading program: {argument}"
        if self.controller.state().program_running:
            self.controller.stop_program()
        self.controller.loaded_program = path
        self.controller.loaded_program_source = program
        log.info("loaded program %s", path)
        return f"Loading program: {argument}"

    def _read(self, path: str) -> "str | ProgramTree":
        if path.lower().endswith(".urp"):
            tree = with_installation(read_urp(path), path)
            program_urscript(tree, _checked_only)  # what would not run is refused now, as PolyScope's load does
            return tree
        if os.path.getsize(path) > MAX_SCRIPT_BYTES:
            raise UrpError(f"{path}: larger than {MAX_SCRIPT_BYTES // (1024 * 1024)} MB")
        with open(path, encoding="utf-8") as script:
            return script.read()

    def script_for_play(self) -> str | None:
        """The URScript `play` runs: a `.urp`'s script generated now (URCap programs fetched), or the loaded script;
        None when nothing is loaded or the script cannot be generated (logged)."""
        loaded = self.controller.loaded_program_source
        if loaded is None or isinstance(loaded, str):
            return loaded
        try:
            return program_urscript(loaded, ExternalControl(self.external_control))
        except UrpFormatError as error:
            log.warning("play %s: %s", self.controller.loaded_program, error)
            return None


def _checked_only(tree: ProgramTree, node: Element) -> str:
    """A URCap node at load: checked to be one the simulator plays; its program is fetched only at play."""
    check_supported(tree, node)
    return ""
