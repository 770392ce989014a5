"""The force noise a diagnosis measures its gains against: what differs from cycle to cycle at
the same phase, and where the estimate came from (N)."""
from __future__ import annotations

import numpy as np

from models.diagnose.data import Data

NOISE_HARMONICS = 60  # at most, and at most a third of a cycle's samples


def noise_sd(r, d: Data, k):
    """Force noise [N] in the residual r over the samples k: what differs from cycle to
    cycle at the same phase. Per sine segment whose cycle is a whole number of samples, the
    residual at each phase is fitted with a straight line over the cycles (a slow change,
    warm-up, is not noise) and what is left, with its degrees of freedom, is noise of any
    colour shorter than a cycle (_by_phase); otherwise the residual is fitted with the
    motion's harmonics (_by_harmonics). The median over segments keeps one badly fitted
    segment from setting it. Sample-to-sample differences (the fallback for motion that
    does not repeat) see only the white part: first-order noise with a pole at 0.95 per
    sample reads as a third of its size, and every structured misfit above that third was
    then announced as physics; harmonics up to 60 Hz on a 1 Hz segment take up that
    noise's low frequencies and read it 16 % small."""
    same = (np.diff(d.cycle) == 0) & k[1:] & k[:-1]
    diff = float(np.median(np.abs(np.diff(r)[same])) / 0.6745 / np.sqrt(2))
    if not d.periodic:
        return diff
    out = []
    for s, (_, f) in enumerate(d.segments):
        j = np.nonzero(d.segment == s)[0]
        if np.count_nonzero(k[j]) < 64:  # (a time split judges the last segments only)
            continue
        h = float(np.median(d.h[j]))
        got = _by_phase(r[j], k[j], d.t[j], h, f)
        got = _by_harmonics(r[j][k[j]], d.t[j][k[j]], h, f) if got is None else got
        if got is not None:
            out.append(got)
    return float(np.median(out)) if out else diff


def noise_from(d: Data) -> str:
    """Where noise_sd's estimate came from, in words, with the source's smoothing if any."""
    how = ("what differs from cycle to cycle at the same phase" if d.periodic else
           "sample-to-sample differences (the motion does not repeat: only the noise's white part)")
    if any(f.kind == "smoothed" for f in d.flags):
        how += "; the force was smoothed by its source, so this is the filter's noise, not the load cell's"
    return how


def _by_phase(r, k, t, h, f):
    """The noise sd [N] of r from its cycle-to-cycle variation at each phase (samples k),
    less a straight line over the cycles; None unless a cycle is a whole number of samples
    and there are at least 4 cycles."""
    n = 1.0 / (f * h)
    N = int(round(n))
    if abs(n - N) > 1e-6 * n or N < 4:
        return None
    i = np.round((t - t[0]) / h).astype(int)
    Q = int(i.max() // N + 1)
    if Q < 4:
        return None
    y, w = np.zeros((Q, N)), np.zeros((Q, N))
    y[i // N, i % N], w[i // N, i % N] = r, k
    q = np.arange(Q, dtype=float)[:, None]
    cnt = w.sum(axis=0)
    ok = cnt >= 4
    if not ok.any():
        return None
    mq, my = (w * q).sum(axis=0) / np.maximum(cnt, 1), (w * y).sum(axis=0) / np.maximum(cnt, 1)
    Sqq = (w * (q - mq) ** 2).sum(axis=0)
    Sqy = (w * (q - mq) * (y - my)).sum(axis=0)
    Syy = (w * (y - my) ** 2).sum(axis=0)
    ssr = Syy - Sqy ** 2 / np.maximum(Sqq, 1e-30)
    return float(np.sqrt(ssr[ok].sum() / (cnt[ok] - 2).sum()))


def _by_harmonics(r, t, h, f):
    """The noise sd [N] of r less the motion's harmonics (up to NOISE_HARMONICS, a third
    of a cycle's samples at most), each with an amplitude that may change linearly over the
    segment, and a quadratic trend; None when too few samples."""
    n = len(r)
    K = min(NOISE_HARMONICS, int(1.0 / (3 * f * h)))
    if K < 2:
        return None
    tau = t - t.mean()
    u = tau / max(np.ptp(tau), 1e-9)
    cols = [np.ones(n), u, u * u]
    for m in range(1, K + 1):
        c, sn = np.cos(2 * np.pi * m * f * tau), np.sin(2 * np.pi * m * f * tau)
        cols += [c, sn, u * c, u * sn]
    A = np.column_stack(cols)
    if n < 2 * A.shape[1]:
        return None
    e = r - A @ np.linalg.lstsq(A, r, rcond=None)[0]
    return float(np.sqrt(np.sum(e ** 2) / (n - A.shape[1])))
