"""The simulator's load error for PolyScope programs."""
from polyscope_format.urp_file import UrpFormatError


class UrpError(UrpFormatError):
    """A PolyScope program this simulator cannot run (a node or setting it does not play); the message says what
    is wrong and where. A file that is not a readable program at all raises its base class, UrpFormatError: the
    dashboard answers both with PolyScope's load error."""
