"""What the user gave us is wrong: an argument, a file that cannot be read as what it should
be, a recording without the channel an analysis needs. Its message names the problem in
one line and the command exits 2. The rig's own faults (a configuration, a device, a trip)
are RigError (rig/errors.py)."""


class UsageError(Exception):
    """Bad input: one line naming it."""


class Refused(Exception):
    """What a command made does not meet its bar (a model that does not predict): one line
    saying why and what would, nothing written, exit 1."""
