"""Displacement steps (thesis 6.2: steps of 1.27, 2.54 and 5.08 cm on the simulator; on the
dyno, steps of the damper about mid-stroke): each held, then returned."""
from __future__ import annotations

from dataclasses import dataclass, field

from ..plan import ParamError, RigInfo, Segment

NAME = "step"


@dataclass
class Params:
    steps_mm: list[float] = field(default_factory=lambda: [5.0, -5.0, 10.0, -10.0])
    hold_s: float = 1.0
    rise_s: float = 0.01  # the step's ramp time: the actuator's velocity limit is the real bound


def check(p: Params, rig: RigInfo):
    if not p.steps_mm or any(s == 0 for s in p.steps_mm):
        raise ParamError("steps_mm: needs non-zero steps")
    if not p.hold_s > 0 or not p.rise_s > 0:
        raise ParamError("hold_s, rise_s: must be positive")
    for s in p.steps_mm:
        x = rig.x_mid + s / 1e3
        if not rig.x_min <= x <= rig.x_max:
            raise ParamError(f"steps_mm: {s:g} mm leaves the stroke limits "
                             f"{rig.x_min * 1e3:.1f}..{rig.x_max * 1e3:.1f} mm about {rig.x_mid * 1e3:.1f} mm")
        if abs(s) / 1e3 / p.rise_s > rig.v_max:
            raise ParamError(f"rise_s: a {s:g} mm step in {p.rise_s:g} s is faster than the rig's {rig.v_max:g} m/s")
    return []


def plan(p: Params, rig: RigInfo):
    for s in p.steps_mm:
        d = s / 1e3
        yield Segment(f"step {s:+g} mm", {"step_mm": s}, p.hold_s,
                      lambda t, d=d: rig.x_mid + d * min(t / p.rise_s, 1.0))
        yield Segment(f"return from {s:+g} mm", {"step_mm": s}, p.hold_s,
                      lambda t, d=d: rig.x_mid + d * max(1.0 - t / p.rise_s, 0.0), False)
