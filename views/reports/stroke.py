"""The force read along the stroke (a crank dyno's curve, a run of one speed, a random
input's scatter): the mean force in speed bins per direction, a loop's mid-line. SI: m/s, N."""
from __future__ import annotations

import numpy as np

STROKE_BINS = 20  # speed bins per direction of the force read along the stroke


def stroke(v, F, widths=False):
    """The force along the stroke: (speed at each bin's centre [m/s], mean force there [N])
    over STROKE_BINS bins per direction up to the top speed reached. Each bin averages the
    accelerating and the decelerating half of the cycle, as a crank dyno's curve is read
    (the loop's mid-line: the mean of the two halves' means); bins nothing reached, or
    beyond either half's reach, are left out. widths: also the loop's half-width there [N]
    (half the difference of the two halves' means, v in time order; nan for a stroke of
    one half only)."""
    v, F = np.asarray(v, float), np.asarray(F, float)
    rising = np.gradient(np.abs(v)) > 0 if len(v) > 1 else np.zeros(len(v), bool)  # |v| growing: accelerating
    out_v, out_F, out_W = [], [], []
    for sign in (-1.0, 1.0):
        s = sign * v
        top = float(np.max(s, initial=0.0))
        if top <= 0:
            continue
        edges = np.linspace(0.0, top, STROKE_BINS + 1)
        centre = 0.5 * (edges[:-1] + edges[1:])
        centre[-1] = top  # the last bin is read at the top speed, where the peak is
        k = s > 0
        idx = np.minimum(np.searchsorted(edges, s[k], side="right") - 1, STROKE_BINS - 1)
        n = np.bincount(idx, minlength=STROKE_BINS)
        mean = np.bincount(idx, weights=F[k], minlength=STROKE_BINS) / np.maximum(n, 1)
        # each half's mean, and in a bin one half skipped, that half read between its
        # neighbours: sampled at a fixed set of phases (a 20 Hz sine at 1 kHz takes the same
        # 50 every cycle) a bin can hold one half only, and its plain mean was that half's
        # force: on a wide loop the curve zigzagged between the loop's two branches
        parts = [part for part in (rising[k], ~rising[k]) if part.any()]
        halves = [_half(idx[part], F[k][part], centre) for part in parts]
        # one half only (a stroke, not a loop): its mean; both: a bin beyond one half's reach
        # has no mid-line, and is left out rather than read as the other half's force
        mid = 0.5 * (halves[0] + halves[1]) if len(halves) == 2 else mean
        ok = (n > 0) & np.isfinite(mid)
        out_v.append(sign * centre[ok]), out_F.append(mid[ok])
        out_W.append((0.5 * np.abs(halves[0] - halves[1]) if len(halves) == 2 else np.full(len(centre), np.nan))[ok])
    v_all, F_all, W_all = (np.concatenate(a or [np.zeros(0)]) for a in (out_v, out_F, out_W))
    order = np.argsort(v_all)
    return (v_all[order], F_all[order]) + ((W_all[order],) if widths else ())


def _half(idx, F, centre):
    """One half's mean force in each speed bin [N], a bin it skipped read linearly between
    the bins it reached on either side; nan beyond them."""
    m = np.bincount(idx, minlength=len(centre))
    mean = np.where(m > 0, np.bincount(idx, weights=F, minlength=len(centre)) / np.maximum(m, 1), np.nan)
    got = m > 0
    if got.sum() < 2:
        return mean
    return np.interp(centre, centre[got], mean[got], left=np.nan, right=np.nan)
