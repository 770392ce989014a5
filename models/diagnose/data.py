"""A recording as the diagnosis sees it: one uniform time base per stretch of motion,
cut into whole cycles (or, for motion that does not repeat, blocks of BLOCK_S) that are
either fitted (train) or only judged (held out).

Channels may come at different rates, with gaps and dropouts: samples the data-quality
check flags (models/diagnose/quality.py) are left out first, everything is put on the
force channel's clock (block-averaged to at most MAX_RATE_HZ), a cycle touched by a gap
or a flagged span is left out (a short glitch: only its samples), and what could not be
assessed is said in `notes`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from models.diagnose import quality
from records.data import Channels, sign_problem, smooth
from records.data import gaps as _gaps
from records.events import Event
from records.segmentation import BLOCK_KINDS, cut
from records.source_filter import Smoothing, unbroken
from records.strokes import frequency

MAX_RATE_HZ = 1000.0  # the model is algebraic in x, v, a: 1 kHz resolves 16 Hz cycles finely
MIN_CYCLES = 6  # fewer whole cycles than this are split by quarter cycles (_quartered)
MIN_WHOLE = 2  # fewer whole cycles than this cannot be split into train and held-out
BLOCK_S = 0.5  # s: the unit of motion that does not repeat (random, road replay), as a cycle is of a sine
# a gap or flagged span at most this share of a cycle (or block) is a glitch: its samples are
# left out, not the cycle. A wired cell's actuator jerks at a late setpoint and puts a
# one-sample inertial spike in the force every second or so (flagged with quality.MARGIN_S
# either side: 40 ms), which would cost every cycle of a 1 Hz segment; a cycle's judgement
# does not miss a tenth of it.
GLITCH = 0.1


class DiagnoseError(ValueError):
    """The recording cannot be diagnosed; the message says why."""


@dataclass
class Data:
    t: np.ndarray  # s
    x: np.ndarray  # m, low-passed (zero phase)
    v: np.ndarray  # m/s, derivative of the low-passed displacement
    a: np.ndarray  # m/s^2
    F: np.ndarray  # N, measured
    cycle: np.ndarray  # cycle number of each sample (-1: not in a whole cycle)
    segment: np.ndarray  # index into `segments` of each sample
    h: np.ndarray  # s, sample spacing of each sample's stretch
    segments: list  # [(name, freq_hz)]
    T: np.ndarray | None = None  # K, body temperature
    aux: dict = field(default_factory=dict)  # {name: values}
    notes: list = field(default_factory=list)  # what could not be assessed, and why
    flags: list = field(default_factory=list)  # [quality.Flag]: samples excluded before fitting
    periodic: bool = True  # some segment is read by cycles (False: all is judged in blocks of BLOCK_S)
    tone_hz: float | None = None  # a line in the residual unrelated to the motion (terms.tone)
    # s: the last time any fit sees on a time split (None: the fits span the recording). A
    # function of time is not extrapolated past it: beyond, it holds its last value
    fitted_until: float | None = None
    smoothing: Smoothing | None = None  # the source's moving average, declared at import (records/source_filter.py)
    filter_hz: list | None = None  # per segment, the frequency [Hz] a per-period source filter took (None: none)
    # Hz, the motion's frequency at each sample: its segment's, a sweep's or ramp's as it goes
    # (records/strokes.frequency: one over each stroke's period), nan where none is known
    freq: np.ndarray | None = None

    def take(self, k):
        """The samples at index array/mask k (same fields)."""
        return Data(self.t[k], self.x[k], self.v[k], self.a[k], self.F[k], self.cycle[k], self.segment[k],
                    self.h[k], self.segments, None if self.T is None else self.T[k],
                    {n: a[k] for n, a in self.aux.items()}, self.notes, self.flags, self.periodic, self.tone_hz,
                    self.fitted_until, self.smoothing, self.filter_hz, None if self.freq is None else self.freq[k])

    def through_source(self, y):
        """y along these samples [any unit] through the moving average the source passed
        the force through (segment by segment), or y itself when none was declared."""
        if self.smoothing is None:
            return y
        out = np.array(y, float)
        for j, t, h, f, stretches, whole in self._stretches:
            out[j] = self.smoothing.apply(out[j], t, h, f, stretches, whole)
        return out

    @cached_property
    def _stretches(self):
        """(samples, their times, median spacing [s], frequency [Hz] or None, the stretches no
        gap breaks, whether it is whole cycles) of each segment: what through_source reads at every model evaluation and
        column (a fifth of a smoothed file's diagnosis went to finding them again), taken
        once: the data do not change. A segment's samples in one run are a slice (a view)."""
        out = []
        for s, (_, f) in enumerate(self.segments):
            j = np.nonzero(self.segment == s)[0]
            if len(j):
                h = float(np.median(self.h[j]))
                if j[-1] - j[0] + 1 == len(j):
                    j = slice(int(j[0]), int(j[-1]) + 1)
                hz = f if self.filter_hz is None else self.filter_hz[s]
                out.append((j, self.t[j], h, hz, unbroken(self.t[j], h), f is not None))
        return out


def _clean(t, v):
    """Sorted, finite, unique time stamps (a repeated stamp keeps its last value)."""
    t, v = np.asarray(t, float), np.asarray(v, float)
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    keep = np.append(np.diff(t) > 0, True)
    return t[keep], v[keep]


HARMONICS = 8


def _periodic_motion(t, x, f):
    """(x, v, a) of a periodic motion at f [Hz] as a sum of HARMONICS harmonics and a slow
    drift, fitted to the displacement samples: differentiating the fit adds no transducer
    noise, where a low-pass derivative at 10 f puts millimetres per second of it into the
    velocity (tens of newtons through a valve). (None, None, None) when the motion is not
    periodic at f to within 20 um RMS: then the caller low-passes."""
    w = 2 * np.pi * f
    tau = t - t[0]
    cols = [np.ones_like(t), tau]
    for k in range(1, HARMONICS + 1):
        cols += [np.cos(k * w * tau), np.sin(k * w * tau)]
    A = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(A, x, rcond=None)
    xf = A @ coef
    if np.sqrt(np.mean((x - xf) ** 2)) > 2e-5:
        return None, None, None
    v = np.full_like(t, coef[1])
    a = np.zeros_like(t)
    for k in range(1, HARMONICS + 1):
        c, s_ = coef[2 * k], coef[2 * k + 1]
        kw = k * w
        v += kw * (-c * np.sin(kw * tau) + s_ * np.cos(kw * tau))
        a += -kw * kw * (c * np.cos(kw * tau) + s_ * np.sin(kw * tau))
    return xf, v, a


def _band(t, x, t0, t1):
    """[Hz] below which 99 % of the displacement's power lies between t0 and t1 (at least
    1 Hz): what a motion that does not repeat is smoothed at."""
    k = (t >= t0) & (t < t1)
    if k.sum() < 16:
        return 1.0
    h = float(np.median(np.diff(t[k])))
    P = np.abs(np.fft.rfft(x[k] - np.mean(x[k]))) ** 2
    c = np.cumsum(P) / max(P.sum(), 1e-300)
    return max(float(np.fft.rfftfreq(int(k.sum()), h)[np.searchsorted(c, 0.99)]), 1.0)


def _spans(channels, events, smoothing, notes):
    """[(name, freq_hz or None, t0, t1, the source filter's frequency [Hz] or None)]: the one
    cut (records/segmentation.cut): its periodic tests, read by whole cycles, and (an
    imported program's) its ramps, sweeps and random motion, read in blocks of BLOCK_S
    (freq None; a ramp goes through a source's per-period filter at its sine's) but where a
    source's moving average blends them with their neighbours (said in notes); else the road
    segments, or the whole recording, as motion that does not repeat."""
    segs = cut(channels, events)
    sines = {s.name: s for s in segs if s.kind == "sine"}
    spans = [(s.name, s.params["freq_hz"] if s.kind == "sine" else None, s.t0, s.t1,
              _ramped(s, segs, sines) if s.kind != "sine" else s.params["freq_hz"])
             for s in segs if s.kind == "sine" or s.kind in BLOCK_KINDS]
    blocks = [sp for sp in spans if sp[1] is None]
    if isinstance(smoothing, Smoothing) and blocks and len(blocks) < len(spans):
        notes.append(f"the ramps, sweeps and random motion beside the tests ({sum(b[3] - b[2] for b in blocks):.1f} "
                     f"s) are not judged: the source's moving average blends each with what lies beyond it, which a "
                     f"model of it alone cannot follow")
        spans = [sp for sp in spans if sp[1] is not None]
    if spans:
        return spans
    spans = [(s.name, None, s.t0, s.t1, None) for s in segs if s.kind == "road"]
    tx = channels["x"][0]
    return spans or [("random", None, float(tx[0]), float(tx[-1]), None)]


def _ramped(span, segs, sines):
    """The frequency [Hz] of the sine a ramp leads into or out of (the one beside it), or None."""
    if span.kind != "ramp":
        return None
    i = segs.index(span)
    near = [segs[j] for j in (i - 1, i + 1) if 0 <= j < len(segs) and segs[j].name in sines]
    return near[0].params["freq_hz"] if near else None


def _screened(channels, force, x, aux, every):
    """(flags, excluded spans, force, x, aux): the data-quality check's flags and the
    channels without the flagged spans. aux: the channels that drive the damper; every: all
    aux channels, the readings among them checked for a rail (quality.at_rail)."""
    flags = quality.check({"force": force, "x": x, **aux, **({"v": _clean(*channels["v"])} if "v" in channels else {})})
    flags += quality.at_rail({n: c for n, c in every.items() if n not in aux})
    bad = quality.excluded(flags)

    def drop(t, y):
        k = quality.within(t, bad)
        return t[~k], y[~k]
    return flags, bad, drop(*force), drop(*x), {n: drop(*c) for n, c in aux.items()}


def _usable(channels):
    """DiagnoseError unless the recording has force and displacement in our sign convention."""
    missing = [n for n in ("force", "x") if n not in channels or len(channels[n][0]) < 10]
    if missing:
        raise DiagnoseError(f"the recording has no {' or '.join(missing)} channel: diagnosis needs time, "
                            f"displacement and force")
    sign = sign_problem(channels)
    if sign:
        raise DiagnoseError(sign)


def prepare(channels: Channels, events: list[Event], drives: list[str] | None = None,
            smoothing: Smoothing | None = None) -> Data:
    """Data from a recording's channels {name: (t, values)} and events; smoothing: the
    moving average its source applied (records/source_filter.py), or None."""
    _usable(channels)
    notes = []
    tF, F = _clean(*channels["force"])
    tx, x = _clean(*channels["x"])
    every = {n: _clean(*c) for n, c in channels.items() if n.startswith("aux.") and len(c[0]) > 10}
    aux = _driving(every, drives, notes)
    period = float(np.median(np.diff(tF)))
    holes = _gaps(tF, period) + _gaps(tx)
    if holes:
        lost = sum(b - a for a, b in holes)
        notes.append(f"{len(holes)} gap(s) in force or displacement ({lost:.2f} s in all): "
                     f"the cycles they touch are left out")
    spans = _spans(channels, events, smoothing, notes)  # before the screening cuts holes in x
    flags, bad, (tF, F), (tx, x), aux = _screened(channels, (tF, F), (tx, x), aux, every)
    gaps = holes + bad
    flags += quality.smoothed("force", tF, F, [(f, t0, t1) for _, f, t0, t1, _ in spans if f is not None], smoothing)
    step = max(1, int(round(1.0 / (MAX_RATE_HZ * period))))
    h = period * step
    T_ch = next((n for n in ("T_body", "temperature", "T_reservoir") if n in channels and len(channels[n][0]) > 1), None)
    parts, seg_names, filter_hz, freqs, n_cycles = [], [], [], [], 0
    for name, f, t0, t1, source_hz in spans:
        # smooth over the stretch with a margin each side (the recording goes on around a
        # segment), then keep the segment: a zero-phase filter's edges are not to be trusted
        random = f is None
        f = _band(tx, x, t0, t1) if random else f
        pad = min(max(1.0 / f, 0.1), 1.0)
        te = _on_clock(tF, max(t0 - pad, tF[0], tx[0]), min(t1 + pad, tF[-1], tx[-1]), h)
        keep = (te >= t0) & (te < t1)
        t = te[keep]
        if len(t) < 50 or max(tF[0], tx[0]) - t0 > 2 * h or t1 - min(tF[-1], tx[-1]) > 2 * h:
            continue  # the records do not cover it
        Fi = _decimated(tF, F, t)
        xs, v, a = (None, None, None) if random else _periodic_motion(t, np.interp(t, tx, x), f)
        if xs is None:
            xe = smooth(np.interp(te, tx, x), h, f)
            ve = np.gradient(xe, h)
            ae = np.gradient(smooth(ve, h, f), h)
            xs, v, a = xe[keep], ve[keep], ae[keep]
        # whole cycles: the motion's phase from the segment start (segments are whole
        # cycles); motion that does not repeat is cut into blocks of BLOCK_S instead
        per = 1.0 / BLOCK_S if random else f
        cyc = np.floor((t - t0) * per + 1e-9).astype(int)
        whole = cyc < (int(np.floor((t1 - t0) * per + 1e-6)) if random else int(round((t1 - t0) * f - 1e-6)))
        for g0, g1 in gaps:  # a cycle touched by a gap is left out; a glitch, only its samples
            near = (t >= g0 - 2 * h) & (t <= g1 + 2 * h)
            whole &= ~near if (g1 - g0) * per <= GLITCH else ~np.isin(cyc, np.unique(cyc[near]))
        cyc = np.where(whole, cyc + n_cycles, -1)
        n_cycles = max(n_cycles, cyc.max() + 1)
        parts.append((t, xs, v, a, Fi, cyc, np.full(len(t), len(seg_names)), np.full(len(t), h)))
        freqs.append(frequency(tx, x, t0, t1, t) if random else np.full(len(t), f))
        seg_names.append((name, None if random else f))
        filter_hz.append(source_hz)
    if not parts:
        raise DiagnoseError("the recording has no motion to judge (no segment and no stretch of at least "
                            "50 samples without a gap)")
    cols = [np.concatenate(c) for c in zip(*parts)]
    d = Data(*cols, segments=seg_names, notes=notes, flags=flags, periodic=any(f is not None for _, f in seg_names),
             smoothing=smoothing, filter_hz=filter_hz, freq=np.concatenate(freqs))
    keep = d.cycle >= 0
    d = d.take(keep)
    if not len(d.t):  # every cycle touched by a gap: nothing to interpolate the other channels onto
        return _enough(d)
    if T_ch is None:
        notes.append("no temperature channel: gas and damping temperature effects not assessed")
    else:
        tT, T = _clean(*channels[T_ch])
        d.T = np.interp(d.t, tT, T)
        if np.ptp(d.T) < 0.5:
            notes.append(f"temperature spans only {np.ptp(d.T):.2f} K: temperature effects not assessed")
            d.T = None
    for n, (ta, va) in aux.items():
        if ta[0] > d.t[0] + 1.0 or ta[-1] < d.t[-1] - 1.0:
            notes.append(f"{n} does not cover the cycling: not assessed")
            continue
        d.aux[n] = np.interp(d.t, ta, va)
    return _enough(d)


def _driving(aux, drives, notes):
    """The aux channels an effect may be scaled by: those the recording says drive the damper
    (every one when drives is None); the others said in notes."""
    if drives is None:
        return aux
    for n in sorted(set(aux) - set(drives)):
        notes.append(f"{n}: the recording does not say it drives the damper, so no effect is scaled by it "
                     f"(a coil current or valve command is declared: `dyno import --drive {n}=coil current`, "
                     f"or `drives` in the rig config's channel)")
    return {n: c for n, c in aux.items() if n in drives}


def _enough(d: Data) -> Data:
    """d, its periodic segments split by quarter cycles when they hold fewer than MIN_CYCLES
    whole cycles; DiagnoseError below MIN_WHOLE cycles, or MIN_CYCLES blocks of motion that
    does not repeat (a block is no stroke to cut)."""
    n_whole = len(np.unique(d.cycle))
    least = MIN_WHOLE if d.periodic else MIN_CYCLES
    if n_whole < least:
        raise DiagnoseError(f"only {n_whole} whole {'cycle' if d.periodic else 'block'}(s) without gaps: too short "
                            f"to judge (at least {least} needed, half fitted and half held out)")
    cycling = np.array([f is not None for _, f in d.segments])[d.segment]
    n_cycles = len(np.unique(d.cycle[cycling]))
    if 0 < n_cycles < MIN_CYCLES:
        d.cycle = _quartered(d, cycling)
        d.notes.append(f"cycle by cycle (only {n_cycles} whole cycles): fitted and held out by quarter cycles, "
                       f"alternate ones in alternate cycles, so that fit and judgement both see every stroke")
    return d


def _quartered(d: Data, cycling):
    """Unit numbers of a recording of few cycles: each cycle (of the samples cycling) cut
    into quarters, numbered so that even units are quarters 0 and 2 of even cycles and 1
    and 3 of odd ones (a checkerboard): alternate units then hold both directions, all
    speeds and, across two cycles, both halves of the stroke and both the speeding-up and
    slowing-down strokes. A block keeps its parity (4 c + c % 2)."""
    out = np.empty(len(d.cycle), int)
    starts = np.r_[0, np.nonzero(np.diff(d.cycle))[0] + 1, len(d.cycle)]
    for a, b in zip(starts[:-1], starts[1:]):
        c = d.cycle[a]
        if not cycling[a]:
            out[a:b] = 4 * c + c % 2
            continue
        q = (np.arange(b - a) * 4) // (b - a)
        out[a:b] = 4 * c + (q ^ 1 if c % 2 else q)  # q ^ 1 swaps 0<->1 and 2<->3
    return out


def _on_clock(tF, a, b, h):
    """Times from a to b [s] every h, on the force channel's own clock: from its first
    sample at or after a. A segment's start falls between samples (a plan's times are not
    rounded to ticks); a time base begun there puts every force value between two samples,
    and across a valve's knee, hundreds of newtons a sample at 12 Hz, the interpolated
    value is off by a hundred or more: a residual no physics left it."""
    end = b + 0.5 * h if b >= tF[-1] else b  # the recording's last sample is one of a segment that ends there
    return np.arange(tF[min(np.searchsorted(tF, a), len(tF) - 1)], end, h)


def _decimated(tF, F, t):
    """The force at times t: the raw samples at those instants (interpolated between the
    two nearest), no smoother. A smoother is a filter the model's prediction would need
    too: a box average bent the force's curvature (F'' w^2 / 24, named fluid inertia on a
    5 kHz null), a Savitzky-Golay one its fourth derivative (a few newtons at 10 Hz, named
    a hysteretic element on every white-noise null at 5 and 10 kHz) and it spread each
    friction reversal over the neighbouring samples. The noise keeps its raw variance."""
    return np.interp(t, tF, F)


def split(d: Data) -> tuple[Data, Data]:
    """(train, held-out): alternate whole cycles within each segment."""
    test = d.cycle % 2 == 1
    return d.take(~test), d.take(test)
