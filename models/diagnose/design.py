"""The next test (issue 31): which sine segment would best tell apart the explanations a
diagnosis could not, per second of rig time.

Rivals come from the diagnosis itself, among what a motion can tell apart (not an effect
in time, temperature or an aux channel, which a sine holds constant):
  - an accepted effect against the runner-up of its round, where that runner-up was worth
    having too (RELEVANCE noise variances): the residual had two readings; and against
    each of its rivals (the cell's timing at one frequency among them);
  - the model as accepted against it with a candidate of the last round that was worth
    having but not significant, or hinted at (p under HINT_P): an effect under the noise.

For each rival pair and each feasible sine (amplitude, frequency: within the cell's stroke,
velocity and frequency limits, the force of the fitted model within its force limit) both
models predict the force along the motion; the expected log-likelihood ratio between them
is sum(dF^2) / (2 sigma^2) over the samples (dF less its mean, which the baseline's gas
level absorbs). A proposal is the sine with the largest ratio per second of rig time for
each rival, if over its own duration it would be decisive (DECISIVE), and proposals are
taken best first until the budget is spent.

The proven envelope: sines outside the amplitudes and peak speeds the diagnosis has been
proven clean on (the prove plan's) are not proposed. Below it the baseline's own friction reversal (sgn(v) softened
over spec.V_EPS, the sampled reversal) leaves a residual on a null that the catalogue
reads as physics: on the plain cell with nothing hidden, the prove plan followed by 0.5 mm
at 0.2 Hz left 19 noise variances at the reversals (pre-sliding, refused as unresolved),
and followed by 1 mm at 4 Hz named free play (2.4 noise variances). The design seeks where
two models differ most, which is where the baseline is weakest: without the envelope it
chased that residual instead of the physics. Above it alike: with 20 mm strokes allowed,
a null named stroke damping.

A smooth basis (a term outside the catalogue, position friction) keeps the knots of the
recording it was fitted on (terms.cached): over the recorded stroke it predicts as fitted,
beyond it it holds its end values. The rival's parameters are the final model's with the
rival's own from its round: a design, not a refit.
SI units: m, m/s, Hz, s, N.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.diagnose import RELEVANCE, resolved  # a rival must have been worth having, as in acceptance
from models.diagnose.candidates import EFFECTS, Model
from models.diagnose.data import Data
from models.diagnose.result import Diagnosis
from models.diagnose.spec import ActsOn, Variable

HINT_P = 0.1  # or a p-value under this: an effect the recording hints at without showing
MAX_HINTS = 3  # hinted effects designed for, largest gain first (many p-values sit at the
# bootstrap's floor: ranked by p, the ties fell to whichever came first)
DECISIVE = 10.0  # expected log-likelihood ratio a proposal must reach over its own duration
HELD = {"temperature", "aux"}  # what a sine holds constant: an effect in them cannot be told apart by motion
AMPLITUDES_M = (0.0005, 0.001, 0.002, 0.005, 0.01, 0.02)
FREQUENCIES_HZ = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 4.0, 8.0, 12.0, 16.0, 25.0)
RATE_HZ = 1000.0
SETTLE_CYCLES = 1  # cycles run before the ones that count (the recorder drops them)
RAMP_CYCLES = 1  # cycles over which the amplitude grows in, and as many to fade out
MIN_CYCLES, MIN_S = 5, 2.0  # at least this many counted cycles, and at least this long


@dataclass(frozen=True)
class Limits:
    """What the cell may do: stroke [m from full extension], velocity [m/s], frequency
    [Hz] (inf: none) and force [N]; and the amplitudes [m] and peak speeds [m/s] the
    diagnosis is proven clean on nulls within (the proven envelope: see the module)."""
    x_min: float
    x_max: float
    velocity_max: float
    force_max: float
    frequency_max: float = math.inf
    amplitude_min: float = 0.0
    velocity_min: float = 0.0
    amplitude_max: float = math.inf
    velocity_proven: float = math.inf  # the fastest peak speed of the proven plan


@dataclass(frozen=True)
class Sine:
    amplitude_m: float
    frequency_hz: float
    offset_m: float  # centre, m from full extension

    @property
    def cycles(self):
        return max(MIN_CYCLES, math.ceil(MIN_S * self.frequency_hz)) + SETTLE_CYCLES

    @property
    def duration_s(self):
        return self.cycles / self.frequency_hz

    @property
    def rig_s(self):
        """Rig time, the ramps in and out included [s]."""
        return self.duration_s + 2 * RAMP_CYCLES / self.frequency_hz


@dataclass(frozen=True)
class Rival:
    chosen: tuple  # effects of the model as accepted
    other: tuple  # effects of the explanation it competes with
    values: dict  # parameters of `other` (the final model's, the rival's own from its round)
    said: str  # why they compete, in words


@dataclass(frozen=True)
class Proposal:
    sine: Sine
    rival: Rival
    difference_rms_n: float  # the two predictions' difference along the sine, less its mean
    ratio: float  # that over the force noise
    score: float  # expected log-likelihood ratio per second of rig time
    why: str


def _designable(e):
    """Can a motion tell it apart? Not an effect in temperature or an aux channel (held),
    nor a force in time itself (a drift, a tone); a time shift of the motion (a lag) it can."""
    spec = EFFECTS[e.split(":")[0]]
    return not HELD & set(spec.depends_on) and (Variable.TIME not in spec.depends_on or spec.acts_on == ActsOn.MOTION)


def rivals(diag: Diagnosis) -> list[Rival]:
    """The explanations the diagnosis could not tell apart (see the module's docstring);
    only those a motion can tell apart (not one in time, temperature or an aux channel)."""
    accepted = list(diag.accepted)
    fitted = tuple(diag.effects())  # with the cell's timing, which every model carries
    cell = fitted[:len(fitted) - len(accepted)]
    final = diag.final.parameters
    out = []
    by_round = {}
    for c in diag.candidates:
        by_round.setdefault(c.round, []).append(c)
    for k, e in enumerate(accepted):
        others = [c for c in by_round.get(k + 1, []) if c.effect != e and c.effect not in accepted
                  and c.relevance >= RELEVANCE and _designable(c.effect)]
        if not others or not _designable(e):
            continue
        # the runner-up, and the step's own rivals beside it (the cell's timing at one
        # frequency: referees.timing_rival), each a pair a motion may part
        said = {r for r, _, _ in next((st.rivals for st in diag.steps if st.effect == e), [])}
        top = max(others, key=lambda c: c.relevance)
        own = {p.name for p in EFFECTS[e.split(":")[0]].params(diag.data, e)}
        chosen_gain = next(x.relevance for x in by_round[k + 1] if x.effect == e)
        for c in [top] + [c for c in others if c is not top and c.effect in said]:
            values = {**{n: v for n, v in final.items() if n not in own}, **c.parameters}
            out.append(Rival(fitted, cell + tuple(a if a != e else c.effect for a in accepted), values,
                             f"{_say(e)} was taken over {_say(c.effect)}, {chosen_gain:.2f} to {c.relevance:.2f} "
                             f"noise variances"))
    last = by_round.get(len(accepted) + 1, [])
    hints = [c for c in sorted(last, key=lambda c: -c.relevance)
             if c.effect not in accepted and (c.relevance >= RELEVANCE or c.p_value < HINT_P)
             and _designable(c.effect) and resolved(diag.data, c.effect, c.parameters, c.ci)]
    for c in hints[:MAX_HINTS]:
        out.append(Rival(fitted, fitted + (c.effect,), {**final, **c.parameters},
                         f"{_say(c.effect)} is hinted at but not shown (gain {c.relevance:.2f} noise "
                         f"variances, p = {c.p_value:.2g})"))
    return out


def _say(e):
    return e.replace("_", " ")


def motion(sine: Sine, d: Data) -> Data:
    """The sine as Data the diagnosis's models evaluate (force unknown: zeros); the
    recording's temperature and aux channels held at their means."""
    n = int(round(sine.duration_s * RATE_HZ))
    t = (np.arange(n) + 0.5) / RATE_HZ  # no sample on a reversal, where a friction's sign is a coin toss
    w = 2 * np.pi * sine.frequency_hz
    x = sine.offset_m + sine.amplitude_m * np.sin(w * t)
    v = sine.amplitude_m * w * np.cos(w * t)
    a = -sine.amplitude_m * w * w * np.sin(w * t)
    cycle = np.floor(t * sine.frequency_hz).astype(int)
    T = None if d.T is None else np.full(n, float(np.mean(d.T)))
    return Data(t, x, v, a, np.zeros(n), cycle, np.zeros(n, int), np.full(n, 1.0 / RATE_HZ),
                [("next", sine.frequency_hz)], T, {k: np.full(n, float(np.mean(a_))) for k, a_ in d.aux.items()})


def feasible(limits: Limits, d: Data) -> list[Sine]:
    """The sines the cell can run about the recording's mean position, within the proven
    envelope (Limits.amplitude_min..amplitude_max, velocity_min..velocity_proven)."""
    centre = float(np.mean(d.x))
    out = []
    for A in AMPLITUDES_M:
        if (centre - A < limits.x_min or centre + A > limits.x_max
                or not limits.amplitude_min <= A <= limits.amplitude_max):
            continue
        for f in FREQUENCIES_HZ:
            v = 2 * np.pi * f * A
            if f <= limits.frequency_max and limits.velocity_min <= v <= min(limits.velocity_max, limits.velocity_proven):
                out.append(Sine(A, f, centre))
    return out


def key(rival: Rival) -> frozenset:
    """What a rival is about: the effects the two explanations do not share."""
    return frozenset(set(rival.chosen) ^ set(rival.other))


def propose(diag: Diagnosis, limits: Limits, budget_s: float = 120.0, tried: list[tuple] | tuple = frozenset()
           ) -> list[Proposal]:
    """The next segments, best first, whose rig time adds up to at most budget_s. tried:
    (key(rival), Sine) pairs already run: a sine expected to decide a rival that did not
    is not asked for again for it (on nulls, 10 mm at 12 Hz for the cell's timing against
    fluid inertia, round after round)."""
    d = diag.data
    sigma = diag.noise_sd
    best = []
    ma = Model(d, diag.effects())  # every rival competes with the model as accepted
    sines = feasible(limits, d)
    motions = {s: motion(s, d) for s in sines}
    chosen = {s: ma.force(motions[s], diag.final.parameters) for s in sines}
    sines = [s for s in sines if np.max(np.abs(chosen[s])) <= limits.force_max]
    for rv in rivals(diag):
        mb = Model(d, list(rv.other))
        start = {p.name: p.x0 for p in mb.params}  # what no fit gave it (the alignment an accepted lag took over)
        found = None
        for s in (s for s in sines if s.rig_s <= budget_s and (key(rv), s) not in tried):
            m = motions[s]
            fa = chosen[s]
            counted = m.cycle >= SETTLE_CYCLES
            diff = (fa - mb.force(m, {**start, **rv.values}))[counted]
            diff = diff - diff.mean()
            score = float(np.sum(diff ** 2) / (2 * sigma ** 2) / s.rig_s)
            if found is None or score > found.score:
                rms = float(np.sqrt(np.mean(diff ** 2)))
                found = Proposal(s, rv, rms, rms / sigma, score, "")
        if found is not None and found.score * found.sine.rig_s >= DECISIVE:
            best.append(found)
    out, spent = [], 0.0
    for p in sorted(best, key=lambda p: -p.score):
        if spent + p.sine.rig_s <= budget_s and p.sine not in [q.sine for q in out]:
            spent += p.sine.rig_s
            out.append(Proposal(p.sine, p.rival, p.difference_rms_n, p.ratio, p.score, _why(p)))
    return out


def _why(p: Proposal) -> str:
    s = p.sine
    return (f"{1e3 * s.amplitude_m:g} mm at {s.frequency_hz:g} Hz for {s.rig_s:.0f} s: {p.rival.said}; "
            f"there the two differ by {p.difference_rms_n:.2g} N RMS, {p.ratio:.1f}x the noise")
