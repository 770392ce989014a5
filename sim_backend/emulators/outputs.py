"""What the virtual rig's devices would output, from the plant's readings and the config:
a device signal's value is the inverse of its channel's calibration (a config that says
1032 N/V gets 1/1032 V per N), so the virtual rig honours any calibration pointed at it.
The virtual rig serves the standard channel names (Plant.readings)."""
from __future__ import annotations


def outputs(config, device, readings):
    """{signal: device output} for one device; signals without a channel read 0."""
    out = {}
    for ch in config.channels.values():
        if ch.device == device and ch.name in readings:
            out[ch.signal] = ch.unscale(readings[ch.name])
    return out
