"""A displacement read as strokes, whatever its sample rate and noise (issue 88): its noise
measured, its turning points, the half-cycles between them (travel, mid-level, the time it
crosses that level, the period from the crossing before to the one after), and a periodic
motion (a fundamental and harmonics) fitted to it at a refined frequency. What
records/steady.py and records/segmentation.py cut a program with.

Why each (docs/recording.md#segments-of-an-imported-recording): the noise is measured as
it is, not from differences (a DAQ's need not be white); turning points are found on the
displacement low-passed at SMOOTH_HZ, each once the motion has come back REVERSAL_NOISE
times that noise; a crank dyno's stroke is no sine, its crossings alternate short and long,
but its period (crossing before to crossing after) is one; the fit is least squares on the
displacement itself, never zero crossings. Arrays in (t [s], x [m]), dataclasses out."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

SMOOTH_HZ = 50.0  # Hz: turning points on the displacement low-passed here (a dyno program's sines are below 30 Hz) ...
SMOOTH_SHARE = 0.25  # ... or at this share of the sample rate, if lower
NOISE_S = 0.2  # s: the blocks the noise is measured in
REVERSAL_NOISE = 8.0  # a turning point once the motion has come back this many times the smoothed noise ...
MIN_REVERSAL = 2e-5  # m: ... and at least this
MIN_TRAVEL = 2e-4  # m: a test's stroke travels at least this far (below: noise about a hold)
HARMONICS = 16  # of a periodic fit, fewer where the rate does not resolve them (a triangle's misfit: 0.3 %)
TRIANGLE_SHARE = 0.5  # a stroke within 10 % of its median speed this share of the time is a triangle's


def noise(t: np.ndarray, x: np.ndarray) -> float:
    """The displacement's noise [x's unit, RMS], in the quietest tenth of the recording (blocks
    of NOISE_S), where the motion adds least: its scatter about a line there, or where no
    block is still (a file of one sine) its white part, from second differences, if less. A
    DAQ's noise need not be white (the UTFSM exports' has five times more below 50 Hz than
    their differences say), so where the recording holds still it is measured as it is."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    h = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    m = max(8, int(round(NOISE_S / h)))
    n = len(x) // m
    if n < 1:
        return 0.0
    b = x[:n * m].reshape(n, m)
    u = np.arange(m) - (m - 1) / 2
    line = b.mean(axis=1, keepdims=True) + np.outer(b @ u / (u @ u), u)
    scatter = np.percentile(np.sqrt(np.mean((b - line) ** 2, axis=1)), 10)
    d2 = b[:, 2:] - 2 * b[:, 1:-1] + b[:, :-2]
    white = 1.4826 * np.percentile(np.median(np.abs(d2 - np.median(d2, axis=1, keepdims=True)), axis=1), 10) / math.sqrt(6)
    return float(min(scatter, white))


def smoothed(x: np.ndarray, h: float) -> np.ndarray:
    """x low-passed at SMOOTH_HZ (at most SMOOTH_SHARE of the rate; zero phase)."""
    fc = min(SMOOTH_HZ, SMOOTH_SHARE / h)
    if len(x) < 30:
        return np.asarray(x, float)
    from scipy.signal import butter, sosfiltfilt  # here: scipy.signal takes a second to import
    return sosfiltfilt(butter(2, fc * 2 * h, output="sos"), x)


@njit(cache=True)
def _turning_points(x, delta):
    """Indices of x's alternate maxima and minima, each once x has come back more than delta."""
    out = np.empty(len(x), np.int64)
    n, hi, lo, way = 0, 0, 0, 0
    for i in range(1, len(x)):
        if way >= 0 and x[i] > x[hi]:
            hi = i
        if way <= 0 and x[i] < x[lo]:
            lo = i
        if way == 0:
            if x[hi] - x[lo] > delta:
                out[n] = lo if lo < hi else hi
                n += 1
                way = 1 if lo < hi else -1
        elif way == 1 and x[hi] - x[i] > delta:
            out[n] = hi
            n += 1
            way, lo = -1, i
        elif way == -1 and x[i] - x[lo] > delta:
            out[n] = lo
            n += 1
            way, hi = 1, i
    return out[:n]


@njit(cache=True)
def _crossings(t, x, ext):
    """The time each half-cycle (ext[j] to ext[j+1]) first crosses its mid-level, linearly
    interpolated."""
    out = np.empty(len(ext) - 1)
    for j in range(len(ext) - 1):
        a, b = ext[j], ext[j + 1]
        mid = 0.5 * (x[a] + x[b])
        up = x[b] > x[a]
        out[j] = t[b]
        for i in range(a, b):
            if (x[i + 1] >= mid) if up else (x[i + 1] <= mid):
                u = (mid - x[i]) / (x[i + 1] - x[i]) if x[i + 1] != x[i] else 0.0
                out[j] = t[i] + u * (t[i + 1] - t[i])
                break
    return out


def _peaks(x, ext):
    """x at its turning points, each the vertex of the parabola through it and its two
    neighbours: at a few samples a cycle the highest sample lies up to 12 % below the
    motion's peak (2 % once interpolated)."""
    i = np.clip(ext, 1, len(x) - 2)
    a, b, c = x[i - 1], x[i], x[i + 1]
    curve = a - 2 * b + c
    with np.errstate(divide="ignore", invalid="ignore"):
        top = b - (c - a) ** 2 / (8 * curve)
    return np.where((curve != 0) & (ext == i) & (np.abs(top - b) <= np.abs(c - a)), top, x[ext])


@dataclass
class Halves:
    """The half-cycles of a stretch of motion: turning points ext (indices), and per
    half-cycle j (ext[j] to ext[j+1]) its travel [m], mid-level [m], mid-level crossing [s]
    and period [s] (from the crossing before it to the one after: the half-cycle that joins two
    tests has neither's; nan for the first and last)."""
    ext: np.ndarray
    travel: np.ndarray
    mid: np.ndarray
    cross: np.ndarray
    period: np.ndarray

    @classmethod
    def of(cls, t, xs, delta):
        ext = _turning_points(xs, delta)
        if len(ext) < 2:
            e = np.zeros(0)
            return cls(ext, e, e, e, e)
        peak = _peaks(xs, ext)
        travel = np.abs(np.diff(peak))
        mid = 0.5 * (peak[1:] + peak[:-1])
        cross = _crossings(t, xs, ext)
        period = np.full(len(cross), np.nan)
        period[1:-1] = cross[2:] - cross[:-2]
        return cls(ext, travel, mid, cross, period)

    def __len__(self):
        return len(self.travel)


@dataclass
class Fit:
    freq: float  # Hz
    amplitude: float  # m: half the fitted stroke's peak-to-peak (a triangle's: its speed over 4 f)
    mean: float  # m
    rms: float  # m: the displacement's misfit
    waveform: str  # sine or triangle
    coef: np.ndarray = field(repr=False)
    t_ref: float = 0.0
    harmonics: int = 1

    def at(self, t):
        return _basis(np.asarray(t, float) - self.t_ref, self.freq, self.harmonics) @ self.coef


def _basis(tau, f, n):
    """Columns 1, tau, cos(k w tau), sin(k w tau) for k = 1..n (the powers of one complex
    exponential: a few times cheaper than n cosines and sines)."""
    z = np.exp(2j * np.pi * f * tau)
    out = np.empty((len(tau), 2 + 2 * n))
    out[:, 0], out[:, 1] = 1.0, tau
    p = z.copy()
    for k in range(n):
        out[:, 2 + 2 * k], out[:, 3 + 2 * k] = p.real, p.imag
        if k + 1 < n:
            p *= z
    return out


SEARCH_SAMPLES = 2000  # a frequency search fits at most this many samples (a fundamental and two harmonics) ...
FIT_SAMPLES = 20000  # ... and the fit at that frequency at most this many


def fit(t: np.ndarray, x: np.ndarray, f0: float, search: float = 0.01) -> Fit | None:
    """The periodic motion (fundamental and harmonics, a constant and a slow drift) at the
    frequency within `search` of f0 [Hz] that fits x [m] best: least squares on the
    displacement itself (never zero crossings), the frequency refined by a bounded search.
    None for fewer than 4 samples a cycle."""
    from scipy.optimize import minimize_scalar
    t, x = np.asarray(t, float), np.asarray(x, float)
    h = float(np.median(np.diff(t)))
    if len(t) < 16 or 1.0 / (h * f0) < 4:
        return None

    def thinned(most, harmonics):
        """(tau, x, harmonics) every stride-th sample: at most `most`, at least 8 a harmonic's cycle."""
        stride = max(1, min(len(t) // most, int(1.0 / (h * f0 * 8 * harmonics))))
        return t[::stride] - t[0], x[::stride], max(1, min(harmonics, int(0.4 / (h * stride * f0))))

    def lsq(tau, y, f, n):
        A = _basis(tau, f, n)
        c = np.linalg.lstsq(A, y, rcond=None)[0]
        return c, float(np.sum((A @ c - y) ** 2))
    def best(f, search, harmonics):
        tau, y, n = thinned(SEARCH_SAMPLES, harmonics)
        return float(minimize_scalar(lambda g: lsq(tau, y, g, n)[1], bounds=(f * (1 - search), f * (1 + search)),
                                     method="bounded", options={"xatol": f * 1e-7}).x)
    f = best(f0, search, 3) if search else f0
    tau, y, n = thinned(FIT_SAMPLES, HARMONICS)
    c, sse = lsq(tau, y, f, n)
    if search and n > 3 and np.hypot(c[8::2], c[9::2]).sum() > 0.005 * np.hypot(c[2], c[3]):
        # a stroke that is no sine (a triangle, a crank's): its higher harmonics, left out of a
        # search on three, lean on the frequency (0.1 % on a triangle's whole cycles); once more on all
        f = best(f, 0.002, HARMONICS)
        c, sse = lsq(tau, y, f, n)
    ph = np.linspace(0, 1, 256, endpoint=False)
    wave = _basis(ph / f, f, n)[:, 2:] @ c[2:]
    speed = np.abs(np.gradient(wave, 1.0 / (256 * f)))  # m/s
    if np.mean(np.abs(speed / np.median(speed) - 1) <= 0.1) >= TRIANGLE_SHARE:
        # its speed, not the fit's peaks: harmonics round a triangle's corners (2.5 % low at 16)
        waveform, amplitude = "triangle", float(np.median(speed)) / (4 * f)
    else:
        waveform, amplitude = "sine", float(np.ptp(wave) / 2)
    return Fit(f, amplitude, float(c[0]), math.sqrt(sse / len(y)), waveform, c, float(t[0]), n)


def frequency(t: np.ndarray, x: np.ndarray, t0: float, t1: float, at: np.ndarray = None) -> np.ndarray:
    """The instantaneous frequency [Hz] of the motion x [m] between t0 and t1 [s] (a sweep's,
    a ramp's) at times `at` (t by default): one over each half-cycle's period at its
    mid-level crossing, interpolated; nan outside the crossings found, or where none is."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    at = t if at is None else np.asarray(at, float)
    k = (t >= t0) & (t <= t1)
    tk, xk = t[k], x[k]
    out = np.full(len(at), np.nan)
    if len(tk) < 16:
        return out
    xs = smoothed(xk, float(np.median(np.diff(tk))))
    H = Halves.of(tk, xs, max(REVERSAL_NOISE * noise(tk, xs), MIN_REVERSAL))
    ok = np.isfinite(H.period) & (H.travel >= MIN_TRAVEL)
    if ok.sum() < 2:
        return out
    inside = (at >= H.cross[ok][0]) & (at <= H.cross[ok][-1])
    out[inside] = np.interp(at[inside], H.cross[ok], 1.0 / H.period[ok])
    return out


def turns(t: np.ndarray, H: Halves) -> np.ndarray:
    """[(t [s], the shorter of its half-cycles [s])] of the turning points between two
    half-cycles of MIN_TRAVEL or more: a slow motion's, still for a moment either side."""
    j = np.flatnonzero((H.travel[:-1] >= MIN_TRAVEL) & (H.travel[1:] >= MIN_TRAVEL)) + 1
    te = t[H.ext]
    return np.column_stack([te[j], np.minimum(te[j] - te[j - 1], te[j + 1] - te[j])]) if len(j) else np.zeros((0, 2))
