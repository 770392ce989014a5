"""Sinusoidal test matrix (thesis 2.3.1.1): amplitudes x frequencies about mid-stroke,
each ramped in, settled, recorded over whole cycles, and ramped out. Combinations above
the rig's velocity limit are skipped and reported; one whose expected force is above the
pre-flight margin of the rig's limit is recorded instead at the highest frequency that
stays within it (the fastest strokes the cell allows are the ones the valves' high-speed
behaviour is identified from), and reported."""
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
    record_s: float = 0.0  # ... or more, to record at least this long [s] at each frequency
    # amplitudes and frequencies taken pairwise (the next test's sines), not as a matrix
    paired: bool = False


def check(p: Params, rig: RigInfo):
    _validate(p, rig)
    return _matrix(p, rig)[1]


def _validate(p: Params, rig: RigInfo):
    """ParamError naming a parameter that cannot be run at all."""
    positive("amplitudes_mm", p.amplitudes_mm)
    positive("freqs_hz", p.freqs_hz)
    for name in ("ramp_cycles", "record_cycles"):
        positive(name, getattr(p, name))
    if p.settle_cycles < 0:
        raise ParamError(f"settle_cycles: must not be negative, got {p.settle_cycles}")
    if p.paired and len(p.amplitudes_mm) != len(p.freqs_hz):
        raise ParamError(f"paired: {len(p.amplitudes_mm)} amplitudes_mm for {len(p.freqs_hz)} freqs_hz")
    if not (math.isfinite(p.record_s) and p.record_s >= 0):
        raise ParamError(f"record_s: must be 0 or more seconds, got {p.record_s:g}")
    for f in p.freqs_hz:
        if f > rig.f_max:
            raise ParamError(f"freqs_hz: {f:g} Hz is above the rig's {rig.f_max:g} Hz")
    for a in p.amplitudes_mm:
        if not (rig.x_min <= rig.x_mid - a / 1e3 and rig.x_mid + a / 1e3 <= rig.x_max):
            raise ParamError(f"amplitudes_mm: {a:g} mm leaves the stroke limits "
                             f"{rig.x_min * 1e3:.1f}..{rig.x_max * 1e3:.1f} mm about {rig.x_mid * 1e3:.1f} mm")


def _matrix(p: Params, rig: RigInfo):
    """([(amplitude mm, frequency Hz, extra params of its recorded segment)] to record,
    [(segment, why skipped or moved)]); ParamError if nothing is left to record. A sine
    moved to a lower frequency says so in its recorded segment's params: `adapted` (the
    frequency asked and why) and `adapted_from` (the segment asked for)."""
    runs, skipped = [], []
    pairs = zip(p.amplitudes_mm, p.freqs_hz) if p.paired else ((a, f) for a in p.amplitudes_mm for f in p.freqs_hz)
    for a, f in pairs:
        v = 2 * math.pi * f * a / 1e3
        if v > rig.v_max:
            skipped.append((_name(a, f), f"peak velocity {v:.2f} m/s above the rig's {rig.v_max:g} m/s"))
        elif rig.peak_force is not None and rig.peak_force(v) > MARGIN * rig.force_max:
            why = (f"expected force {rig.peak_force(v):.0f} N above {100 * MARGIN:.0f} % of the rig's "
                   f"{rig.force_max:.0f} N")
            f_ok = _fastest(rig, a, f)
            slower = max((g for g in p.freqs_hz if g < f), default=0.0)
            if f_ok is not None and f_ok > slower and (a, f_ok) not in [r[:2] for r in runs]:
                runs.append((a, f_ok, {"adapted": f"asked {f:g} Hz: {why}", "adapted_from": _name(a, f)}))
                why += f": recorded at {f_ok:g} Hz instead"
            skipped.append((_name(a, f), why))
        else:
            runs.append((a, f, {}))
    if not runs:
        raise ParamError(f"nothing to run: every combination is skipped ({skipped[0][0]}: {skipped[0][1]})")
    return runs, skipped


def _fastest(rig: RigInfo, a, f):
    """The highest frequency below f [Hz], in 0.1 Hz steps, at which the damper model's
    force at amplitude a [mm] stays within the margin of the rig's limit (None if none)."""
    lo, hi = 0.0, f
    for _ in range(30):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if rig.peak_force(2 * math.pi * mid * a / 1e3) <= MARGIN * rig.force_max else (lo, mid)
    f_ok = math.floor(lo * 10 + 1e-9) / 10
    return f_ok if f_ok >= 0.1 else None


def _name(a, f):
    return f"sine {a:g} mm {f:g} Hz"


def plan(p: Params, rig: RigInfo):
    _validate(p, rig)
    for a, f, moved in _matrix(p, rig)[0]:
        A, n = a / 1e3, p.ramp_cycles
        params = {"amplitude_mm": a, "freq_hz": f}
        # every segment is whole cycles, so each starts at phase 0 and the motion is smooth
        yield Segment(f"ramp in {a:g} mm {f:g} Hz", params, n / f, ramp_in(A, f, n, rig.x_mid), False)
        if p.settle_cycles:
            yield Segment(f"settle {a:g} mm {f:g} Hz", params, p.settle_cycles / f, _sine(A, f, rig.x_mid), False)
        cycles = max(p.record_cycles, math.ceil(p.record_s * f - 1e-9))
        yield Segment(_name(a, f), {**params, "cycles": cycles, **moved}, cycles / f,
                      _sine(A, f, rig.x_mid), kind="sine")
        yield Segment(f"ramp out {a:g} mm {f:g} Hz", params, n / f, _sine(A, f, rig.x_mid, fade=n / f), False)


def _sine(A, f, x_mid, fade=None):
    """x_mid + A sin(2 pi f t), its amplitude fading to zero over `fade` seconds if given."""
    if fade is None:
        return lambda t: x_mid + A * math.sin(2 * math.pi * f * t)
    return lambda t: x_mid + A * max(1.0 - t / fade, 0.0) * math.sin(2 * math.pi * f * t)
