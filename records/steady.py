"""The steady tests and sweeps among a program's half-cycles (records/strokes.py; issue 88).

Sweeps first: half-cycles whose period drifts smoothly (a line through a dozen of them
explains it) by SWEEP_CHANGE or more. Steady tests: runs of alike half-cycles (travel, level
and period within SAME), then a periodic motion fitted to the displacement itself, its
frequency refined; its ends are followed sample by sample while the fit holds (a run's
half-cycles stop a quarter cycle short of a test's ends), and whole cycles are taken from
the middle. A stroke at constant speed is a triangle, else a sine (a crank's included)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from records.strokes import MIN_TRAVEL, Halves, fit

SAME = 0.03  # half-cycles of one steady test: travel, mid-level (of the travel) and period within this share
STEADY_FIT = 0.01  # of the amplitude: RMS misfit of a steady test's periodic fit (beyond the noise) ...
EDGE = 0.01  # ... and where it is followed to its ends, the misfit [of the amplitude] that ends it
MIN_CYCLES = 2  # a steady test has at least this many whole cycles
# a seed's frequency is searched this far about its half-cycles' period: two cycles' few
# periods reach across to the crossings of the motion beside them (3.4 % off beside a ramp)
SEED_SEARCH = 0.05
CYCLE_SLACK = 0.05  # of a cycle: a steady stretch this short of a whole number of cycles still holds it
SWEEP_WINDOW = 5  # half-cycles each side of one: the line its period is judged against
SWEEP_SMOOTH = 0.3  # a sweep's periods leave that line by at most this share of their change per half-cycle ...
SWEEP_RATE = 5e-4  # ... which is at least this (a steady sine's periods jitter by a tenth of it)
SWEEP_FOLLOW = 0.02  # its ends followed while their period stays this close to its line
SWEEP_HALVES = 10  # a sweep lasts at least this many half-cycles ...
SWEEP_CHANGE = 0.1  # ... and its frequency changes by at least this share


@dataclass
class FoundSegment:
    name: str
    kind: str  # sine (waveform sine or triangle), sweep, ramp, hold, dwell, step, random
    t0: float
    t1: float
    params: dict = field(default_factory=dict)
    of: tuple = field(default=(None, None), repr=False)  # a ramp's: the tests before and after it


def _g(v):
    return f"{v:.3g}"


def _swept(H):
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


def sweeps(t: np.ndarray, H: Halves) -> list[FoundSegment]:
    """The sweeps among the half-cycles H (records/strokes.Halves) at times t [s]; their
    params come from sweep_params once their tapers have widened them."""
    return [FoundSegment("sweep", "sweep", float(t[H.ext[a]]), float(t[H.ext[b + 1]])) for a, b in _swept(H)]


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


def sweep_params(H: Halves, t0: float, t1: float) -> dict:
    """A sweep's params: its frequency [Hz] at its first and last strokes of MIN_TRAVEL or
    more between t0 and t1 [s] but the outermost (one over their periods) and its median
    amplitude."""
    k = (H.cross >= t0) & (H.cross <= t1) & (H.travel >= MIN_TRAVEL) & np.isfinite(H.period)
    k[np.flatnonzero(k)[[0, -1]] if k.sum() > 2 else []] = False  # their periods reach across its ends
    f = 1.0 / H.period[k]
    return {"kind": "sweep", "f_start_hz": round(float(f[0]), 4), "f_end_hz": round(float(f[-1]), 4),
            "amplitude_mm": round(float(np.median(H.travel[k])) / 2 * 1e3, 3), "measured": True, "found": "import"}


def steady(t: np.ndarray, x: np.ndarray, H: Halves, sigma: float, swept: list[FoundSegment], source: str | None = None
          ) -> list[FoundSegment]:
    """The steady periodic tests among the half-cycles H (records/strokes.Halves) at times t
    [s] of the displacement x [m] (its noise sigma [m]) that are in none of the sweeps.
    source: the source's moving average (records/source_filter), whose reach at either end of
    a stretch holds no whole cycle: there it averaged what lies beyond."""
    free = ~np.any([(H.cross >= s.t0) & (H.cross <= s.t1) for s in swept], axis=0) if swept else np.ones(len(H), bool)
    taken = [(s.t0, s.t1) for s in swept]
    held = []
    for a, b, period in _alike_runs(H, free):
        got = _seed(t, x, H, a, b, 1.0 / period, sigma)
        if got is None or not _steady(got, sigma):
            continue
        a, b, got = got.run
        i0, i1 = H.ext[a], H.ext[b + 1]
        held0, held1 = _ends(t, x, i0, i1, got, taken)
        # a seed of three half-cycles holds its frequency loosely (0.4 % off, which stopped a 2 cycle
        # test's ends a quarter cycle short): refitted on all it holds, its ends followed again
        j0, j1 = int(np.searchsorted(t, held0)), int(np.searchsorted(t, held1, "right")) - 1
        again = fit(t[j0:j1 + 1], x[j0:j1 + 1], got.freq) if b - a < 2 * MIN_CYCLES - 1 else None
        if again is not None and _steady(again, sigma):
            got = again
            held0, held1 = _ends(t, x, j0, j1, got, taken)
        held.append([held0, held1, got, float(np.median(np.diff(t[i0:i1 + 1])))])
    out, fits = [], []
    for held0, held1, got, h in _stepped(held, t, x):
        found = _whole(t, x, held0, held1, got, h, source)
        if found is not None:
            out.append(found[0])
            fits.append(found[1])
    return _apart(out, fits, t, x)


def _stepped(held, t, x):
    """The steady stretches held ([t0, t1, fit, sample period]) with none overlapping the
    next: two tests stepped straight into each other are each followed past the step while
    their motions agree, so each stretch ends where the displacement leaves one fit for the
    other (_step_at), before whole cycles are counted in it; where the tests were counted
    first, the one found first kept the overlap and the other lost a cycle. A stretch
    within another is the same test's."""
    out = []
    for s in sorted(held, key=lambda s: s[0]):
        if out and s[1] <= out[-1][1]:
            continue
        if out and s[0] < out[-1][1]:
            out[-1][1] = s[0] = _step_at(t, x, out[-1][2], s[2], s[0], out[-1][1])
        out.append(s)
    return out


def _whole(t, x, held0, held1, got, h, source):
    """(FoundSegment, its fit) of the whole cycles in the steady stretch held0..held1 [s] of
    the fit got (sample period h [s]), or None for fewer than MIN_CYCLES."""
    # a source's moving average blends whatever lies within its reach of a stretch's ends (the
    # file's ends, a ramp, the next test) into it: no whole cycle is taken there
    edge = 0.0 if source is None else source.reach(got.freq)
    soft0, soft1 = held0 > t[0] and not edge, held1 < t[-1] and not edge
    held0, held1 = max(held0, float(t[0])) + edge, min(held1, float(t[-1])) - edge
    # a stretch ends between the last sample the fit held and the first it did not, and a
    # little past that (EDGE stops inside a ramp): there whole cycles may reach a sample and
    # half CYCLE_SLACK further (two tests stepped into each other: _apart); the recording's
    # ends and a source's reach are where it ends, to a sample (a test of 1.05 Hz at 300 Hz is
    # no whole number of samples a cycle: its last may fall just past a file's end)
    pad = h + 0.5 * CYCLE_SLACK / got.freq
    lo, hi = held0 - (pad if soft0 else h), held1 + (pad if soft1 else h)
    n = int(math.floor((hi - lo) * got.freq + 1e-9))
    if n < MIN_CYCLES:
        return None
    # whole cycles from the stretch's firm end when it has one (the same whatever lies past
    # its other end: one run reads alike in the file that holds it alone), else in its middle
    if soft0 == soft1:
        t0 = 0.5 * (lo + hi - n / got.freq)
    else:
        t0 = held0 if soft1 else hi - n / got.freq
    k = (t >= max(t0, held0)) & (t <= min(t0 + n / got.freq, held1))
    final = fit(t[k], x[k], got.freq, search=0.002) or got
    amp = final.amplitude
    return FoundSegment(f"{final.waveform} {_g(amp * 1e3)} mm {_g(final.freq)} Hz", "sine", float(t0),
                        float(t0 + n / final.freq),
                        {"kind": "sine", "amplitude_mm": round(amp * 1e3, 4), "freq_hz": round(final.freq, 5),
                         "cycles": n, "waveform": final.waveform, "measured": True, "found": "import"}), final


def _steady(got, sigma):
    return got.rms <= STEADY_FIT * got.amplitude + 2 * sigma


def _seed(t, x, H, a, b, f0, sigma):
    """The fit of the half-cycles a to b (Fit, its .run (a, b, fit) the half-cycles kept),
    less those at either end that the fit misses three times as badly as the median half-
    cycle: the half-cycle that joins two tests, let in where a few samples a cycle blur its
    travel. While the fit is not steady and no end stands out (two cycles' fit bends to a
    joining half-cycle and spreads its misfit over all), the end whose loss leaves the
    steadier fit goes. Each fit searches about the period of the half-cycles it keeps (both
    crossings within them): about the fit before, a seed lost the test (a 2 cycle sine's fit
    bent to the joining half-cycle 8 % off, its search kept it there), and a period reaching
    across a dwell to the test before took a 1.9 Hz seed to 0.65 Hz. None where no fit is made."""
    def part(a, b):
        p = H.period[a + 1:b]
        p = p[np.isfinite(p)]
        f = 1.0 / float(np.median(p)) if len(p) else f0
        return fit(t[H.ext[a]:H.ext[b + 1] + 1], x[H.ext[a]:H.ext[b + 1] + 1], f, search=SEED_SEARCH)
    got = part(a, b)
    while got is not None and b - a >= 3:
        i0, i1 = H.ext[a], H.ext[b + 1]
        r = x[i0:i1 + 1] - got.at(t[i0:i1 + 1])
        miss = np.array([np.sqrt(np.mean(r[H.ext[j] - i0:H.ext[j + 1] - i0 + 1] ** 2)) for j in range(a, b + 1)])
        worst = int(np.argmax(miss[[0, -1]]))
        if miss[[0, -1]][worst] > 3 * np.median(miss) + EDGE * got.amplitude / 10:
            a, b = (a + 1, b) if worst == 0 else (a, b - 1)
            got = part(a, b)
        elif not _steady(got, sigma):
            left, right = part(a + 1, b), part(a, b - 1)
            share = lambda g: g.rms / g.amplitude if g is not None and g.amplitude > 0 else np.inf
            a, b, got = (a + 1, b, left) if share(left) <= share(right) else (a, b - 1, right)
        else:
            break
    if got is not None:
        got.run = (a, b, got)
    return got


def _alike_runs(H, free):
    """[(first, last half-cycle, period [s])] of runs of at least three alike half-cycles (a
    sine's two whole cycles less the quarter cycles at its ends): their travel and mid-level
    within SAME of the run's medians, then split where the period changes by more than
    SAME, two half-cycles running (the one at the change in both). A run's first and last half-cycles take the period of
    their neighbours: theirs reaches across to the crossing of the motion beside the run."""
    out = []
    for a, b in _runs(H, free):
        known = {j for j in range(a + 1, b) if np.isfinite(H.period[j])}
        # the known periods of the group being grown, kept as it grows: gathered again at each
        # half-cycle, a 1,000-cycle sine took 10 s of a million-row import's 16
        groups, periods = [[a]], []
        for j in range(a + 1, b + 1):
            off = lambda i: i in known and abs(H.period[i] / np.median(periods) - 1) > SAME
            # the next confirms a change (a run's last known period reaches across to the motion
            # beside it); the half-cycle at the change goes to both groups, their seeds' fits decide
            if periods and off(j) and off(j + 1):
                groups[-1].append(j)
                groups.append([])
                periods = []
            groups[-1].append(j)
            if j in known:
                periods.append(H.period[j])
        for g in groups:
            # a group's end half-cycles reach across to the crossing of the group beside it (a
            # sine stepped into another): its period from its inner ones where it has them
            periods = [H.period[i] for i in g[1:-1] if i in known] or [H.period[i] for i in g if i in known]
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
    # averaged over w samples, a misfit that sets in at a sample shows w / 2 before it
    start = max(int(before[-1]) + 1 - w // 2, lo) if len(before) else lo
    end = min(int(after[0]) - 1 + w // 2, hi) if len(after) else hi
    return float(t[start]), float(t[end])


def _apart(sines, fits, t, x):
    """Steady tests in time order with none overlapping its neighbour. Two tests stepped
    straight into each other are each followed a little past the step (their motions
    agree there within EDGE): the overlap is cut where the displacement leaves one fit
    (fits, each test's) for the other, and each keeps its whole cycles when it loses at
    most CYCLE_SLACK of a cycle (the slack they were counted with), else the whole cycles
    left."""
    order = sorted(range(len(sines)), key=lambda i: sines[i].t0)
    sines, fits = [sines[i] for i in order], [fits[i] for i in order]
    for (a, fa), (b, fb) in zip(zip(sines, fits), zip(sines[1:], fits[1:])):
        if a.t1 <= b.t0:
            continue
        cut = _step_at(t, x, fa, fb, b.t0, a.t1)
        for s, lost in ((a, a.t1 - cut), (b, cut - b.t0)):
            f = s.params["freq_hz"]
            if lost * f > CYCLE_SLACK:
                s.params["cycles"] -= int(math.ceil(lost * f - CYCLE_SLACK))
        a.t1, b.t0 = cut, cut
    return [s for s in sines if s.params["cycles"] >= MIN_CYCLES]


def _step_at(t, x, fa, fb, t0, t1):
    """Where [s] between t0 and t1 the displacement x leaves fit fa for fb: the sample that
    leaves fa's misfit before it and fb's after it least in sum; t0 when every sample is
    fb's, t1 when every one is fa's, the middle where the two fits cannot tell (one sample,
    or both alike on all). (The middle for the first two as well cut a slow sine's
    overshoot into the fast one after it in half: a cycle of it lost.)"""
    k = np.flatnonzero((t >= t0) & (t <= t1))
    if len(k) < 2:
        return 0.5 * (t0 + t1)
    ra, rb = (x[k] - fa.at(t[k])) ** 2, (x[k] - fb.at(t[k])) ** 2
    cost = np.concatenate([[0.0], np.cumsum(ra)]) + np.concatenate([np.cumsum(rb[::-1])[::-1], [0.0]])
    if np.ptp(cost) <= 1e-12 * max(float(np.max(cost)), 1e-300):
        return 0.5 * (t0 + t1)
    j = int(np.argmin(cost))
    return float(t0) if j == 0 else float(t1) if j == len(k) else float(t[k[j]])
