"""A recording made elsewhere cut into the segments our analyses read (issue 43): periodic
motion (a sine, a crank dyno's skewed stroke, a triangle) into cycles, grouped by frequency
and amplitude into sine segments named as ours are (`sine 19 mm 1.05 Hz`), and static holds.
Motion that does not repeat is left to the analyses, which cut it into blocks.

Arrays in (t [s], x [m]), dataclasses out; the events a run would have written come from
`events()`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from records.events import Event, SegmentEnd, SegmentStart
from records.data import Test, same_tests, segments

MIN_TRAVEL = 2e-4  # m: a cycle moves at least this far each way (below: noise about a hold)
REVERSAL_SHARE = 0.25  # a crossing counts once the motion has gone this share of the local range back
SAME_PERIOD = 0.05  # cycles within 5 % of each other's period ...
SAME_AMPLITUDE = 0.10  # ... and 10 % of amplitude (and mean) belong to one segment ...
SAME_SHAPE = 0.15  # ... and whose strokes, put on one phase scale, differ by at most this RMS share of the amplitude
SHAPE_POINTS = 32  # phases a stroke's shape is compared at
MIN_CYCLES = 2
# motion that mostly does not repeat (a random input) holds pairs of alike strokes by chance:
# where the sine segments cover less than REPEATING of the time not held, only runs of
# CHANCE_CYCLES or more are tests (a sine run in a random file is still found)
REPEATING = 0.5
CHANCE_CYCLES = 4
HOLD_S = 0.5  # s: a hold lasts at least this long ...
HOLD_TRAVEL = 5e-5  # m: ... within this band
LEFT_S = 1.0  # s: strokes outside every segment worth saying they are left out


@dataclass
class Segment:
    name: str
    kind: str  # "sine" or "hold"
    t0: float
    t1: float
    params: dict = field(default_factory=dict)


def _g(v):
    return f"{v:.3g}"


def cycles(t, x):
    """[(t_start, t_end, amplitude [m], mean [m], shape)] of whole strokes: x rising through
    its local mid-level, each counted once the motion has gone REVERSAL_SHARE of the range
    back; shape: x at SHAPE_POINTS phases of the stroke, less its mean, over its amplitude."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    ok = np.isfinite(t) & np.isfinite(x)
    t, x = t[ok], x[ok]
    if len(t) < 8 or np.ptp(x) < 2 * MIN_TRAVEL:
        return []
    starts = _cycle_starts(x, 2 * MIN_TRAVEL, REVERSAL_SHARE).tolist()
    out = []
    for a, b in zip(starts, starts[1:]):
        seg = x[a:b + 1]
        amp, mid = float(np.ptp(seg) / 2), float((seg.max() + seg.min()) / 2)
        shape = (np.interp(np.linspace(t[a], t[b], SHAPE_POINTS), t[a:b + 1], seg) - mid) / max(amp, 1e-12)
        out.append((float(t[a]), float(t[b]), amp, mid, shape))
    return out


@njit(cache=True)
def _cycle_starts(x, min_span, share):
    """Indices where x rises through its mid-level, once it has come down share of the
    range below it. The mid-level follows the motion: a running median over a few seconds
    would be costly, so the level is the midpoint of the range between successive extremes."""
    starts = np.empty(len(x), np.int64)
    n, armed, lo, hi = 0, False, x[0], x[0]
    for i in range(1, len(x)):
        lo, hi = min(lo, x[i]), max(hi, x[i])
        span = hi - lo
        if span < min_span:
            continue
        mid = 0.5 * (hi + lo)
        if not armed and x[i] < mid - share * span / 2:
            armed = True  # come down far enough: the next rise through mid is a new cycle
        elif armed and x[i - 1] < mid <= x[i]:
            starts[n] = i
            n += 1
            armed = False
            lo = hi = x[i]
    return starts[:n]


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


def _alike(c, run):
    """A stroke of the test the strokes `run` are: period, amplitude and mean as its first,
    shape as the one before (a random input's strokes can match in period and size by
    chance, seldom in shape as well)."""
    ref = run[0]
    return (ref[1] > ref[0] and abs((c[1] - c[0]) / (ref[1] - ref[0]) - 1) <= SAME_PERIOD
            and abs(c[2] / ref[2] - 1) <= SAME_AMPLITUDE and abs(c[3] - ref[3]) <= SAME_AMPLITUDE * ref[2]
            and float(np.sqrt(np.mean((c[4] - run[-1][4]) ** 2))) <= SAME_SHAPE)


def find(t, x) -> list[Segment]:
    """The sine segments (runs of at least MIN_CYCLES alike cycles) and holds of a
    recording, in time order."""
    out = []
    run = []
    for c in cycles(t, x) + [None]:
        if c is not None and c[2] >= MIN_TRAVEL and run and _alike(c, run):
            run.append(c)
            continue
        if len(run) >= MIN_CYCLES:
            t0, t1 = run[0][0], run[-1][1]
            amp = float(np.median([r[2] for r in run]))
            hz = len(run) / (t1 - t0)
            out.append(Segment(f"sine {_g(amp * 1e3)} mm {_g(hz)} Hz", "sine", t0, t1,
                               {"kind": "sine", "amplitude_mm": float(_g(amp * 1e3)), "freq_hz": float(_g(hz)),
                                "cycles": len(run), "measured": True, "found": "import"}))
        run = [c] if c is not None and c[2] >= MIN_TRAVEL else []
    still = holds(t, x, [(s.t0, s.t1) for s in out])
    moving = (t[-1] - t[0]) - sum(s.t1 - s.t0 for s in still) if len(t) else 0.0
    if sum(s.t1 - s.t0 for s in out) < REPEATING * moving:
        out = [s for s in out if s.params["cycles"] >= CHANCE_CYCLES]
    out += still
    out.sort(key=lambda s: s.t0)
    # the same test repeated (at another current, another temperature): numbered, under the
    # first's name (a repeat's estimated frequency differs in the last digit)
    sines = [s for s in out if s.kind == "sine"]
    groups = same_tests([Test.of(s.params) for s in sines])
    for i, g in enumerate(groups):
        if g != i:
            sines[i].name = f"{sines[g].name} ({groups[:i + 1].count(g)})"
    seen = {}
    for s in out:
        if s.kind == "hold":
            seen[s.name] = seen.get(s.name, 0) + 1
            s.name += f" ({seen[s.name]})" if seen[s.name] > 1 else ""
    return out


def unsegmented(t, x, spans, least_s=LEFT_S):
    """[(t0, t1, seconds of strokes, [(start, end) of each stroke])] of the motion outside
    `spans` [(t0, t1)]: strokes that repeat no test (a sweep whose period changes by more
    than SAME_PERIOD a cycle), in stretches holding at least least_s of them."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    edges = sorted((a, b) for a, b in spans)
    # a hole in the file (its acquisition paused) is no stroke, however far x moved across it
    pieces = np.split(np.arange(len(t)), np.flatnonzero(np.diff(t) > 5 * np.median(np.diff(t))) + 1)
    out = []
    for a, b in zip([-np.inf] + [e[1] for e in edges], [e[0] for e in edges] + [np.inf]):
        strokes = [c for i in pieces for k in [i[(t[i] >= a) & (t[i] <= b)]] for c in cycles(t[k], x[k])
                   if c[2] >= MIN_TRAVEL]
        moving = sum(c[1] - c[0] for c in strokes)
        if moving >= least_s:
            out.append((strokes[0][0], strokes[-1][1], moving, [(c[0], c[1]) for c in strokes]))
    return out


def left_out(rest) -> str:
    """unsegmented()'s stretches in words (what import, report and diagnosis say), or ""."""
    if not rest:
        return ""
    where = ", ".join(f"{a:.1f}-{b:.1f} s" for a, b, *_ in rest)
    return (f"{sum(m for _, _, m, _ in rest):.1f} s of strokes outside the sine segments ({where}) repeat no test "
            f"(a sweep's period changes by more than {100 * SAME_PERIOD:g} % a cycle): the loops, peaks and "
            f"diagnosis read the segments alone")


def imported_unsegmented(events, t, x):
    """unsegmented() of an imported recording (its segments found here), or []: a run of
    ours has its settling and ramps between its segments by design."""
    found = [s for s in segments(events) if s.params.get("found") == "import"]
    if not any(s.kind == "sine" for s in found):
        return []
    return unsegmented(t, x, [(s.t0, s.t1) for s in found])


def holds(t, x, taken=()):
    """Static holds: HOLD_S or longer with x within HOLD_TRAVEL, outside the `taken` spans."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    out = []
    for i, j in _still_runs(x, HOLD_TRAVEL).tolist():
        if t[j] - t[i] >= HOLD_S and not any(a < t[j] and t[i] < b for a, b in taken):
            xm = float(np.mean(x[i:j + 1]))
            came = x[i] - x[max(i - 50, 0)]  # the motion into the hold: as the static test's approaches
            out.append(Segment(f"hold {xm * 1e3:.1f} mm", "hold", float(t[i]), float(t[j]),
                               {"kind": "hold", "x_mm": round(xm * 1e3, 1), "measured": True, "found": "import",
                                "approach": "compression stroke" if came > 0 else "extension stroke"}))
    return out


def events(segments) -> list[Event]:
    """The segment_start and segment_end events a run writes, for these segments."""
    out = []
    for s in segments:
        out += [SegmentStart(s.t0, s.name, s.params), SegmentEnd(s.t1, s.name)]
    return out
