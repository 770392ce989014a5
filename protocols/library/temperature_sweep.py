"""Temperature sweep (thesis 2.3.1.1): warm the damper by cycling until it is above the
top target, then, while it cools, record the given sine at each target temperature."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from protocols.plan import MARGIN, ParamError, RigInfo, Segment, positive, ramp_in, sine_peaks

NAME = "temperature-sweep"
MARGIN_K = 5.0  # targets must lie this far inside ambient .. the rig's temperature limit
REACH_K = 10.0  # warming must be able to go this far past its end point (it slows near its balance)


@dataclass
class Params:
    targets_c: list[float] = field(default_factory=lambda: [140.0, 120.0, 100.0, 80.0, 60.0, 40.0])
    amplitude_mm: float = 12.7
    freq_hz: float = 2.0
    cycles: int = 3
    warm_amplitude_mm: float = 12.7
    warm_freq_hz: float = 8.0
    overshoot_c: float = 3.0  # warm this far above the top target
    max_warm_s: float = 1800.0
    max_cool_s: float = 1800.0  # per target


def check(p: Params, rig: RigInfo):
    positive("targets_c", p.targets_c)
    if p.overshoot_c < 0:
        raise ParamError(f"overshoot_c: must not be negative (the warm-up ends above the top target), "
                         f"got {p.overshoot_c:g}")
    for name in ("amplitude_mm", "freq_hz", "cycles", "warm_amplitude_mm", "warm_freq_hz", "max_warm_s",
                 "max_cool_s"):
        positive(name, getattr(p, name))
    hi, lo = rig.T_max - 273.15 - MARGIN_K, rig.T_ambient - 273.15 + MARGIN_K
    for T in p.targets_c:
        if T > hi or T + p.overshoot_c > rig.T_max - 273.15:
            raise ParamError(f"targets_c: {T:g} C is above what the rig may reach ({hi:g} C, its limit "
                             f"{rig.T_max - 273.15:g} C less {MARGIN_K:g} K)")
        if T < lo:
            raise ParamError(f"targets_c: {T:g} C cannot be reached by cooling (ambient "
                             f"{rig.T_ambient - 273.15:g} C, at least {lo:g} C)")
    for A, f, what in ((p.amplitude_mm, p.freq_hz, ""), (p.warm_amplitude_mm, p.warm_freq_hz, "warm_")):
        # the rig's limits first: they are cheap, and the force checks below search over frequency
        if f > rig.f_max:
            raise ParamError(f"{what}freq_hz: {f:g} Hz is above the rig's {rig.f_max:g} Hz")
        if 2 * math.pi * f * A / 1e3 > rig.v_max:
            raise ParamError(f"{what}freq_hz: {A:g} mm at {f:g} Hz is faster than the rig's {rig.v_max:g} m/s")
        if not (rig.x_min <= rig.x_mid - A / 1e3 and rig.x_mid + A / 1e3 <= rig.x_max):
            raise ParamError(f"{what}amplitude_mm: {A:g} mm leaves the stroke limits")
    if rig.peak_force is not None:
        v = 2 * math.pi * p.freq_hz * p.amplitude_mm / 1e3
        if rig.peak_force(v) > MARGIN * rig.force_max:
            raise ParamError(f"freq_hz: {p.amplitude_mm:g} mm at {p.freq_hz:g} Hz needs about "
                             f"{rig.peak_force(v):.0f} N, above {100 * MARGIN:.0f} % of the rig's "
                             f"{rig.force_max:.0f} N")
        if _warm_freq(p, rig) is None:
            raise ParamError(f"warm_amplitude_mm: {p.warm_amplitude_mm:g} mm needs more force than the rig's "
                             f"{rig.force_max:.0f} N even at 1 Hz")
    skipped = [(f"sine at {T:g} C", why) for T, why in _too_hot(p, rig)]
    if len(skipped) == len(p.targets_c):
        raise ParamError(f"targets_c: none can be run on this damper: {skipped[-1][1]}")
    return skipped


def _too_hot(p: Params, rig: RigInfo):
    """[(target C, why)] of the targets the damper model says would take the gas pressure
    above MARGIN of the rig's limit (while cycling at the target, or while warming to just
    above it when it would be the top target), or that warming cannot reach: the power the
    warm cycling dissipates there (mean F v) against the cell's conductance times the rise
    over ambient. The hottest first."""
    out = []
    if rig.response is None:
        return out
    fw = _warm_freq(p, rig) or p.warm_freq_hz
    for T in sorted(p.targets_c, reverse=True):
        top = T + p.overshoot_c + 273.15
        gas = sine_peaks(rig, p.amplitude_mm / 1e3, p.freq_hz, T + 273.15)[1]
        _, warm, power = sine_peaks(rig, p.warm_amplitude_mm / 1e3, fw, top)
        if rig.gas_max and max(gas, warm) > MARGIN * rig.gas_max:
            what = "cycling at it" if gas >= warm else f"warming to {top - 273.15:g} C"
            out.append((T, f"gas pressure {max(gas, warm) / 1e6:.2f} MPa {what} (damper model), above "
                           f"{100 * MARGIN:.0f} % of the rig's {rig.gas_max / 1e6:.2f} MPa"))
        elif rig.conductance and power < rig.conductance * (top + REACH_K - rig.T_ambient):
            # warming balances the cell's cooling below the target: it would never get there
            out.append((T, f"warming at {fw:g} Hz cannot reach {top - 273.15:g} C: the damper model dissipates "
                           f"{power:.0f} W there, the cell takes {rig.conductance:g} W/K x "
                           f"{top + REACH_K - rig.T_ambient:.0f} K"))
        else:
            break  # the rest are colder
    return out


def _above(T_K):
    return lambda r: "T_body" in r and r["T_body"].value >= T_K


def _below(T_K):
    return lambda r: "T_body" in r and r["T_body"].value <= T_K


def _warm_freq(p: Params, rig: RigInfo):
    """warm_freq_hz, lowered in 0.5 Hz steps until the damper's expected force stays under
    90 % of the rig's limit (a stiff damper warms more slowly but safely); None if even
    1 Hz is too much."""
    f = p.warm_freq_hz
    while rig.peak_force is not None and rig.peak_force(2 * math.pi * f * p.warm_amplitude_mm / 1e3) > \
            0.9 * rig.force_max:
        f -= 0.5
        if f < 1.0:
            return None
    return f


def plan(p: Params, rig: RigInfo):
    too_hot = {T for T, _ in _too_hot(p, rig)}
    targets = sorted((T for T in p.targets_c if T not in too_hot), reverse=True)
    Aw, fw = p.warm_amplitude_mm / 1e3, _warm_freq(p, rig)
    top = targets[0] + p.overshoot_c + 273.15
    yield Segment("warm up", {"until_c": top - 273.15, "freq_hz": fw}, p.max_warm_s, ramp_in(Aw, fw, 4, rig.x_mid),
                  False, _above(top), ("T_body", top), cycle=1 / fw, kind="warm-up")
    yield Segment("stop warming", {}, 2 / fw,
                  lambda t: rig.x_mid + Aw * max(1 - t * fw / 2, 0) * math.sin(2 * math.pi * fw * t), False)
    A, f = p.amplitude_mm / 1e3, p.freq_hz
    for T in targets:
        yield Segment(f"cool to {T:g} C", {"target_c": T}, p.max_cool_s, lambda t: rig.x_mid, False,
                      _below(T + 273.15), ("T_body", T + 273.15), kind="rest")
        params = {"target_c": T, "amplitude_mm": p.amplitude_mm, "freq_hz": f, "cycles": p.cycles}
        yield Segment(f"ramp in at {T:g} C", params, 1 / f, ramp_in(A, f, 1, rig.x_mid), False)
        yield Segment(f"sine at {T:g} C", params, p.cycles / f,
                      lambda t: rig.x_mid + A * math.sin(2 * math.pi * f * t), kind="sine")
        yield Segment(f"ramp out at {T:g} C", params, 1 / f,
                      lambda t: rig.x_mid + A * max(1 - t * f, 0) * math.sin(2 * math.pi * f * t), False)
