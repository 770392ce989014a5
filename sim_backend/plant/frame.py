"""The load frame: compliant under the damper's force."""
from __future__ import annotations


def mount_position(pl, h):
    """Where the damper's mount is [m]: the actuator less the frame's give under the
    force, low-passed over the frame's time constant (explicit, and stable with Dahl
    friction)."""
    fr = pl.p["frame"]
    pl.F_frame += h / fr["tau_s"] * (pl.F - pl.F_frame)
    return pl.x_act - pl.F_frame / fr["stiffness"]
