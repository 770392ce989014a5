"""The block bootstrap's resamples, drawn once and shared: every candidate of a diagnosis
is judged on the same held-out blocks, so the same resamples serve them all, each
resample as the count of every block in it (a mean over a resample is then one product).
Chunk i of the resamples over n blocks comes from the seed, n and i alone, whatever was
asked before it."""
from __future__ import annotations

import numpy as np

CHUNK = 2000  # resamples drawn at a time (the p-value stops after one when p is surely large)
KEEP_BYTES = 256 * 2 ** 20  # resamples kept for reuse at most; beyond, drawn again when asked


class Resamples:
    def __init__(self, seed):
        self.seed = seed
        self.kept = {}
        self.bytes = 0

    def chunk(self, n, i):
        """(CHUNK, n) counts: how often each of n blocks is drawn in each resample."""
        got = self.kept.get((n, i))
        if got is None:
            idx = np.random.default_rng([*np.atleast_1d(self.seed), n, i]).integers(0, n, (CHUNK, n))
            got = np.bincount((idx + n * np.arange(CHUNK)[:, None]).ravel(), minlength=CHUNK * n)
            got = got.reshape(CHUNK, n).astype(float)
            if self.bytes + got.nbytes <= KEEP_BYTES:
                self.kept[(n, i)] = got
                self.bytes += got.nbytes
        return got

    def means(self, x, i):
        """The mean of x over each resample of chunk i."""
        return self.chunk(len(x), i) @ x / len(x)
