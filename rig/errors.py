"""The rig's own error: every problem with a configuration, a device or a byte on a wire
becomes a RigError whose message names it in one line."""


class RigError(Exception):
    """Bad configuration, unreachable device, or malformed data from a device."""
