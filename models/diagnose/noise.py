"""The force noise a diagnosis measures its gains against: what differs from cycle to cycle at
the same phase, and where the estimate came from (N)."""
from __future__ import annotations

import numpy as np

from models.diagnose.data import Data

STROKE_SPACING = 0.25  # neighbouring strokes this much more unevenly spaced are not compared (a gap between)


def noise_sd(r: np.ndarray, d: Data, k: np.ndarray) -> float:
    """Force noise [N] in the residual r over the samples k: what differs from one cycle to
    the next at the same point of the stroke, with any change slower than a cycle taken out
    (_by_strokes). Drift, warm-up, a heat gun, repeats at another setting are not noise:
    a straight line over the cycles, or a harmonic fit over a whole segment, took up only
    the part of them that is linear and read a heated or drifting run's noise six times
    its steady twin's. The median over segments keeps one badly fitted segment from
    setting it. Sample-to-sample differences (the fallback for motion that does not
    repeat) see only the white part: first-order noise with a pole at 0.95 per sample
    reads as a third of its size, and every structured misfit above that third was then
    announced as physics."""
    same = (np.diff(d.cycle) == 0) & k[1:] & k[:-1]
    diff = float(np.median(np.abs(np.diff(r)[same])) / 0.6745 / np.sqrt(2))
    if not d.periodic:
        return diff
    out = []
    for s, (_, f) in enumerate(d.segments):
        if f is None:  # a block of motion that does not repeat: no stroke to compare with the next
            continue
        j = np.nonzero(d.segment == s)[0]
        got = _by_strokes(r[j], k[j], d.t[j], d.v[j], float(np.median(d.h[j])))
        if got is not None:
            out.append(got)
    return float(np.median(out)) if out else diff


def noise_from(d: Data) -> str:
    """Where noise_sd's estimate came from, in words, with the source's smoothing if any."""
    how = ("what differs from one cycle to the next at the same point of the stroke, slow changes taken out"
           if d.periodic else
           "sample-to-sample differences (the motion does not repeat: only the noise's white part)")
    if d.smoothing is not None or any(f.kind == "smoothed" for f in d.flags):
        how += "; the force was filtered by its source, so this is the filter's noise, not the load cell's"
    return how


def _strokes(t, v, h):
    """[(i0, i1, t_start, t_end, direction)]: the half strokes of one segment, between the
    velocity's zero crossings (interpolated between samples) and never across a gap."""
    sgn = np.sign(v)
    cut = np.nonzero((np.diff(sgn) != 0) | (np.diff(t) > 1.5 * h))[0] + 1
    edges = np.r_[0, cut, len(t)]
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        if b - a < 4 or sgn[a] == 0:
            continue
        t0 = _zero(t, v, a - 1, a) if a > 0 and t[a] - t[a - 1] <= 1.5 * h else None
        t1 = _zero(t, v, b - 1, b) if b < len(t) and t[b] - t[b - 1] <= 1.5 * h else None
        if t0 is not None and t1 is not None:  # a stroke cut by a gap or the segment's edge has no known start
            out.append((a, b, t0, t1, sgn[a]))
    return out


def _zero(t, v, i, j):
    """Time [s] the velocity crosses zero between samples i and j."""
    return float(t[i] + (t[j] - t[i]) * v[i] / (v[i] - v[j])) if v[i] != v[j] else float(t[i])


def _by_strokes(r, k, t, v, h):
    """The noise sd [N] of r (samples k) from each half stroke against the mean of the
    same direction's strokes a cycle before and after, at the same share of the stroke's
    time (linear between samples): a change slower than a cycle cancels to second order,
    whatever the motion's speed does from cycle to cycle, and noise of any colour shorter
    than a cycle keeps its variance. The interpolation's own averaging is allowed for with
    the noise's correlation from one sample to the next. None: fewer than three strokes a
    way."""
    num, weights, D = 0.0, [], []
    strokes = _strokes(t, v, h)
    for way in (-1.0, 1.0):
        ss = [s for s in strokes if s[4] == way]
        for a, b, c in zip(ss, ss[1:], ss[2:]):
            before, after = b[2] - a[2], c[2] - b[2]
            if abs(after - before) > STROKE_SPACING * min(before, after):
                continue
            ph = [(t[s[0]:s[1]] - s[2]) / (s[3] - s[2]) for s in (a, b, c)]
            ok = k[b[0]:b[1]] & (ph[1] >= max(ph[0][0], ph[2][0])) & (ph[1] <= min(ph[0][-1], ph[2][-1]))
            if np.count_nonzero(ok) < 4:
                continue
            p = ph[1][ok]
            ra, wa = _at(ph[0], r[a[0]:a[1]], p)
            rc, wc = _at(ph[2], r[c[0]:c[1]], p)
            D.append(r[b[0]:b[1]][ok] - 0.5 * (ra + rc))
            weights.append((wa, wc))
    if not D:
        return None
    # the noise's correlation between neighbouring samples, read off the differences
    # themselves (each a sum of independent cycles' noise with that correlation)
    rho = float(np.clip(np.mean([np.corrcoef(x[:-1], x[1:])[0, 1] for x in D if len(x) > 8] or [0.0]), 0, 1))
    var = 0.0
    for x, (wa, wc) in zip(D, weights):
        num += float(np.sum(x ** 2))
        var += float(np.sum(1 + 0.25 * (wa[0] + wa[1] + 2 * rho * wa[2] + wc[0] + wc[1] + 2 * rho * wc[2])))
    return float(np.sqrt(num / var))


def _at(p0, y, p):
    """(y at the points p of its own phases p0, linearly; its two weights' squares and
    product): what interpolating adds up of the noise."""
    m = np.clip(np.searchsorted(p0, p), 1, len(p0) - 1)
    w = np.clip((p - p0[m - 1]) / np.maximum(p0[m] - p0[m - 1], 1e-30), 0, 1)
    return (1 - w) * y[m - 1] + w * y[m], ((1 - w) ** 2, w ** 2, w * (1 - w))
