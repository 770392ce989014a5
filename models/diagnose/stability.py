"""How firmly each decision of a diagnosis holds (issue 71): every test on the held-out
blocks is judged again with the blocks' boundaries shifted and the bootstrap drawn anew, and
a decision is taken by the share of those judgements in which it holds, not by one draw on
one partition. A fixed threshold on a statistic the fit gives (a gain in noise variances, a
share of the error) is judged with a band about it. So a verdict near its threshold is said
as such ("at the edge", with its share), and one far from it does not flip with the last bits
of the arithmetic: the judgements are the same on every machine, only their inputs move, by
far less than a shifted block moves them.

Stability selection (Meinshausen and Buehlmann 2010) names what holds in most perturbed
repeats; ensemble SINDy reports the same share as an inclusion probability. Here the repeats
are of the held-out judgement, which costs bootstrap draws only; `dyno diagnose --repeats N`
repeats the whole diagnosis on perturbed copies of the recording as well (costly)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from models.diagnose.bootstrap import BOOT, block_sse, p_value, resamples, usual_chunks
from models.diagnose.data import Data

SHIFTS = 5  # block partitions: the quarter-cycle blocks shifted by 0, 1/5, ... 4/5 of a block
DRAWS = 3  # bootstrap draws of each partition (seeds): 15 judgements, so that no share is one half
HELD = 2 / 3  # a decision holds when it holds in at least this share of its judgements (a clear majority) ...
EDGE = 1.0 - HELD  # ... is at the edge above this share, and does not hold at or below it
BAND = 1.25  # a statistic within this factor of its fixed threshold is at the edge (half its judgements)


@dataclass(frozen=True)
class Variant:
    """One judgement's partition of the held-out samples into blocks, and its draw."""
    block: np.ndarray  # block number of each sample
    ids: np.ndarray  # the blocks holding judged samples
    seed: int


@dataclass
class Judge:
    """The held-out samples and every judgement of them; the first is the diagnosis's own."""
    judged: np.ndarray  # bool per sample
    variants: list

    @property
    def main(self) -> Variant:
        return self.variants[0]

    def sse(self, r, v: Variant) -> np.ndarray:
        """The squared residual r [N] per judged block of v."""
        return block_sse(np.where(self.judged, r, 0.0), v.block, v.ids)

    def log_ratio(self, r_new, r_old, v: Variant) -> np.ndarray:
        """Per block of v, log(SSE of r_old / SSE of r_new): above zero where r_new is better."""
        return np.log(np.maximum(self.sse(r_old, v), 1e-30) / np.maximum(self.sse(r_new, v), 1e-30))

    def p(self, r_new, r_old, alpha, v: Variant = None) -> float:
        """The paired bootstrap p-value that r_new is better than r_old on v's blocks (the
        diagnosis's own when v is None)."""
        v = v or self.main
        return p_value(self.log_ratio(r_new, r_old, v), v.seed, alpha)

    def vote(self, r_new, r_old, alpha, v: Variant) -> bool:
        """Is r_new significantly better on v's blocks: the paired block bootstrap's p below
        alpha, from a fixed number of resamples (the least in which it can fall below alpha
        three times over, in whole chunks). A p-value near the bar is what the judgements
        measure; drawing on until the draw is sure (p_value) cost as much as the fits."""
        x = self.log_ratio(r_new, r_old, v)
        n = len(x)
        if n < 3:
            return False
        m, y = x.mean(), (x / n).astype(np.float32)
        chunks = _chunks(alpha)
        hits = sum(int(np.sum(resamples(n, v.seed, i) @ y - m >= m)) for i in range(chunks))
        return (hits + 1) / (chunks * BOOT + 1) < alpha

    def drawn(self, alpha) -> None:
        """Every judgement's resamples at the bar alpha drawn (bootstrap.resamples keeps
        them), so that forked fitting processes share them instead of each drawing its own."""
        for v in self.variants:
            for i in range(usual_chunks(alpha) if v is self.main else _chunks(alpha)):  # p's, and the votes'
                resamples(len(v.ids), v.seed, i)

    def votes(self, r_new, r_old, alpha) -> np.ndarray:
        """1.0 in each judgement in which r_new is significantly better, else 0."""
        return np.array([float(self.vote(r_new, r_old, alpha, v)) for v in self.variants])

    def share(self, r_new, r_old, alpha) -> float:
        """The share of the judgements in which r_new is significantly better."""
        return float(np.mean(self.votes(r_new, r_old, alpha)))


def _chunks(alpha: float) -> int:
    """Chunks of resamples a judgement draws: the least in which p can fall below alpha three
    times over."""
    return int(np.ceil(3.0 / alpha / BOOT))


def judge(d: Data, judged: np.ndarray, seed: int, blocks: Callable[..., np.ndarray]) -> Judge:
    """The judgements of a diagnosis's held-out samples: blocks(d, offset) gives each
    sample's block with the partition shifted by offset [share of a block]."""
    out = []
    for k in range(SHIFTS):
        block = blocks(d, offset=k / SHIFTS)
        # every block of the judged cycles, however cut: as many in each judgement, which then
        # all draw on the same kept resamples (bootstrap.resamples)
        ids = np.unique(block[np.isin(d.cycle, np.unique(d.cycle[judged]))])
        out += [Variant(block, ids, seed + j) for j in range(DRAWS)]
    return Judge(judged, out)


def against(x: float, threshold: float, band: float = BAND) -> float:
    """A statistic the fit gives against a fixed threshold, as a share of judgements: 1 well
    above it, 0 well below it, 0.5 within the band about it (at the edge)."""
    if not np.isfinite(x):
        return 0.0
    if threshold <= 0:
        return 1.0 if x >= threshold else 0.0
    return 1.0 if x >= threshold * band else 0.0 if x < threshold / band else 0.5


def holds(share: float) -> bool:
    return share >= HELD


def at_edge(share: float) -> bool:
    return EDGE < share < HELD


def of(share: float, n: int = SHIFTS * DRAWS) -> str:
    """A share in words: "53 % of 15 judgements" (a fixed bar's band counts half a judgement)."""
    return f"{100 * share:.0f} % of {n} judgements"
