"""Low-speed test (thesis 2.3.1.2, 4.2.2): slow sine cycling, 0.005-0.05 Hz, for the
breakaway friction at stroke reversals and the gas spring (gamma, thermal expansion)."""
from __future__ import annotations

from dataclasses import dataclass, field

from protocols.plan import ParamError, RigInfo, Segment, positive, ramp_in

NAME = "low-speed"


@dataclass
class Params:
    amplitude_mm: float = 12.7
    freqs_hz: list[float] = field(default_factory=lambda: [0.05, 0.02, 0.005])
    cycles: int = 2


def check(p: Params, rig: RigInfo):
    positive("amplitude_mm", p.amplitude_mm)
    positive("freqs_hz", p.freqs_hz)
    positive("cycles", p.cycles)
    A = p.amplitude_mm / 1e3
    if not (rig.x_min <= rig.x_mid - A and rig.x_mid + A <= rig.x_max):
        raise ParamError(f"amplitude_mm: {p.amplitude_mm:g} mm leaves the stroke limits")
    for f in p.freqs_hz:
        if f > 0.5:
            raise ParamError(f"freqs_hz: {f:g} Hz is not low speed (at most 0.5 Hz; use sine-matrix)")
    return []


def plan(p: Params, rig: RigInfo):
    import math
    A = p.amplitude_mm / 1e3
    for f in p.freqs_hz:
        params = {"amplitude_mm": p.amplitude_mm, "freq_hz": f}
        yield Segment(f"ramp in {f:g} Hz", params, 1 / f, ramp_in(A, f, 1, rig.x_mid), False)
        yield Segment(f"low-speed {f:g} Hz", {**params, "cycles": p.cycles}, p.cycles / f,
                      lambda t, f=f: rig.x_mid + A * math.sin(2 * math.pi * f * t), kind="low-speed")
        yield Segment(f"ramp out {f:g} Hz", params, 1 / f,
                      lambda t, f=f: rig.x_mid + A * max(1 - t * f, 0) * math.sin(2 * math.pi * f * t), False)
