"""The paired block bootstrap every decision of the diagnosis is taken on (issue 44): the
held-out blocks' errors resampled with replacement, on resamples kept and shared, so two
candidates' p-values differ by their data, not by their draws."""
from __future__ import annotations

import threading

import numpy as np

ALPHA = 0.01  # the bar of every paired test
BOOT = 2000
SURE_HITS = 50
MORE = 4  # the most resamples a p-value at the bar draws, in multiples of its usual number


def block_sse(r: np.ndarray, block: np.ndarray, ids: np.ndarray) -> np.ndarray:
    return np.bincount(block, weights=r ** 2, minlength=ids.max() + 1)[ids]


# the resamples kept in memory, by (blocks, seed, chunk): every test of a diagnosis draws
# the same ones, so a round's dozen candidates cost one draw, not a dozen
_KEPT, _KEPT_BYTES, _kept_lock = {}, 1e9, threading.Lock()


def resamples(n: int, seed: int, i: int) -> np.ndarray:
    """Chunk i of the block bootstrap's resamples of n blocks: BOOT rows, each how often
    each block is drawn (blocks drawn with replacement), from its own seed, so a test gives
    the same p whether the chunk was kept or is drawn again."""
    key = (n, seed, i)
    w = _KEPT.get(key)
    if w is None:
        idx = np.random.default_rng([seed, n, i]).integers(0, n, (BOOT, n)) + n * np.arange(BOOT)[:, None]
        w = np.bincount(idx.ravel(), minlength=BOOT * n).reshape(BOOT, n).astype(np.float32)
        with _kept_lock:
            kept = sum(v.nbytes for v in _KEPT.values())
            # room made from other recordings' chunks (another n), then from later chunks
            # than this one: every test starts at chunk 0 (and the judgements of
            # stability.py draw on the first few of each seed), so a full store keeps the
            # first chunks and draws the rare late ones (a p-value at the bar) again.
            # Evicting the oldest instead evicted chunk 0 first, and every later test then
            # missed: 297 draws of 971 on the crank
            later = sorted((k for k in _KEPT if k[0] == key[0] and k[2] > key[2]), key=lambda k: -k[2])
            for k in [k for k in _KEPT if k[0] != key[0]] + later:
                if kept + w.nbytes <= _KEPT_BYTES:
                    break
                kept -= _KEPT.pop(k).nbytes
            if kept + w.nbytes <= _KEPT_BYTES:
                _KEPT[key] = w
    return w


def _resamples(alpha: float) -> int:
    """The resamples p_value draws at least unless it stops early: BOOT, and 20 / alpha."""
    return max(BOOT, int(np.ceil(20 / alpha)))


def usual_chunks(alpha: float = ALPHA) -> int:
    """The chunks of resamples p_value draws unless it stops early."""
    return int(np.ceil(_resamples(alpha) / BOOT))


def p_value(d_c: np.ndarray, seed: int, alpha: float = ALPHA) -> float:
    """One-sided bootstrap p-value of mean(d_c) > 0 over blocks d_c, with enough resamples
    (at least BOOT, and 20 / alpha) that the smallest p it can give is well under alpha.
    It stops early once p is surely above alpha (SURE_HITS hits, and alpha under p's
    lower bound at 3.3 sd), as for most candidates tried: p is then known to about 15 %.
    Where p is still within 3.3 sd of alpha it draws on, up to MORE times as many
    resamples: a verdict at the bar is the data's, not the draw's. Every test with the
    same seed and number of blocks resamples the same blocks (common random numbers: two
    candidates' p differ by their data, not by their draws)."""
    n = len(d_c)
    if n < 3:
        return 1.0
    m = d_c.mean()
    x = (d_c / n).astype(np.float32)
    total = _resamples(alpha)
    hits = done = i = 0
    while done < MORE * total:
        boot = resamples(n, seed, i) @ x
        hits, done, i = hits + int(np.sum(boot - m >= m)), done + BOOT, i + 1
        if hits >= SURE_HITS and hits - 3.3 * np.sqrt(hits) > alpha * done:
            break
        if done >= total and abs(hits - alpha * done) >= 3.3 * np.sqrt(alpha * done):
            break
    return float((hits + 1) / (done + 1))
