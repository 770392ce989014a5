"""Data quality before diagnosis: samples no physics can explain are flagged, excluded and
reported, never fitted.

- saturated: a run of identical samples at a measured channel's extreme (an amplifier or
  ADC at its rail). An aux channel that drives the damper (a command) may sit at its
  extreme; one that is a reading (an actuator's accelerometer) is saturated there only
  when it otherwise changes from sample to sample (READING_STILL): a slow, coarse or
  stepped reading sits still without leaving its range;
- spikes: one or two samples that leave both neighbours by far more than the channel's
  sample-to-sample noise and by a visible share of its range (a dropout or a glitch);
- unit mismatches: a displacement spanning more than a damper's stroke, a velocity channel
  a power of ten away from the displacement's derivative. These are reported, not
  excluded: no sample is wrong, the whole channel is.
- smoothed: a force channel whose noise was filtered before the file was written (a moving
  average, a low-pass): reported, not excluded, so its noise is not read as the load cell's.

Thresholds are choices, stated here once.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from records.data import Channels
from records.source_filter import Smoothing

FLAT_MIN = 8  # identical samples in a row at the extreme: saturated
# an aux reading repeats its last value at fewer than this share of its samples away from
# its extremes, or sitting still at one says nothing (measured on the NEES MR record: its
# actuator's accelerometer 0.1 %, pinned at both rails for 0.4 s as the rig hit its stop;
# force and displacement 0.5 %; the coil's command voltage, stepped, 12 %)
READING_STILL = 0.02
SPIKE_SIGMA = 12.0  # spike: away from its neighbours' mean by this many noise sd ...
SPIKE_RANGE = 0.02  # ... and by this share of the channel's 1-99 % range
MARGIN_S = 0.02  # s excluded either side of a flagged run (the conditioning settles)
MAX_STROKE = 0.5  # m: no damper strokes more
CHANNELS = ("force", "x")  # the channels the model is fitted to
# smoothed: the lag-one correlation of the force's change from one cycle to the next
# (_cycle_to_cycle) above which, in every periodic stretch, the source smoothed it.
# Measured: white noise 0; our rig 0.06-0.07; a crank dyno's file 0.28; the UTFSM DAQ's raw
# export 0.15-0.94 over its five currents; its sine files, a moving average of a tenth of a
# period, 0.78 (4 samples) to 1.00 (100 samples).
SMOOTHED_RHO = 0.7
MIN_CYCLE = 20  # samples a cycle needs to tell smoothing from the force's own shape


@dataclass(frozen=True)
class Flag:
    channel: str
    kind: str  # "saturated" | "spike" | "units" | "smoothed"
    t0: float  # s, excluded span (with margin); equal t0 = t1 = nan for a channel-wide note
    t1: float
    samples: int
    message: str


def _runs(mask):
    """[(start, stop)] of the True runs of a boolean array."""
    k = np.diff(np.r_[0, mask.astype(np.int8), 0])
    return list(zip(np.nonzero(k == 1)[0], np.nonzero(k == -1)[0]))


def saturated(name: str, t: np.ndarray, y: np.ndarray) -> list[Flag]:
    """Flags for runs of >= FLAT_MIN identical samples at the channel's max or min."""
    out = []
    if len(y) < FLAT_MIN:
        return out
    same = np.r_[np.diff(y) == 0, False]
    for a, b in _runs(same):
        n = b - a + 1
        v = y[a]
        if n >= FLAT_MIN and v in (y.max(), y.min()):
            out.append(Flag(name, "saturated", t[a] - MARGIN_S, t[b] + MARGIN_S, int(n),
                            f"{name} flat at {v:.6g} for {n} samples from {t[a]:.3f} s (saturated)"))
    return out


def spikes(name: str, t: np.ndarray, y: np.ndarray) -> list[Flag]:
    """Flags for one- or two-sample spikes."""
    if len(y) < 10:
        return []
    # a spike leaves both neighbours the same way, they agree, and the signal is quiet on
    # either side (a step, or the ringing after it, fails one of these): one sample, or a
    # pair against the samples either side of it
    n = len(y)
    dev, dev2 = np.zeros(n), np.zeros(n)
    i = np.arange(2, n - 2)
    dl, dr = y[i] - y[i - 1], y[i] - y[i + 1]
    m1 = np.minimum(np.abs(dl), np.abs(dr))
    quiet = np.maximum.reduce([np.abs(y[i + 1] - y[i - 1]), np.abs(y[i - 1] - y[i - 2]), np.abs(y[i + 2] - y[i + 1])])
    dev[i] = np.where((dl * dr > 0) & (quiet < 0.5 * m1), m1, 0.0)
    i = np.arange(2, n - 3)
    m2 = np.maximum(np.minimum(y[i], y[i + 1]) - np.maximum(y[i - 1], y[i + 2]),  # pair above both outer samples
                    np.minimum(y[i - 1], y[i + 2]) - np.maximum(y[i], y[i + 1]))  # or below both
    quiet = np.maximum.reduce([np.abs(y[i + 2] - y[i - 1]), np.abs(y[i - 1] - y[i - 2]), np.abs(y[i + 3] - y[i + 2])])
    dev2[i] = np.where(quiet < 0.5 * m2, m2, 0.0)
    sd = 1.4826 * float(np.median(np.abs(np.diff(y, 2)))) / np.sqrt(6) or 1e-12
    span = float(np.subtract(*np.percentile(y, [99, 1])))
    bound = max(SPIKE_SIGMA * sd, SPIKE_RANGE * span)
    pair = dev2 > bound
    hit = (dev > bound) | pair | np.r_[False, pair[:-1]]
    out = []
    for a, b in _runs(hit):
        if b - a <= 3:  # longer departures are motion, not a glitch
            out.append(Flag(name, "spike", t[a] - MARGIN_S, t[b - 1] + MARGIN_S, int(b - a),
                            f"{name} spike at {t[a]:.3f} s ({b - a} sample(s), "
                            f"{max(np.max(dev[a:b]), np.max(dev2[a:b])):.3g} "
                            f"beyond its neighbours)"))
    return out


def units(channels: Channels) -> list[Flag]:
    """Channel-wide unit notes (nothing excluded)."""
    out = []
    if "x" in channels and len(channels["x"][1]) > 1:
        tx, x = channels["x"]
        if np.ptp(x) > MAX_STROKE:
            out.append(Flag("x", "units", np.nan, np.nan, 0,
                            f"displacement spans {np.ptp(x):.3g} m, more than any damper's stroke: recorded in mm "
                            f"and read as m?"))
        if "v" in channels and len(channels["v"][1]) > 10:
            tv, v = channels["v"]
            dx = np.interp(tv, tx, np.gradient(x, tx))
            ok = np.isfinite(dx) & np.isfinite(v)
            if ok.sum() > 10 and np.std(dx[ok]) > 0:
                ratio = float(np.dot(v[ok], dx[ok]) / np.dot(dx[ok], dx[ok]))
                if abs(np.log10(max(abs(ratio), 1e-12))) > 0.5:
                    out.append(Flag("v", "units", np.nan, np.nan, 0,
                                    f"velocity channel is {ratio:.3g} times the displacement's derivative: "
                                    f"a unit mismatch between them (the diagnosis uses the displacement's)"))
    return out


def _cycle_to_cycle(t, y, f, k):
    """y's change from one cycle to the next over samples k, less what a cycle's shift in
    time or a slow change leaves (the repeating force cancels; the noise stays). The period
    is where the force repeats best: a segment's frequency is known to a few digits only."""
    period = minimize_scalar(lambda T: np.mean((y[k] - np.interp(t[k] - T, t, y)) ** 2),
                             bounds=(0.99 / f, 1.01 / f), method="bounded", options={"xatol": 1e-5 / f}).x
    e = y[k] - np.interp(t[k] - period, t, y)
    slope = np.gradient(y, t)
    cols = (np.ones(len(e)), slope[k], np.gradient(slope, t)[k], t[k] - t[k].mean())
    cycle = np.floor((t[k] - t[k][0]) / period).astype(int)
    for c in np.unique(cycle):
        j = cycle == c
        A = np.column_stack([a[j] for a in cols])
        e[j] -= A @ np.linalg.lstsq(A, e[j], rcond=None)[0]
    return e


def _named(declared) -> str:
    """A declared source filter in words (records/source_filter.py)."""
    return f"moving average of {declared.text()}" if hasattr(declared, "width") else f"low-pass {declared.text()}"


def smoothed(name: str, t: np.ndarray, y: np.ndarray, cycles: list[tuple[float, float, float]],
             declared: Smoothing | None = None) -> list[Flag]:
    """A channel-wide flag when the channel y(t) was smoothed by its source. cycles: [(f [Hz],
    t0, t1 [s])] of periodic stretches; declared: the source's moving average as import was
    told it (records/source_filter.py), which every model then goes through. From one cycle
    to the next the repeating force cancels and the noise is left: white noise changes from
    sample to sample with no correlation, smoothed noise keeps it. A source smooths the whole
    channel, so every stretch must show it (a damper's own slow change from cycle to cycle
    can in one). Undeclared, the flag says how wide a moving average the correlation reads
    (_window)."""
    rho, stretches = [], []
    for f, t0, t1 in cycles:
        k = np.nonzero((t >= t0 + 1.01 / f) & (t <= t1))[0]
        h = float(np.median(np.diff(t)))
        if len(k) < 4 * MIN_CYCLE or 1.0 / (f * h) < MIN_CYCLE:
            continue
        e = _cycle_to_cycle(t, y, f, k)
        ss = float(e @ e)
        if np.sqrt(ss / len(e)) > 1e-5 * np.ptp(y):  # a noiseless recording has nothing to tell
            rho.append(float(e[:-1] @ e[1:]) / ss)
            stretches.append((e, h, f))
    if not rho or min(rho) <= SMOOTHED_RHO:
        return []
    n, h, f = sorted((_window(e, int(0.5 / (f * h))), h, f) for e, h, f in stretches)[len(stretches) // 2]
    lowpass = None if declared else _lowpass(*max(stretches, key=lambda s: len(s[0]))[:2])
    if lowpass:
        return [Flag(name, "smoothed", np.nan, np.nan, 0,
                     f"{name} was filtered by its source (a low-pass before the file was written): its change from "
                     f"one cycle to the next keeps a sample-to-sample correlation of {min(rho):.2f} or more (white "
                     f"noise: 0), so its noise is the filter's, not the load cell's, and a model compared with it "
                     f"needs the same filter: the correlation reads a causal low-pass of about {lowpass[1]:.2g} Hz "
                     f"(a Butterworth of order {lowpass[0]} fits it better than a moving average; the source's own "
                     f"figure is better); import the file again with the filter its source used (dyno import "
                     f"--filtered force=butter:{lowpass[0]}:{float(f'{lowpass[1]:.2g}'):g}Hz)")]
    return [Flag(name, "smoothed", np.nan, np.nan, 0,
                 f"{name} was smoothed by its source (a moving average or a low-pass before the file was "
                 f"written): its change from one cycle to the next keeps a sample-to-sample correlation of "
                 f"{min(rho):.2f} or more (white noise: 0), so its noise is the filter's, not the load cell's, "
                 + (f"and every model is compared with it through the {_named(declared)} its import "
                    f"declared" if declared else f"and a model compared with it needs the same filter: the correlation "
                    f"reads a moving average of about {n} samples ({1e3 * n * h:.3g} ms, {n * h * f:.2g} of the "
                    f"period; this reading runs up to a third short, the source's own figure is better); import the "
                    f"file again with the filter its source used (dyno import --smoothed, e.g. "
                    f"{float(f'{n * h * f:.1g}'):g}period or {float(f'{1e3 * n * h:.2g}'):g}ms)"))]


LOWPASS_BETTER = 0.5  # a Butterworth's correlation must fit with at most this share of a moving average's error


def _lowpass(e, h):
    """(order, cut-off [Hz]) of the Butterworth low-pass whose noise correlation fits e's
    best, when it fits much better (LOWPASS_BETTER) than any moving average's triangle;
    else None. A DAQ's anti-alias filter rolls the spectrum off smoothly (four decades from
    10 to 60 Hz on a crank dyno's 300 Hz files), where a moving average's has notches."""
    from scipy.signal import butter, sosfreqz
    L = max(3, min(64, len(e) // 4))
    e = e - e.mean()
    ac = np.fft.irfft(np.abs(np.fft.rfft(e, 2 * len(e))) ** 2)[:L]
    ac = ac / ac[0]
    # the lags before the correlation falls to a tenth: each cycle's trend removed
    # (_cycle_to_cycle) pulls the longer ones below zero, whatever the filter
    L = max(3, int(np.argmax(ac < 0.1)) or L)
    ac = ac[:L]
    lags = np.arange(L)
    box = min(float(np.sum((ac - np.maximum(0.0, 1.0 - lags / m)) ** 2)) for m in range(2, L + 1))
    best = None
    for order in (1, 2, 4):
        for fc in np.geomspace(0.01 / h, 0.4 / h, 40):
            _, H = sosfreqz(butter(order, fc, fs=1 / h, output="sos"), worN=4096, fs=1 / h)
            r = np.fft.irfft(np.abs(H) ** 2, 2 * 4096 - 2)[:L]
            err = float(np.sum((ac - r / r[0]) ** 2))
            if best is None or err < best[0]:
                best = (err, order, float(fc))
    return best[1:] if best[0] <= LOWPASS_BETTER * box else None


def _window(e, most):
    """The width in samples of the moving average white noise went through to become e:
    its autocorrelation is then a triangle falling to zero at that width. Fitted by least
    squares over widths 2..most. Removing each cycle's trend (_cycle_to_cycle) pulls the
    long lags below zero, so a wide window reads short: the UTFSM sine files, whose source
    averaged 0.1 of the period, read 0.074-0.098; 77 samples of white noise at 1.3 Hz and
    1 kHz read 55. Without that removal a damper's slow change from cycle to cycle reads
    them 0.15-0.25."""
    L = max(3, min(most, len(e) // 4))
    e = e - e.mean()
    spectrum = np.fft.rfft(e, 2 * len(e))  # zero-padded: the linear, not the circular, correlation
    ac = np.fft.irfft(np.abs(spectrum) ** 2)[:L]
    ac = ac / ac[0]
    lags = np.arange(L)
    err = [float(np.sum((ac - np.maximum(0.0, 1.0 - lags / m)) ** 2)) for m in range(2, L)]
    return 2 + int(np.argmin(err)) if err else 1


def check(channels: Channels) -> list[Flag]:
    """[Flag] for the channels the model is fitted to and its aux channels; channels
    {name: (t, values)}, each sorted and finite."""
    flags = []
    for name, (t, y) in channels.items():
        if name in CHANNELS:
            flags += saturated(name, t, y)
        if name in CHANNELS or name.startswith("aux."):  # an aux command may sit at its extreme
            flags += spikes(name, t, y)
    return flags + units(channels)


def at_rail(readings: Channels) -> list[Flag]:
    """[Flag] of saturated runs in aux readings {name: (t, values)} (channels that drive
    nothing, each sorted and finite) that otherwise change from sample to sample: an
    accelerometer or a monitor at its rail says the rig left its range, and so every
    channel's samples there."""
    flags = []
    for name, (t, y) in readings.items():
        inside = (y[1:] != y.max()) & (y[1:] != y.min()) if len(y) else np.zeros(0, bool)
        if np.any(inside) and float(np.mean(np.diff(y)[inside] == 0)) < READING_STILL:
            flags += saturated(name, t, y)
    return flags


def excluded(flags: list[Flag]) -> list[tuple[float, float]]:
    """[(t0, t1)] spans to leave out, merged."""
    spans = sorted((f.t0, f.t1) for f in flags if np.isfinite(f.t0))
    out = []
    for a, b in spans:
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def within(t: np.ndarray, spans: list[tuple[float, float]]) -> np.ndarray:
    """The samples at times t [s] inside any of the spans [(t0, t1)] (excluded's)."""
    k = np.zeros(len(t), bool)
    for a, b in spans:
        k |= (t >= a) & (t <= b)
    return k


def describe(flags: list[Flag], most: int = 3) -> list[str]:
    """One line per channel and kind: how many, how many samples, the first few."""
    out = []
    groups = {}
    for f in flags:
        groups.setdefault((f.channel, f.kind), []).append(f)
    for (ch, kind), fs in groups.items():
        if not np.isfinite(fs[0].t0):  # a note on the whole channel
            out += [f.message for f in fs]
            continue
        shown = "; ".join(f.message for f in fs[:most]) + (f"; and {len(fs) - most} more" if len(fs) > most else "")
        out.append(f"{len(fs)} {kind} run(s) in {ch}, {sum(f.samples for f in fs)} samples, excluded "
                   f"with {1e3 * MARGIN_S:.0f} ms either side: {shown}")
    return out
