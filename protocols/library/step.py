"""Displacement steps (thesis 6.2: steps of 1.27, 2.54 and 5.08 cm on the simulator; on the
dyno, steps of the damper about mid-stroke): each held, then returned."""
from __future__ import annotations

from dataclasses import dataclass, field

from protocols.plan import MARGIN, ParamError, RigInfo, Segment

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


def rise_time(p: Params, rig: RigInfo, step_mm):
    """rise_s, lengthened where the damper model says the step's speed would take the force
    above MARGIN of the rig's limit (a stiff damper is stepped more slowly, not tripped)."""
    v = abs(step_mm) / 1e3 / p.rise_s
    if rig.peak_force is None or rig.peak_force(v) <= MARGIN * rig.force_max:
        return p.rise_s
    lo, hi = 0.0, v
    for _ in range(30):  # the fastest speed that fits, by bisection
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if rig.peak_force(mid) <= MARGIN * rig.force_max else (lo, mid)
    return abs(step_mm) / 1e3 / max(lo, 1e-9)


def plan(p: Params, rig: RigInfo):
    for s in p.steps_mm:
        d, rise = s / 1e3, rise_time(p, rig, s)
        yield Segment(f"step {s:+g} mm", {"step_mm": s, "rise_s": rise}, p.hold_s,
                      lambda t, d=d, r=rise: rig.x_mid + d * min(t / r, 1.0), kind="step")
        yield Segment(f"return from {s:+g} mm", {"step_mm": s, "rise_s": rise}, p.hold_s,
                      lambda t, d=d, r=rise: rig.x_mid + d * max(1.0 - t / r, 0.0), False, kind="step")
