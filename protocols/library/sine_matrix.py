"""Sinusoidal test matrix (thesis 2.3.1.1): amplitudes x frequencies about mid-stroke,
each ramped in, settled, recorded over whole cycles, and ramped out. Combinations above
the rig's velocity limit are skipped and reported."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from protocols.plan import MARGIN, ParamError, RigInfo, Segment, positive, ramp_in

NAME = "sine-matrix"


@dataclass
class Params:
    amplitudes_mm: list[float] = field(default_factory=lambda: [12.7, 6.4, 3.2, 1.6])
    freqs_hz: list[float] = field(default_factory=lambda: [1.0, 2.0, 4.0, 8.0, 16.0])
    ramp_cycles: int = 2
    settle_cycles: int = 2
    record_cycles: int = 5


def check(p: Params, rig: RigInfo):
    positive("amplitudes_mm", p.amplitudes_mm)
    positive("freqs_hz", p.freqs_hz)
    for name in ("ramp_cycles", "record_cycles"):
        positive(name, getattr(p, name))
    if p.settle_cycles < 0:
        raise ParamError(f"settle_cycles: must not be negative, got {p.settle_cycles}")
    for f in p.freqs_hz:
        if f > rig.f_max:
            raise ParamError(f"freqs_hz: {f:g} Hz is above the rig's {rig.f_max:g} Hz")
    for a in p.amplitudes_mm:
        if not (rig.x_min <= rig.x_mid - a / 1e3 and rig.x_mid + a / 1e3 <= rig.x_max):
            raise ParamError(f"amplitudes_mm: {a:g} mm leaves the stroke limits "
                             f"{rig.x_min * 1e3:.1f}..{rig.x_max * 1e3:.1f} mm about {rig.x_mid * 1e3:.1f} mm")
    skipped = []
    for a in p.amplitudes_mm:
        for f in p.freqs_hz:
            v = 2 * math.pi * f * a / 1e3
            if v > rig.v_max:
                skipped.append((_name(a, f), f"peak velocity {v:.2f} m/s above the rig's {rig.v_max:g} m/s"))
            elif rig.peak_force is not None and rig.peak_force(v) > MARGIN * rig.force_max:
                skipped.append((_name(a, f), f"expected force {rig.peak_force(v):.0f} N above "
                                             f"{100 * MARGIN:.0f} % of the rig's {rig.force_max:.0f} N"))
    if len(skipped) == len(p.amplitudes_mm) * len(p.freqs_hz):
        raise ParamError(f"nothing to run: every combination is skipped ({skipped[0][0]}: {skipped[0][1]})")
    return skipped


def _name(a, f):
    return f"sine {a:g} mm {f:g} Hz"


def plan(p: Params, rig: RigInfo):
    skip = {name for name, _ in check(p, rig)}
    for a in p.amplitudes_mm:
        for f in p.freqs_hz:
            if _name(a, f) in skip:
                continue
            A, n = a / 1e3, p.ramp_cycles
            params = {"amplitude_mm": a, "freq_hz": f}
            # every segment is whole cycles, so each starts at phase 0 and the motion is smooth
            yield Segment(f"ramp in {a:g} mm {f:g} Hz", params, n / f, ramp_in(A, f, n, rig.x_mid), False)
            if p.settle_cycles:
                yield Segment(f"settle {a:g} mm {f:g} Hz", params, p.settle_cycles / f, _sine(A, f, rig.x_mid), False)
            yield Segment(_name(a, f), {**params, "cycles": p.record_cycles}, p.record_cycles / f,
                          _sine(A, f, rig.x_mid), kind="sine")
            yield Segment(f"ramp out {a:g} mm {f:g} Hz", params, n / f, _sine(A, f, rig.x_mid, fade=n / f), False)


def _sine(A, f, x_mid, fade=None):
    """x_mid + A sin(2 pi f t), its amplitude fading to zero over `fade` seconds if given."""
    if fade is None:
        return lambda t: x_mid + A * math.sin(2 * math.pi * f * t)
    return lambda t: x_mid + A * max(1.0 - t / fade, 0.0) * math.sin(2 * math.pi * f * t)
