"""Pre-flight: what a plan will do, predicted before anything moves.

Every segment's setpoints are sampled and run through the damper model (incompressible,
eq 3.33/3.44 family, at the segment's temperature): stroke, velocity, force and gas
pressure are compared with the rig's limits, and the planned time with MAX_MOTION_S. A
plan that would trip a limit it could have predicted is refused, naming the segment.

Temperature: a segment that states one (a temperature sweep's target, a warm-up's end)
is predicted at it; any other at the cell's ambient for the gas (it has not warmed) and at
the worse of ambient and the damper's reference temperature for the force (a cold damper
is stiffer). Margins: the model is a prediction, and a real damper differs from it, so a
force or gas pressure above MARGIN of its limit is refused.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from protocols.plan import MARGIN, ParamError, RigInfo, Segment
from protocols.units import Units, fmt

MAX_MOTION_S = 2 * 3600.0  # s: a plan that moves longer than this needs --long
# s: ... and one that may last longer than this with every wait at its longest (the standard
# sequence: 4 min of motion, its 18 waits at most 2 h 7 min; a wait usually ends far sooner)
MAX_RUN_S = 4 * 3600.0
SAMPLES = 400  # per segment, and at least POINTS_PER_CYCLE a cycle
POINTS_PER_CYCLE = 64


@dataclass
class Forecast:
    duration_s: float = 0.0  # fixed-time segments [s]
    waits: int = 0  # segments that end on a reading (a temperature, a settled force)
    wait_max_s: float = 0.0  # their time limits, summed [s]
    x_range: tuple = (math.inf, -math.inf)  # m
    v_peak: float = 0.0  # m/s
    force_peak: float = 0.0  # N
    gas_peak: float = 0.0  # Pa
    worst: dict = field(default_factory=dict)  # quantity -> segment name


def segment_temperatures(seg: Segment):
    """The temperatures [K] to predict a segment at: a sweep's target; a warm-up's start
    (None: see RigInfo.response) and end; else None."""
    if "target_c" in seg.params:
        return (float(seg.params["target_c"]) + 273.15,)
    if "until_c" in seg.params:
        return None, float(seg.params["until_c"]) + 273.15
    return (None,)


def _samples(seg: Segment, rate_hz):
    """(t, x) of the segment's setpoints, fine enough for its fastest motion (a closed
    loop's prediction at every tick: its content is not known ahead)."""
    if seg.control is not None:
        t = np.arange(0.0, seg.duration, 1.0 / rate_hz)
        return t, np.array([seg.x(ti) for ti in t])
    f = float(seg.params.get("freq_hz", 0.0) or 0.0)
    span = seg.duration if f <= 0 else min(seg.duration, 32 / f)  # a long cycling repeats itself
    n = SAMPLES if f <= 0 else max(SAMPLES, int(span * f * POINTS_PER_CYCLE))
    t = np.linspace(0.0, span, n + 1)
    return t, np.array([seg.x(ti) for ti in t])


JUMP_M = 1e-5  # a setpoint that moves more than this between segments is a jump


def _end_x(seg: Segment):
    """Where a segment leaves the setpoint; None if that depends on when a reading ends it
    while it moves (the segment after it would start with a jump)."""
    if seg.until is None:
        return seg.x(seg.duration)
    if seg.cycle:
        return seg.x(seg.cycle * round(seg.duration / seg.cycle))
    if _at_rest(seg) and _at_rest(seg, end=True) and abs(seg.x(seg.duration) - seg.x(0.0)) < JUMP_M:
        return seg.x(0.0)
    return None


def forecast(segments, info: RigInfo, T=None) -> Forecast:
    """The plan's forecast; T [K]: predict every segment at this temperature instead of the
    ones it states (for a run that starts with the damper already there)."""
    out = Forecast()
    for prev, seg in zip([None, *segments[:-1]], segments):
        if prev is not None:
            x_end = _end_x(prev)
            if x_end is None:
                raise ParamError(f"{prev.name}: ends on a reading while it moves, so {seg.name} would start "
                                 f"with a jump (the plan needs Segment.cycle)")
            if abs(seg.x(0.0) - x_end) > JUMP_M:
                raise ParamError(f"{seg.name}: starts {1e3 * (seg.x(0.0) - x_end):+.2f} mm from where "
                                 f"{prev.name} ends: a setpoint jump")
        if seg.until is None:
            out.duration_s += seg.duration
        else:
            out.waits += 1
            out.wait_max_s += seg.duration
        t, x = _samples(seg, info.rate_hz)
        if not np.all(np.isfinite(x)):
            raise ParamError(f"{seg.name}: the plan gives a setpoint that is not a number")
        lo, hi = float(x.min()), float(x.max())
        if lo < out.x_range[0] or hi > out.x_range[1]:
            out.x_range = (min(lo, out.x_range[0]), max(hi, out.x_range[1]))
            out.worst["stroke"] = seg.name
        if lo < info.x_min - 1e-9 or hi > info.x_max + 1e-9:
            raise ParamError(f"{seg.name}: setpoints span {lo * 1e3:.1f}..{hi * 1e3:.1f} mm, outside the stroke "
                             f"limits {info.x_min * 1e3:.1f}..{info.x_max * 1e3:.1f} mm")
        v = np.gradient(x, t) if len(t) > 1 and t[-1] > 0 else np.zeros_like(x)
        vp = float(np.abs(v).max())
        if vp > out.v_peak:
            out.v_peak, out.worst["velocity"] = vp, seg.name
        if info.response is None:
            continue
        fp = gp = 0.0
        for Ts in ((T,) if T is not None else segment_temperatures(seg)):
            force, gas = info.response(t, x, v, Ts)
            fp = max(fp, float(np.abs(force).max()))
            gp = max(gp, float(np.max(gas)) if gas is not None else 0.0)
        if fp > out.force_peak:
            out.force_peak, out.worst["force"] = fp, seg.name
        if gp > out.gas_peak:
            out.gas_peak, out.worst["gas"] = gp, seg.name
    return out


def check(segments, info: RigInfo, long=False) -> Forecast:
    """The forecast of a plan; ParamError naming the segment if it would trip a limit or
    move longer than MAX_MOTION_S without `long`."""
    if not segments:
        raise ParamError("nothing to run: every part of the plan was skipped")
    f = forecast(segments, info)
    if f.v_peak > info.v_max * (1 + 1e-9):
        raise ParamError(f"{f.worst['velocity']}: needs {f.v_peak:.2f} m/s, above the rig's {info.v_max:g} m/s")
    if f.force_peak > MARGIN * info.force_max:
        raise ParamError(f"{f.worst['force']}: the damper model predicts {f.force_peak:.0f} N, above "
                         f"{100 * MARGIN:.0f} % of the rig's {info.force_max:.0f} N")
    if info.gas_max and f.gas_peak > MARGIN * info.gas_max:
        raise ParamError(f"{f.worst['gas']}: the damper model predicts a gas pressure of {f.gas_peak / 1e6:.2f} MPa, "
                         f"above {100 * MARGIN:.0f} % of the rig's {info.gas_max / 1e6:.2f} MPa")
    if f.duration_s > MAX_MOTION_S and not long:
        raise ParamError(f"the plan moves for {_hours(f.duration_s)}, more than {_hours(MAX_MOTION_S)}: "
                         f"check its parameters, or give --long")
    if f.duration_s + f.wait_max_s > MAX_RUN_S and not long:
        raise ParamError(f"the plan may run for {_hours(f.duration_s + f.wait_max_s)} ({_hours(f.duration_s)} of "
                         f"motion and {f.waits} waits of at most {_hours(f.wait_max_s)} in all), more than "
                         f"{_hours(MAX_RUN_S)}: check its parameters, or give --long")
    return f


def _hours(s):
    return f"{s / 3600:.1f} h" if s >= 3600 else f"{s / 60:.0f} min" if s >= 60 else f"{s:.0f} s"


def summary(f: Forecast, units=Units()) -> str:
    def q(quantity, si, digits=3):
        return f"{fmt(units.show(quantity, si), digits)} {units.unit(quantity)}"
    waits = f" + {f.waits} wait{'s' * (f.waits > 1)} (at most {_hours(f.wait_max_s)})" if f.waits else ""
    gas = f", gas up to {q('pressure', f.gas_peak)}" if f.gas_peak else ""
    force = f", force up to {q('force', f.force_peak, 4)}" if f.force_peak else ""
    return (f"pre-flight: {_hours(f.duration_s)} of motion{waits}; stroke "
            f"{fmt(units.show('length', f.x_range[0]), 3)}.."
            f"{q('length', f.x_range[1])}, velocity up to {q('velocity', f.v_peak)}{force}{gas} (damper model)")


def _at_rest(seg: Segment, end=False):
    """Does the segment start (end) with the actuator at rest? (setpoint speed ~ 0)."""
    t = seg.duration if end else 0.0
    h = 1e-4
    a, b = (t - h, t) if end else (t, t + h)
    return abs(seg.x(b) - seg.x(a)) / h < 1e-3


def critical(segments, f: Forecast):
    """The segments that decide the forecast's peak force and gas pressure, each with what
    leads into it from rest and out of it back to rest: a shortened run that meets the
    plan's hardest moments (a sweep's warm-up, the fastest sine), for checking a plan
    against the rig in minutes instead of hours. [(first index, last index)]."""
    names = [s.name for s in segments]
    spans = []
    for q in ("force", "gas"):
        if q not in f.worst:
            continue
        i = j = names.index(f.worst[q])
        while i > 0 and not _at_rest(segments[i]):
            i -= 1
        while j < len(segments) - 1 and not _at_rest(segments[j], end=True):
            j += 1
        if (i, j) not in spans:
            spans.append((i, j))
    return spans
