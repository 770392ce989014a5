"""A recording made elsewhere cut into the tests its dyno program ran (issues 43 and 88),
whatever the sample rate (100 Hz to 10 kHz) and under an LVDT's noise and quantisation:
steady sines (a crank dyno's skewed stroke and a triangle's constant-velocity strokes
included, each named as what it is) in whole cycles, sweeps (records/steady.py), and
between them the ramps into and out of a test, holds and shorter dwells, steps between
holds and motion that does not repeat. Every second of the recording lands in one
segment; nothing is left unread (docs/recording.md#segments-of-an-imported-recording).

Still: within HOLD_BAND for DWELL_S or longer, its first and last quarters together (a
slow motion crosses the band), but for a slow stroke's turning point, still a moment either
side of it. Arrays in (t [s], x [m]), dataclasses out; the events a run would have written
come from `events()`, the one cut every analysis reads from `cut()`."""
from __future__ import annotations

import numpy as np
from numba import njit

from records.data import Channels, Span, Test, same_tests
from records.data import segments as recorded_segments
from records.events import Event, SegmentEnd, SegmentStart
from records.steady import CYCLE_SLACK, FoundSegment, steady, sweep_params, sweeps
from records.strokes import MIN_REVERSAL, MIN_TRAVEL, REVERSAL_NOISE, Halves, noise, smoothed, turns

APPROACH_M = 1e-6  # m: a hold come into by less motion than this over 50 ms was not come into from a side
HOLD_S = 0.5  # s: a hold lasts at least this long (a shorter still stretch is a dwell) ...
HOLD_BAND = MIN_TRAVEL / 2  # m: ... within this band (a real DAQ's hold wanders 0.1 mm over seconds)
DWELL_S = 0.1  # s: ... and a dwell at least this long
TURN_SHARE = 0.7  # a slow sine's turning point is within HOLD_BAND for less than this share of its half-cycle
LEAST_S = 0.02  # s: a stretch between segments shorter than this joins its neighbour
RANDOM_S = 2.0  # s: motion that does not repeat is called random from this long, a transition below

# what the diagnosis reads of an imported recording: the periodic tests by their cycles, these by blocks
BLOCK_KINDS = ("ramp", "sweep", "random")
TESTS = ("sine", "sweep")  # what a short stretch beside is never joined to


def find(t: np.ndarray, x: np.ndarray, source: str | None = None) -> list[FoundSegment]:
    """The segments of a recording's displacement, in time order, covering it (but for
    holes in its time stamps: an acquisition paused). source: the moving average the file's
    source applied (records/source_filter), or None."""
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
            out += _cut(t[k], x[k], h, source)
    _name(out)
    return out


def _cut(t, x, h, source):
    """The segments of a stretch of the recording no hole breaks (source: steady's)."""
    xs = smoothed(x, h)
    H = Halves.of(t, xs, max(REVERSAL_NOISE * noise(t, xs), MIN_REVERSAL))
    swept = sweeps(t, H)
    # the strokes the steady tests, a still stretch's turning point and a sweep's frequencies
    # are read from: of MIN_TRAVEL, each found once the motion has come back that far. A DAQ's
    # spikes cut H's strokes (UTFSM's chirps: 30-90 um reversals at a slow crest, its quietest
    # noise 0.1 um): the crest was read as a dwell, the sweep's first strokes as random motion,
    # and no run of alike strokes seeded a slow sine (a matrix under spikes: 12-19 of 26-27
    # sines found whole, 17-24 from these; without spikes the two cut alike)
    strokes = Halves.of(t, xs, MIN_TRAVEL)
    tests = sorted(swept + steady(t, x, strokes, noise(t, x), swept, source), key=lambda s: s.t0)
    out = _fill(t, xs, tests, turns(t, strokes))
    for s in swept:  # widened by its tapers: its frequencies read over all of it
        s.params = sweep_params(strokes, s.t0, s.t1)
    return out


def _fill(t, xs, tests, turning):
    """tests with every stretch between them (and before and after) cut into holds and
    dwells, steps, ramps beside a sine, a sweep's tapers (the sweep widened) and motion that
    does not repeat. Still: within HOLD_BAND for DWELL_S or longer, but for a slow motion's
    turning point (turning: strokes.turns), still for a moment either side of it (_crest)."""
    edges = [float(t[0])] + [e for s in tests for e in (s.t0, s.t1)] + [float(t[-1])]
    out = list(tests)
    for i, (a, b) in enumerate(zip(edges[::2], edges[1::2])):
        if b - a <= 0:
            continue
        k = np.flatnonzero((t >= a) & (t <= b))
        pieces, last = [], a
        for tp, tq in _still(t[k], xs[k]):
            if tq - tp < DWELL_S or _crest(t, xs, tp, tq, turning):
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
    return _merged(out, float(np.median(np.diff(t))) if len(t) > 1 else 0.0)


def _crest(t, xs, tp, tq, turning):
    """Is the still stretch tp..tq [s] a slow stroke's turning point (turning: strokes.turns),
    not a stop: one of turning within it whose half-cycles are longer than the stretch over
    TURN_SHARE, and the motion over it a parabola bending by a quarter of HOLD_BAND or more
    whose vertex lies in its middle three fifths (a stop's turning point lies at its start;
    the vertex, a fit to all of its samples, is where a DAQ's spikes do not move it)."""
    near = (turning[:, 0] >= tp) & (turning[:, 0] <= tq)
    if not np.any(tq - tp < TURN_SHARE * turning[near, 1]):
        return False
    k = (t >= tp) & (t <= tq)
    half = 0.5 * (tq - tp)
    c2, c1, _ = np.polyfit(t[k] - (tp + half), xs[k], 2)
    return abs(c2) * half ** 2 >= HOLD_BAND / 4 and abs(c1) < 0.6 * half * 2 * abs(c2)


def _named_pieces(t, xs, pieces, before, after):
    """Segments of the still and moving pieces of a stretch between two tests (or None)."""
    out = []
    for i, (what, t0, t1) in enumerate(pieces):
        k = (t >= t0) & (t <= t1)
        if what == "still":
            xm = float(np.mean(xs[k])) if k.any() else float(np.interp(t0, t, xs))
            kind = "hold" if t1 - t0 >= HOLD_S else "dwell"
            out.append(FoundSegment(f"{kind} {xm * 1e3:.1f} mm", kind, t0, t1,
                               {"kind": kind, "x_mm": round(xm * 1e3, 2), "measured": True, "found": "import",
                                "approach": _approach(t, xs, t0)}))
            continue
        left = before if i == 0 else None
        right = after if i == len(pieces) - 1 else None
        still_around = 0 < i < len(pieces) - 1
        travel = float(np.ptp(xs[k])) if k.any() else 0.0
        if still_around and _monotonic(xs[k], travel) and travel >= MIN_TRAVEL:
            step = float(xs[k][-1] - xs[k][0])
            out.append(FoundSegment(f"step {step * 1e3:+.3g} mm", "step", t0, t1,
                               {"kind": "step", "step_mm": round(step * 1e3, 3), "measured": True, "found": "import"}))
        elif left is not None and left.kind == "sweep" or right is not None and right.kind == "sweep":
            sweep = left if left is not None and left.kind == "sweep" else right
            sweep.t0, sweep.t1 = min(sweep.t0, t0), max(sweep.t1, t1)  # its tapers
        elif left is not None or right is not None:
            out.append(FoundSegment("ramp", "ramp", t0, t1, {"kind": "ramp", "measured": True, "found": "import"},
                               (left, right)))
        elif travel < MIN_TRAVEL and out:
            out[-1].t1 = t1  # a wobble beside a still stretch is still
        else:
            out.append(FoundSegment("random" if t1 - t0 >= RANDOM_S else "transition", "random", t0, t1,
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
    """How a hold was come into (the static test's approaches): the motion over 50 ms before
    it; "unknown" at the file's start or where it did not move beyond APPROACH_M."""
    i, j = int(np.searchsorted(t, t0)), int(np.searchsorted(t, t0 - 0.05))
    came = xs[min(i, len(xs) - 1)] - xs[min(j, len(xs) - 1)]
    if i == j or abs(came) <= APPROACH_M:
        return "unknown"
    return "compression stroke" if came > 0 else "extension stroke"


def _merged(segs, h):
    """Stretches shorter than LEAST_S joined to a neighbour that is no test (the one before,
    else the one after): a test keeps its whole cycles. Between two tests (a sine stepped
    into the next), such a stretch stays itself, nothing left unread, unless it is under two
    sample intervals h long (no sample lies between them) or CYCLE_SLACK of either's cycle
    (the slack their whole cycles are counted with): then they meet at its middle."""
    out, pending = [], None
    for s in segs:
        if s.t1 - s.t0 < LEAST_S and s.kind not in TESTS:
            if out and out[-1].kind not in TESTS and abs(out[-1].t1 - s.t0) < 1e-9:
                out[-1].t1 = s.t1
            elif pending is None:
                pending = s
            else:
                pending.t1 = s.t1
            continue
        if pending is not None:
            if s.kind in TESTS:
                out.append(pending)
            else:
                s.t0 = pending.t0
        pending = None
        out.append(s)
    if pending is not None:
        out.append(pending)
    for i in range(len(out) - 2, 0, -1):
        a, s, b = out[i - 1:i + 2]
        slack = CYCLE_SLACK / max(a.params.get("freq_hz", np.inf), b.params.get("freq_hz", np.inf))
        if a.kind in TESTS and b.kind in TESTS and s.t1 - s.t0 < max(2 * h, slack):
            a.t1 = b.t0 = 0.5 * (s.t0 + s.t1)
            del out[i]
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


def division(segments: list[FoundSegment], duration: float) -> str:
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


def cut(channels: Channels, events: list[Event]) -> list[Span]:
    """The one cut every analysis reads (issue 88): the recording's own measured segments
    when it marks any (a run of ours, an import), else those its displacement is cut into
    here (an MCAP another tool wrote)."""
    if any(isinstance(e, SegmentStart) for e in events) or "x" not in channels:
        return recorded_segments(events)
    return [Span(s.name, s.params, s.t0, s.t1) for s in find(*channels["x"])]


def events(segments: list[FoundSegment]) -> list[Event]:
    """The segment_start and segment_end events a run writes, for these segments."""
    out = []
    for s in segments:
        out += [SegmentStart(s.t0, s.name, s.params), SegmentEnd(s.t1, s.name)]
    return out
