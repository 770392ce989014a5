"""The errors every layer raises, each a message naming the problem in one line.

RigError: the rig's own (a configuration, a device, a byte on a wire, a trip).
UsageError: what the user gave us is wrong (an argument, a file that cannot be read as
what it should be, a recording without the channel an analysis needs); the command exits 2.
Refused: what a command made does not meet its bar; nothing written, exit 1."""


class RigError(Exception):
    """Bad configuration, unreachable device, or malformed data from a device."""


class UsageError(Exception):
    """Bad input: one line naming it."""


class Refused(Exception):
    """What a command made does not meet its bar (a model that does not predict): one line
    saying why and what would, nothing written, exit 1."""
