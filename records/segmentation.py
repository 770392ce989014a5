"""A recording made elsewhere cut into the tests its dyno program ran (issues 43 and 88),
whatever the sample rate (100 Hz to 10 kHz) and under an LVDT's noise and quantisation:
steady sines (a crank dyno's skewed stroke and a triangle's constant-velocity strokes
included, each named as what it is) in whole cycles, sweeps, the ramps into and out of a
sine, holds and shorter dwells, steps between holds and motion that does not repeat. Every
second of the recording lands in one segment; nothing is left unread.

How (docs/recording.md#segments-of-an-imported-recording):
1. the displacement's noise is measured (its scatter in the quietest tenth of the
   recording) and turning points are found on it low-passed at SMOOTH_HZ, each once the
   motion has come back REVERSAL_NOISE times that noise;
2. a half-cycle runs from one turning point to the next; its travel, mid-level and the time
   it crosses that mid-level are what the tests are found by: its period is the time from
   the crossing before it to the one after (a crank dyno's stroke is no sine, its
   crossings alternate short and long, but its period is one; the half-cycle that joins
   two tests has the period of neither);
3. sweeps first: half-cycles whose period drifts smoothly (a line through a dozen of them
   explains it) over SWEEP_CHANGE or more;
4. steady sines: runs of alike half-cycles (travel, level and period within SAME), then a
   sine with harmonics fitted to the displacement itself, its frequency refined; its ends
   are followed sample by sample while the fit holds (the run's half-cycles stop a quarter
   cycle short of a sine's ends), and whole cycles are taken from the middle;
5. the rest: holds and dwells where the motion is still, steps (one move between two
   stills), ramps beside a sine, the tapers of a sweep, random motion elsewhere.

Arrays in (t [s], x [m]), dataclasses out; the events a run would have written come from
`events()`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from records.data import Span, Test, same_tests, segments as recorded_segments
from records.events import Event, SegmentEnd, SegmentStart

SMOOTH_HZ = 50.0  # Hz: turning points on the displacement low-passed here (a dyno program's sines are below 30 Hz) ...
SMOOTH_SHARE = 0.25  # ... or at this share of the sample rate, if lower
NOISE_S = 0.2  # s: the blocks the noise is measured in
REVERSAL_NOISE = 8.0  # a turning point once the motion has come back this many times the smoothed noise ...
MIN_REVERSAL = 2e-5  # m: ... and at least this
MIN_TRAVEL = 2e-4  # m: a test's stroke travels at least this far (below: noise about a hold)
SAME = 0.03  # half-cycles of one steady test: travel, mid-level (of the travel) and period within this share
STEADY_FIT = 0.01  # of the amplitude: RMS misfit of a steady test's periodic fit (beyond the noise) ...
EDGE = 0.01  # ... and where it is followed to its ends, the misfit [of the amplitude] that ends it
MIN_CYCLES = 2  # a steady test has at least this many whole cycles
CYCLE_SLACK = 0.15  # of a cycle: a steady stretch this short of a whole number of cycles still holds it
HARMONICS = 16  # of a periodic test's fit (a triangle's misfit at 16: 0.3 % of its amplitude) (fewer where the rate does not resolve them)
TRIANGLE_SHARE = 0.5  # a stroke within 10 % of its median speed this share of the time is a triangle's
SWEEP_WINDOW = 5  # half-cycles each side of one: the line its period is judged against
SWEEP_SMOOTH = 0.3  # a sweep's periods leave that line by at most this share of their change per half-cycle ...
SWEEP_RATE = 5e-4  # ... which is at least this (a steady sine's periods jitter by a tenth of it)
SWEEP_FOLLOW = 0.02  # its ends followed while their period stays this close to its line
SWEEP_HALVES = 10  # a sweep lasts at least this many half-cycles ...
SWEEP_CHANGE = 0.1  # ... and its frequency changes by at least this share
HOLD_S = 0.5  # s: a hold lasts at least this long (a shorter still stretch is a dwell) ...
HOLD_BAND = MIN_TRAVEL / 2  # m: ... within this band (a real DAQ's hold wanders 0.1 mm over seconds)
DWELL_S = 0.1  # s: ... and a dwell at least this long
TURN_SHARE = 0.7  # a slow sine's turning point is within HOLD_BAND for less than this share of its half-cycle
LEAST_S = 0.02  # s: a stretch between segments shorter than this joins its neighbour
RANDOM_S = 2.0  # s: motion that does not repeat is called random from this long, a transition below

# what the diagnosis reads of an imported recording: the periodic tests by their cycles, these by blocks
BLOCK_KINDS = ("ramp", "sweep", "random")


@dataclass
class Segment:
    name: str
    kind: str  # sine (waveform sine or triangle), sweep, ramp, hold, dwell, step, random
    t0: float
    t1: float
    params: dict = field(default_factory=dict)
    of: tuple = field(default=(None, None), repr=False)  # a ramp's: the tests before and after it


def _g(v):
    return f"{v:.3g}"


# -- the displacement read ------------------------------------------------------------------------

def noise(t, x):
    """The displacement's noise [x's unit, RMS]: its scatter about a line in the quietest tenth
    of the recording (blocks of NOISE_S), where the motion adds least. A DAQ's noise need not
    be white (the UTFSM exports': five times more below 50 Hz than their sample-to-sample
    differences say), so it is measured as it is, not from differences."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    h = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    m = max(8, int(round(NOISE_S / h)))
    n = len(x) // m
    if n < 1:
        return 0.0
    b = x[:n * m].reshape(n, m)
    u = np.arange(m) - (m - 1) / 2
    line = b.mean(axis=1, keepdims=True) + np.outer(b @ u / (u @ u), u)
    return float(np.percentile(np.sqrt(np.mean((b - line) ** 2, axis=1)), 10))


def smoothed(x, h):
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


# -- periodic fits ------------------------------------------------------------------------------------

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


def fit(t, x, f0, search=0.01):
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


# -- the cut ----------------------------------------------------------------------------------------------

def find(t, x) -> list[Segment]:
    """The segments of a recording's displacement, in time order, covering it (but for
    holes in its time stamps: an acquisition paused)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    ok = np.isfinite(t) & np.isfinite(x)
    t, x = t[ok], x[ok]
    if len(t) < 8:
        return []
    order = np.argsort(t, kind="stable")
    t, x = t[order], x[order]
    dt = np.diff(t)
    if not np.any(dt > 0):
        return []
    h = float(np.median(dt[dt > 0]))
    out = []
    for k in np.split(np.arange(len(t)), np.flatnonzero(dt > 5 * h) + 1):
        if len(k) >= 8:
            out += _cut(t[k], x[k], h)
    _name(out)
    return out


def _cut(t, x, h):
    xs = smoothed(x, h)
    sigma, still = noise(t, x), noise(t, xs)
    halves = Halves.of(t, xs, max(REVERSAL_NOISE * still, MIN_REVERSAL))
    swept = _sweeps(halves)
    sweeps = [Segment("sweep", "sweep", float(t[halves.ext[a]]), float(t[halves.ext[b + 1]])) for a, b in swept]
    free = np.ones(len(halves), bool)
    for a, b in swept:
        free[a:b + 1] = False
    sines = _steady(t, x, halves, free, sigma, [(s.t0, s.t1) for s in sweeps])
    out = _fill(t, xs, sorted(sweeps + sines, key=lambda s: s.t0), _turns(t, halves))
    for s in sweeps:  # widened by its tapers: its frequencies read over all of it
        s.params = _sweep_params(halves, s.t0, s.t1)
    return out


def _turns(t, H):
    """[(t [s], the shorter of its half-cycles [s])] of the turning points between two
    half-cycles of MIN_TRAVEL or more: a slow motion's, still for a moment either side."""
    j = np.flatnonzero((H.travel[:-1] >= MIN_TRAVEL) & (H.travel[1:] >= MIN_TRAVEL)) + 1
    te = t[H.ext]
    return np.column_stack([te[j], np.minimum(te[j] - te[j - 1], te[j + 1] - te[j])]) if len(j) else np.zeros((0, 2))


def _sweeps(H):
    """[(first, last half-cycle)] of the sweeps: half-cycles whose log period lies on a line
    through SWEEP_WINDOW each side of it (within SWEEP_SMOOTH of the line's change per
    half-cycle: a staircase of steady sines does not, nor does a steady sine's jitter), the
    line's slope of one sign along them, their travel alike (within a quarter)."""
    n = len(H)
    lp = np.log(H.period)
    slope = np.full(n, np.nan)
    for j in range(n):
        a, b = max(0, j - SWEEP_WINDOW), min(n, j + SWEEP_WINDOW + 1)
        y = lp[a:b]
        ok = np.isfinite(y) & (H.travel[a:b] >= MIN_TRAVEL)
        if ok.sum() < 2 * SWEEP_WINDOW or not np.isfinite(lp[j]):
            continue
        u = np.arange(a, b)[ok] - j
        c = np.polyfit(u, y[ok], 1)
        if abs(c[0]) >= SWEEP_RATE and np.sqrt(np.mean((np.polyval(c, u) - y[ok]) ** 2)) <= SWEEP_SMOOTH * abs(c[0]):
            slope[j] = c[0]
    out, j = [], 0
    while j < n:
        if not np.isfinite(slope[j]):
            j += 1
            continue
        k = j
        while (k + 1 < n and np.isfinite(slope[k + 1]) and np.sign(slope[k + 1]) == np.sign(slope[j])
               and abs(math.log(H.travel[k + 1] / H.travel[k])) <= math.log(1.25)):
            k += 1
        a, b = _follow(H, lp, j, k, -1), _follow(H, lp, j, k, 1)
        if out and a <= out[-1][1] + 1 and out[-1][2] == np.sign(slope[j]):  # one sweep the line lost a moment
            a = out.pop()[0]
        out.append((a, b, np.sign(slope[j])))
        j = k + 1
    return [(a, b) for a, b, _ in out if b - a + 1 >= SWEEP_HALVES and _change(lp[a:b + 1]) >= math.log(1 + SWEEP_CHANGE)]


def _follow(H, lp, j, k, way):
    """The half-cycle a sweep found from j to k reaches the other way (way -1) or on (+1):
    its slope is judged on SWEEP_WINDOW half-cycles either side, so its last few are followed
    one by one while their travel is alike and their period continues the line through the
    sweep's last 2 SWEEP_WINDOW + 1 (within SWEEP_FOLLOW)."""
    end = j if way < 0 else k
    while 0 <= end + way < len(H) and _alike_travel(H, end + way, end):
        nxt = end + way
        run = np.arange(j, end + 1) if way > 0 else np.arange(end, k + 1)
        run = run[np.isfinite(lp[run])]
        run = run[-(2 * SWEEP_WINDOW + 1):] if way > 0 else run[:2 * SWEEP_WINDOW + 1]
        if np.isfinite(lp[nxt]) and len(run) >= 2:
            c = np.polyfit(run - nxt, lp[run], 1)
            if abs(lp[nxt] - c[1]) > math.log(1 + SWEEP_FOLLOW):
                break
        end = nxt
    return end


def _change(lp):
    seen = lp[np.isfinite(lp)]
    return float(np.ptp(seen)) if len(seen) else 0.0


def _alike_travel(H, i, j):
    return H.travel[i] >= MIN_TRAVEL and abs(math.log(H.travel[i] / H.travel[j])) <= math.log(1.25)


def _sweep_params(H, t0, t1):
    """A sweep's params: its frequency [Hz] at its first and last strokes of MIN_TRAVEL or
    more between t0 and t1 [s] (one over their periods) and its median amplitude."""
    k = (H.cross >= t0) & (H.cross <= t1) & (H.travel >= MIN_TRAVEL) & np.isfinite(H.period)
    f = 1.0 / H.period[k]
    return {"kind": "sweep", "f_start_hz": round(float(f[0]), 4), "f_end_hz": round(float(f[-1]), 4),
            "amplitude_mm": round(float(np.median(H.travel[k])) / 2 * 1e3, 3), "measured": True, "found": "import"}


def frequency(t, x, t0, t1):
    """The instantaneous frequency [Hz] of the motion at times t between t0 and t1 (a
    sweep's): one over each half-cycle's period at its mid-level crossing, interpolated; nan
    where there is none."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    k = (t >= t0) & (t <= t1)
    tk, xk = t[k], x[k]
    out = np.full(len(t), np.nan)
    if len(tk) < 16:
        return out
    xs = smoothed(xk, float(np.median(np.diff(tk))))
    H = Halves.of(tk, xs, max(REVERSAL_NOISE * noise(tk, xs), MIN_REVERSAL))
    ok = np.isfinite(H.period) & (H.travel >= MIN_TRAVEL)
    if ok.sum() < 2:
        return out
    at = H.cross[ok]
    out[k] = np.interp(tk, at, 1.0 / H.period[ok])
    return out


def _steady(t, x, H, free, sigma, taken):
    """The steady periodic tests (Segments) among the free half-cycles."""
    out = []
    for a, b, period in _alike_runs(H, free):
        got = _seed(t, x, H, a, b, 1.0 / period)
        if got is None or got.rms > STEADY_FIT * got.amplitude + 2 * sigma:
            continue
        a, b, got = got.run
        i0, i1 = H.ext[a], H.ext[b + 1]
        held0, held1 = _ends(t, x, i0, i1, got, taken + [(s.t0, s.t1) for s in out])
        # the stretch ends between the last sample the fit holds and the first it does not: at
        # a few samples a cycle a sixth of a cycle, so it is counted out to the latter
        h = float(np.median(np.diff(t[i0:i1 + 1])))
        n = int(math.floor((held1 - held0 + 2 * h) * got.freq + CYCLE_SLACK))
        if n < MIN_CYCLES:
            continue
        mid = 0.5 * (held0 + held1)
        t0, t1 = mid - 0.5 * n / got.freq, mid + 0.5 * n / got.freq
        k = (t >= max(t0, held0)) & (t <= min(t1, held1))
        final = fit(t[k], x[k], got.freq, search=0.002) or got
        t1 = t0 + n / final.freq
        amp = final.amplitude
        name = f"{final.waveform} {_g(amp * 1e3)} mm {_g(final.freq)} Hz"
        out.append(Segment(name, "sine", float(t0), float(t1),
                           {"kind": "sine", "amplitude_mm": round(amp * 1e3, 4), "freq_hz": round(final.freq, 5),
                            "cycles": n, "waveform": final.waveform, "measured": True, "found": "import"}))
    return _apart(out)


def _seed(t, x, H, a, b, f0):
    """The fit of the half-cycles a to b (Fit, its .run (a, b, fit) the half-cycles kept),
    less those at either end that the fit misses three times as badly as the median half-
    cycle: the half-cycle that joins two tests, let in where a few samples a cycle blur its
    travel. None where no fit is made."""
    while True:
        i0, i1 = H.ext[a], H.ext[b + 1]
        got = fit(t[i0:i1 + 1], x[i0:i1 + 1], f0)
        if got is None or b - a < 3:
            break
        r = x[i0:i1 + 1] - got.at(t[i0:i1 + 1])
        miss = np.array([np.sqrt(np.mean(r[H.ext[j] - i0:H.ext[j + 1] - i0 + 1] ** 2)) for j in range(a, b + 1)])
        worst = int(np.argmax(miss[[0, -1]]))
        if not miss[[0, -1]][worst] > 3 * np.median(miss) + EDGE * got.amplitude / 10:
            break
        a, b, f0 = (a + 1, b, got.freq) if worst == 0 else (a, b - 1, got.freq)
    if got is not None:
        got.run = (a, b, got)
    return got


def _alike_runs(H, free):
    """[(first, last half-cycle, period [s])] of runs of at least three alike half-cycles (a
    sine's two whole cycles less the quarter cycles at its ends): their travel and mid-level
    within SAME of the run's medians, then split where the period changes by more than
    SAME. A run's first and last half-cycles take the period of their neighbours: theirs
    reaches across to the crossing of the motion beside the run."""
    out = []
    for a, b in _runs(H, free):
        known = [j for j in range(a + 1, b) if np.isfinite(H.period[j])]
        groups = [[a]]
        for j in range(a + 1, b + 1):
            periods = [H.period[i] for i in groups[-1] if i in known]
            if j in known and periods and abs(H.period[j] / np.median(periods) - 1) > SAME:
                groups.append([])
            groups[-1].append(j)
        for g in groups:
            periods = [H.period[i] for i in g if i in known]
            if len(g) >= 3 and periods:
                out.append((g[0], g[-1], float(np.median(periods))))
    return out


def _runs(H, free):
    """[(first, last half-cycle)] of runs of free half-cycles of at least MIN_TRAVEL whose
    travel and mid-level lie within SAME (of the travel) of the run's medians."""
    out, run = [], []
    for j in range(len(H)):
        ok = free[j] and H.travel[j] >= MIN_TRAVEL
        if run and ok:
            a = float(np.median(H.travel[run]))
            ok_here = abs(H.travel[j] / a - 1) <= SAME and abs(H.mid[j] - np.median(H.mid[run])) <= SAME * a
        if run and not (ok and ok_here):
            out.append((run[0], run[-1]))
            run = []
        if ok:
            run.append(j)
    if run:
        out.append((run[0], run[-1]))
    return out


def _ends(t, x, i0, i1, got, taken):
    """(t0, t1) [s]: the steady stretch the fit holds, followed from samples i0 and i1 out
    (at most a cycle, never into a segment already taken) until the displacement leaves the
    fit, less the fit's own misfit at that phase and averaged over a 40th of a cycle, by EDGE
    of the amplitude or half as much again as anywhere between i0 and i1 (the noise), if more."""
    h = float(np.median(np.diff(t[i0:i1 + 1])))
    w = max(1, int(round(1.0 / (40 * got.freq * h))))
    reach = int(round(1.0 / (got.freq * h)))
    lo = max(0, i0 - reach)
    hi = min(len(t) - 1, i1 + reach)
    for a, b in taken:
        if b <= t[i0]:
            lo = max(lo, int(np.searchsorted(t, b)))
        if a >= t[i1]:
            hi = min(hi, int(np.searchsorted(t, a)) - 1)
    r = x[lo:hi + 1] - got.at(t[lo:hi + 1])
    # the fit's own misfit repeats with the motion (harmonics round a triangle's corners): it is
    # taken out at each phase as it lies between i0 and i1, so that only a change of motion is left
    bins = max(1, min(128, int(1.0 / (got.freq * h)) // 2))
    phase = (((t[lo:hi + 1] - t[i0]) * got.freq) % 1.0 * bins).astype(int) % bins
    inner = slice(i0 - lo, i1 - lo + 1)
    own = np.bincount(phase[inner], r[inner], bins) / np.maximum(np.bincount(phase[inner], minlength=bins), 1)
    r = np.abs(np.convolve(r - own[phase], np.ones(w) / w, mode="same"))
    inside = r[i0 - lo + w:i1 - lo - w]
    tol = max(EDGE * got.amplitude, 1.5 * float(inside.max()) if len(inside) else 0.0)
    bad = np.flatnonzero(r > tol) + lo
    before, after = bad[bad < i0], bad[bad > i1]
    start = int(before[-1]) + 1 if len(before) else lo
    end = int(after[0]) - 1 if len(after) else hi
    return float(t[start]), float(t[end])


def _apart(sines):
    """Steady tests in time order with none overlapping its neighbour. Two tests stepped
    straight into each other are each followed a little past the step: the overlap is cut
    at its middle, and each keeps its whole cycles when it loses at most CYCLE_SLACK of a
    cycle (the slack they were counted with), else the whole cycles left."""
    sines.sort(key=lambda s: s.t0)
    for a, b in zip(sines, sines[1:]):
        if a.t1 <= b.t0:
            continue
        cut = 0.5 * (a.t1 + b.t0)
        for s, lost in ((a, a.t1 - cut), (b, cut - b.t0)):
            f = s.params["freq_hz"]
            if lost * f > CYCLE_SLACK:
                s.params["cycles"] -= int(math.ceil(lost * f - CYCLE_SLACK))
        a.t1, b.t0 = cut, cut
    return [s for s in sines if s.params["cycles"] >= MIN_CYCLES]


def _fill(t, xs, tests, turns):
    """tests with every stretch between them (and before and after) cut into holds and
    dwells, steps, ramps beside a sine, a sweep's tapers (the sweep widened) and motion that
    does not repeat. Still: within HOLD_BAND for DWELL_S or longer, but for a slow motion's
    turning point (turns, _turns), still for a moment either side of it: a still stretch with
    one in its middle three fifths, lasting less than TURN_SHARE of its half-cycles, is none
    (a hold's own turning points lie at its ends, or in it with half-cycles that take in the
    hold)."""
    edges = [float(t[0])] + [e for s in tests for e in (s.t0, s.t1)] + [float(t[-1])]
    out = list(tests)
    for i, (a, b) in enumerate(zip(edges[::2], edges[1::2])):
        if b - a <= 0:
            continue
        k = np.flatnonzero((t >= a) & (t <= b))
        pieces, last = [], a
        for tp, tq in _still(t[k], xs[k]):
            margin = 0.2 * (tq - tp)
            inside = (turns[:, 0] > tp + margin) & (turns[:, 0] < tq - margin)
            if tq - tp < DWELL_S or np.any(tq - tp < TURN_SHARE * turns[inside, 1]):
                continue
            if (pieces and pieces[-1][0] == "still" and tp - last < DWELL_S
                    and abs(_level(t, xs, tp, tq) - _level(t, xs, *pieces[-1][1:])) <= HOLD_BAND):
                pieces[-1][2] = tq  # a hold that wandered out of its band a moment: one hold
                last = tq
                continue
            if tp > last:
                pieces.append(["moving", last, tp])
            pieces.append(["still", tp, tq])
            last = tq
        if b > last:
            pieces.append(["moving", last, b])
        before = tests[i - 1] if i > 0 else None
        after = tests[i] if i < len(tests) else None
        out += _named_pieces(t, xs, pieces, before, after)
    out.sort(key=lambda s: s.t0)
    return _merged(out)


def _named_pieces(t, xs, pieces, before, after):
    """Segments of the still and moving pieces of a stretch between two tests (or None)."""
    out = []
    for i, (what, t0, t1) in enumerate(pieces):
        k = (t >= t0) & (t <= t1)
        if what == "still":
            xm = float(np.mean(xs[k])) if k.any() else float(np.interp(t0, t, xs))
            kind = "hold" if t1 - t0 >= HOLD_S else "dwell"
            out.append(Segment(f"{kind} {xm * 1e3:.1f} mm", kind, t0, t1,
                               {"kind": kind, "x_mm": round(xm * 1e3, 2), "measured": True, "found": "import",
                                "approach": _approach(t, xs, t0)}))
            continue
        left = before if i == 0 else None
        right = after if i == len(pieces) - 1 else None
        still_around = 0 < i < len(pieces) - 1
        travel = float(np.ptp(xs[k])) if k.any() else 0.0
        if still_around and _monotonic(xs[k], travel) and travel >= MIN_TRAVEL:
            step = float(xs[k][-1] - xs[k][0])
            out.append(Segment(f"step {step * 1e3:+.3g} mm", "step", t0, t1,
                               {"kind": "step", "step_mm": round(step * 1e3, 3), "measured": True, "found": "import"}))
        elif left is not None and left.kind == "sweep" or right is not None and right.kind == "sweep":
            sweep = left if left is not None and left.kind == "sweep" else right
            sweep.t0, sweep.t1 = min(sweep.t0, t0), max(sweep.t1, t1)  # its tapers
        elif left is not None or right is not None:
            out.append(Segment("ramp", "ramp", t0, t1, {"kind": "ramp", "measured": True, "found": "import"},
                               (left, right)))
        elif travel < MIN_TRAVEL and out:
            out[-1].t1 = t1  # a wobble beside a still stretch is still
        else:
            out.append(Segment("random" if t1 - t0 >= RANDOM_S else "transition", "random", t0, t1,
                               {"kind": "random", "measured": True, "found": "import"}))
    return out


def _monotonic(x, travel):
    """x moves one way only (within a tenth of its travel back)."""
    if len(x) < 2:
        return True
    up = x[-1] >= x[0]
    back = np.maximum.accumulate(x) - x if up else x - np.minimum.accumulate(x)
    return float(back.max()) <= 0.1 * travel


def _approach(t, xs, t0):
    """How a hold was come into (the static test's approaches): the motion over 50 ms before it."""
    i, j = int(np.searchsorted(t, t0)), int(np.searchsorted(t, t0 - 0.05))
    came = xs[min(i, len(xs) - 1)] - xs[min(j, len(xs) - 1)]
    return "compression stroke" if came > 0 else "extension stroke"


def _merged(segs):
    """Stretches shorter than LEAST_S joined to a neighbour that is no test (the one before,
    else the one after): a test keeps its whole cycles."""
    out, pending = [], None
    for s in segs:
        if s.t1 - s.t0 < LEAST_S and s.kind not in ("sine", "sweep"):
            if out and out[-1].kind not in ("sine", "sweep") and abs(out[-1].t1 - s.t0) < 1e-9:
                out[-1].t1 = s.t1
            else:
                pending = s.t0 if pending is None else pending
            continue
        if pending is not None and s.kind not in ("sine", "sweep"):
            s.t0 = pending
        pending = None
        out.append(s)
    return out


def _level(t, xs, t0, t1):
    return float(np.mean(xs[(t >= t0) & (t <= t1)]))


def _still(t, xs):
    """[(t0, t1)] of the still stretches: runs within HOLD_BAND of DWELL_S / 4 or longer whose
    first and last quarters lie together (a slow motion crosses the band), those that follow each other
    one while all lie within twice the band (a hold's slow wander leaves the band now and then)."""
    out = []
    for p, q in (_still_runs(xs, HOLD_BAND).tolist() if len(t) else []):
        m = max(1, (q - p + 1) // 4)
        if t[q] - t[p] < DWELL_S / 4 or abs(np.median(xs[q + 1 - m:q + 1]) - np.median(xs[p:p + m])) > HOLD_BAND / 2:
            continue  # slow motion crosses the band: its first and last quarters lie apart
        lo, hi = float(xs[p:q + 1].min()), float(xs[p:q + 1].max())
        if out and p <= out[-1][2] + 1 and max(hi, out[-1][4]) - min(lo, out[-1][3]) <= 2 * HOLD_BAND:
            out[-1][1:] = [float(t[q]), q, min(lo, out[-1][3]), max(hi, out[-1][4])]
        else:
            out.append([float(t[p]), float(t[q]), q, lo, hi])
    return [(a, b) for a, b, *_ in out]


@njit(cache=True)
def _still_runs(x, travel):
    """(first, last) index pairs of the maximal runs within `travel` of each other, in order."""
    out = np.empty((len(x), 2), np.int64)
    n, i = 0, 0
    while i < len(x):
        j, lo, hi = i, x[i], x[i]
        while j + 1 < len(x) and max(hi, x[j + 1]) - min(lo, x[j + 1]) <= travel:
            j += 1
            lo, hi = min(lo, x[j]), max(hi, x[j])
        out[n, 0], out[n, 1] = i, j
        n += 1
        i = j + 1
    return out[:n]


def _name(out):
    """Segments of one test repeated (at another current, another temperature) numbered,
    under the first's name (a repeat's estimated frequency differs in the last digit); a
    ramp named after its sine; holds, dwells and the rest numbered alike."""
    sines = [s for s in out if s.kind == "sine"]
    groups = same_tests([Test.of(s.params) for s in sines])
    for i, g in enumerate(groups):
        if g != i:
            sines[i].name = f"{sines[g].name} ({groups[:i + 1].count(g)})"
    for s in out:
        if s.kind == "ramp":
            a, b = s.of
            s.name = (f"ramp into {b.name}" if a is None or a.kind != "sine" else f"ramp out of {a.name}"
                      if b is None or b.kind != "sine" else f"from {a.name} to {b.name}")
    seen = {}
    for s in out:
        if s.kind != "sine":
            seen[s.name] = seen.get(s.name, 0) + 1
            s.name += f" ({seen[s.name]})" if seen[s.name] > 1 else ""


KIND_WORDS = {"sine": ("sine", "sines"), "triangle": ("triangle", "triangles"), "sweep": ("sweep", "sweeps"),
              "ramp": ("ramp", "ramps"), "hold": ("hold", "holds"), "dwell": ("dwell", "dwells"),
              "step": ("step", "steps"), "random": ("stretch of random motion", "stretches of random motion")}


def division(segments, duration) -> str:
    """How the recording divides among the segments: "96 % in 22 sines, 3 % ramps, 1 %
    holds", largest first, with what no segment holds (holes in the time stamps)."""
    if not duration > 0:
        return ""
    share, count = {}, {}
    for s in segments:
        k = "triangle" if s.params.get("waveform") == "triangle" else s.kind
        share[k] = share.get(k, 0.0) + (s.t1 - s.t0)
        count[k] = count.get(k, 0) + 1
    parts = []
    for k in sorted(share, key=lambda k: -share[k]):
        one, many = KIND_WORDS.get(k, (k, k + "s"))
        parts.append(f"{100 * share[k] / duration:.0f} % in {count[k]} {one if count[k] == 1 else many}")
    unread = duration - sum(share.values())
    if unread > 0.005 * duration:
        parts.append(f"{100 * unread / duration:.0f} % in no segment (holes in the time stamps)")
    return ", ".join(parts)


def cut(channels, events) -> list[Span]:
    """The one cut every analysis reads (issue 88): the recording's own measured segments
    when it marks any (a run of ours, an import), else those its displacement is cut into
    here (an MCAP another tool wrote)."""
    if any(isinstance(e, SegmentStart) for e in events) or "x" not in channels:
        return recorded_segments(events)
    return [Span(s.name, s.params, s.t0, s.t1) for s in find(*channels["x"])]


def events(segments) -> list[Event]:
    """The segment_start and segment_end events a run writes, for these segments."""
    out = []
    for s in segments:
        out += [SegmentStart(s.t0, s.name, s.params), SegmentEnd(s.t1, s.name)]
    return out
