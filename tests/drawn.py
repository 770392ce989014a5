"""Sine programs drawn at random, the property test's (tests/test_segmentation.py, through
hypothesis, 25 a run) and the grid's (tests/segmentation_grid.py, thousands from numpy's
generator): one description of what is drawn, two ways of drawing it."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from records import segmentation
from tests import programs as P

STEP = 0.1  # a sine stepped straight into the next differs from it by this share in amplitude or frequency
RATE_HZ = (300.0, 10000.0)  # drawn log-uniform between these


def program(pick) -> P.Program:
    """Two to four sines of the issue's range (0.5-16 Hz, 1.6-12.7 mm, under 0.8 m/s), each
    ramped in and out, stepped straight into the next, or dwelling long, with holds about.
    pick: real(lo, hi), whole(lo, hi) (both ends included), one(options), and keep(ok),
    which says whether a draw may stand (hypothesis rejects the example instead)."""
    b = P.Builder("drawn").hold(pick.real(0.3, 1.5))
    before = None  # the sine this one steps straight on from
    for _ in range(pick.whole(2, 4)):
        while True:
            A = pick.real(0.0016, 0.0127)
            f = pick.real(0.5, min(16.0, 0.8 / (2 * math.pi * A)))
            # a program steps to another test: one sine stepped into its like is one test
            if pick.keep(before is None or abs(A / before[0] - 1) > STEP or abs(f / before[1] - 1) > STEP):
                break
        cycles = pick.whole(2, 5)
        style = pick.one(("ramped", "stepped", "dwell"))
        b.sine(A, f, cycles, ramp_cycles=0 if style == "stepped" else 1)
        before = (A, f) if style == "stepped" else None
        if style != "stepped":
            b.hold(2.0 if style == "dwell" else 0.2)
    return b.hold(pick.real(0.3, 1.5)).build()


@dataclass
class Random:
    """Picks from numpy's generator."""
    rng: np.random.Generator

    def real(self, lo, hi):
        return float(self.rng.uniform(lo, hi))

    def whole(self, lo, hi):
        return int(self.rng.integers(lo, hi + 1))

    def one(self, options):
        return options[int(self.rng.integers(len(options)))]

    def keep(self, ok):
        return ok


def cut_wrong(seed: int) -> dict | None:
    """Program `seed` drawn with its rate and noise, sampled and cut: None when every steady
    sine is found whole, none invented and nothing unread, else what went wrong."""
    pick = Random(np.random.default_rng(seed))
    prog = program(pick)
    rate = math.exp(pick.real(*map(math.log, RATE_HZ)))
    noise = pick.one(sorted(P.NOISES))
    t, x = P.sample(prog, rate, *P.NOISES[noise], seed=pick.whole(0, 2 ** 16))
    segs = segmentation.find(t, x)
    sc = P.score(prog, [(s.kind, s.t0, s.t1, s.params) for s in segs], t[-1])
    if P.cut_right(sc, rate):
        return None
    return {"seed": seed, "rate_hz": round(rate), "noise": noise, "found": f"{sc.found}/{sc.sines}",
            "invented": sc.invented, "missed": [f"{p.freq:.3g} Hz at {p.t0:.2f} s: {why}" for p, why in sc.missed]}
