"""Missing-physics diagnosis: fit the baseline (with the channels' alignment within half a
sample, candidates.WITH_BASELINE), locate where its residual lives, try each
catalogue effect (models/diagnose/candidates.py) with the baseline refitted, judge it only on
held-out cycles, accept the best one whose improvement is significant, repeat. Two-fold
cross-fitting (even cycles fit, odd judged, and back) judges every cycle once; a time
split (holdout_masks) fits the past, chooses on the next stretch and reports on the last.
An accepted effect whose parameters trade against an earlier one's (trades), or whose gain a
change in an earlier one's form also brings (form_share), is marked as possibly compensating
that effect's form.

Significance: the held-out improvement per block, log(SSE_baseline,b / SSE_candidate,b), so
that every block counts alike whatever its force level and a block made worse weighs as
much as one made better by the same factor, is tested by
a bootstrap over blocks (quarter cycles) against zero, one-sided,
Bonferroni-corrected for the candidates tried in that round (ALPHA over their number).
An effect must also be worth having: its held-out mean-square improvement at least
RELEVANCE times the force noise variance (the noise from the residual's sample-to-sample
differences), so a structured misfit of the baseline a little smaller than the noise is
not announced as physics; and at least SHARE of the held-out mean-square error it starts
from, so that far above the noise an effect must still matter.
"""
from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from models.diagnose import screen, stability
from models.diagnose.bootstrap import ALPHA, p_value
from models.diagnose.candidates import EFFECTS, GAMMA, WITH_BASELINE, Minimal, Model
from models.diagnose.compensation import FORM_SHARE, changes, form_share, trades
from models.diagnose.data import Data, DiagnoseError, prepare
from models.diagnose.fitting import cross_fit, linear_fit, open_params, pooled
from models.diagnose.from_model import FromModel
from models.diagnose.from_spencer import NAME as SPENCER
from models.diagnose.from_spencer import FromSpencer
from models.diagnose.measured import friction_outside_physics, undetermined
from models.diagnose.noise import noise_from, noise_sd
from models.diagnose.referees import MECHANISMS, RELEVANCE, bar, chosen, rivals_of, stood_in, term
from models.diagnose.result import Baseline, Candidate, CellFit, Diagnosis, Final, LeftOver, Step, Tried
from models.diagnose.spec import Needs
from models.diagnose.stability import Judge
from models.diagnose.stages import Clock
from models.diagnose.terms import frequencies, tone
from models.diagnose.where import describe, locate
from models.statistics import nrmse
from records.data import Channels, differing_repeats
from records.events import Event
from records.source_filter import Smoothing
from workers import threads

__all__ = ["diagnose", "friction_outside_physics", "undetermined", "repeated", "form_share", "holdout_masks", "trades", "noise_sd", "locate", "DiagnoseError"]

MIN_TRAIN = 4  # cycles or blocks a time split fits on at least
REFIT_EFFORT = 4  # function evaluations per parameter when an accepted term is refitted with the rest
SHARE = 0.01
# practical size (docs/diagnosis.md, chosen on nulls and concealed effects of both
# generators): physics is named only when its held-out gain is at least NAMED_SHARE of the
# excess over the noise the damper's physics has to explain (_sized), and, as every
# accepted effect, at least RELEVANCE noise variances; a smaller significant gain stays in
# the model and is said as small, not named
NAMED_SHARE = 0.2


def blocks(d: Data, per_cycle: int = 4, offset: float = 0.0) -> np.ndarray:
    """Block number of each sample: each cycle cut into `per_cycle` equal parts (strokes
    and reversals apart), the units the bootstrap resamples; offset [share of a block]
    shifts the cuts (the cycle's end then closes its first block: stability.py)."""
    out = np.empty(len(d.cycle), int)
    starts = np.r_[0, np.nonzero(np.diff(d.cycle))[0] + 1, len(d.cycle)]
    for a, b in zip(starts[:-1], starts[1:]):
        part = np.floor(np.arange(b - a) * per_cycle / (b - a) + offset).astype(int) % per_cycle
        out[a:b] = d.cycle[a] * per_cycle + part
    return out


def available(d: Data, accepted: list[str]) -> tuple[list[str], list[str]]:
    out, skipped = [], []
    taken = {a.split(":")[0] for a in accepted}
    for name, e in EFFECTS.items():
        if e.needs in (Needs.REFEREE, Needs.BASELINE):
            continue
        if e.needs == Needs.TEMPERATURE and d.T is None:
            skipped.append(name)
        elif e.needs == Needs.FREQUENCIES:  # a function of frequency needs two of them
            if len(frequencies(d)) >= 2 and name not in accepted:
                out.append(name)
        elif e.needs == Needs.TONE:
            if d.tone_hz is not None and name not in accepted:
                out.append(name)
        elif e.needs == Needs.AUX_OR_NOT:  # one of its forms at most
            if name not in taken:
                out += [name] + [f"{name}:{n}" for n in d.aux]
        elif e.needs == Needs.AUX:
            out += [f"{name}:{n}" for n in d.aux if f"{name}:{n}" not in accepted]
            if not d.aux:
                skipped.append(name)
        elif name not in accepted:
            out.append(name)
    return out, skipped


def holdout_masks(d: Data, holdout: str | float = "interleaved"
                 ) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray, np.ndarray]:
    """(folds [(train, held out)], judged, reported): the samples each fold fits and
    predicts, those the candidates are judged on, those the held-out error is reported on.

    "interleaved": two folds, fitted on even cycles and judged on odd ones and the other way
    round, so every cycle is judged once by a fit that never saw it. A float F ("tail:F"):
    a time split, as published results on measured data use: fitted on the first 1 - 2F of
    the cycles, judged on the next F, reported on the last F, which no choice saw.
    Samples within a sample period of a velocity reversal are neither fitted nor judged: the
    friction's sign there is set by where the reversal falls between samples, which no
    model of the physics can know."""
    flip = np.zeros(len(d.v), bool)
    k = np.nonzero(np.diff(np.sign(d.v)) != 0)[0]
    flip[k] = flip[np.minimum(k + 1, len(flip) - 1)] = True
    if holdout == "interleaved":
        even, odd = (d.cycle % 2 == 0) & ~flip, (d.cycle % 2 == 1) & ~flip
        return [(even, odd), (odd, even)], even | odd, even | odd
    cycles = np.unique(d.cycle)  # numbered in time order
    n = max(int(np.ceil(float(holdout) * len(cycles))), 1)
    if len(cycles) < 2 * n + MIN_TRAIN:
        raise DiagnoseError(f"--holdout tail:{holdout:g}: {len(cycles)} cycles or blocks are too few to hold out "
                            f"2 x {n} and fit on at least {MIN_TRAIN}")
    train = np.isin(d.cycle, cycles[:-2 * n]) & ~flip
    judged = np.isin(d.cycle, cycles[-2 * n:-n]) & ~flip
    tail = np.isin(d.cycle, cycles[-n:]) & ~flip
    return [(train, judged | tail)], judged, tail


def scores(F: np.ndarray, r: np.ndarray, k: np.ndarray) -> dict[str, float]:
    """Held-out measures of a residual r [N] on samples k: NRMSE (of the force range), RMSE
    [N] and R^2."""
    e = r[k]
    sst = float(np.sum((F[k] - np.mean(F[k])) ** 2))
    return {"nrmse_heldout": nrmse(F[k] + e, F[k]), "rmse_heldout": float(np.sqrt(np.mean(e ** 2))),
            "r2_heldout": 1.0 - float(np.sum(e ** 2)) / max(sst, 1e-30)}


def diagnose(channels: Channels, events: list[Event], progress: Callable[[str], None] = lambda s: None,
             max_effects: int = 4, seed: int = 0, baseline: tuple | None = None, holdout: str | float = "interleaved",
             drives: list[str] | None = None, jobs: int = 1, smoothing: Smoothing | None = None,
             screening: bool = True) -> Diagnosis:
    """The diagnosis (see commands/diagnose.py for its JSON). baseline: None for `minimal`, or (name,
    damper model) to start from that model, refitted. holdout: "interleaved" or the tail's fraction
    (holdout_masks). drives: the aux channels that drive the damper (records.data.drives), the only ones
    an effect may be scaled by; None: all. jobs: processes fitting a round's candidates (threads.forked); 1:
    this one (a rig's). smoothing: the source's moving average every model goes through (source_filter).
    screening: False fits every candidate, none ruled out by its screen (screen.Sieve: the audit)."""
    clock = Clock(jobs)
    d = prepare(channels, events, drives, smoothing)
    folds, judged, shown = holdout_masks(d, holdout)
    base = _base(d, baseline, folds, progress)
    if holdout != "interleaved":
        d.fitted_until = float(np.max(d.t[folds[0][0]]))
    judge = stability.judge(d, judged, seed, blocks)
    cell = list(WITH_BASELINE)
    with clock.stage("baseline"):
        base_res, fold_vals, values = _fit_baseline(d, base, cell, folds, shown)
        r0 = base_res.residual
        # each fold's prediction [N] on every sample after each round: what an effect changed
        preds = [[Model(d, cell, base).force(d, v) for v in fold_vals]]
        sigma = noise_sd(d.F - preds[0][0], d, judged)  # one fold's model throughout: the folds' differ
        d.tone_hz = tone(d, r0, judged)
    progress(f"baseline: held-out error {100 * base_res.nrmse_heldout:.2f} % of the force range, "
             f"force noise {sigma:.2f} N")
    accepted, steps, candidates = [], [], []
    current, r_cur = fold_vals, r0
    _, not_assessed = available(d, accepted)
    last, cost = {}, {}  # each candidate as tried in the round before (its warm start), its time [s]
    for _ in range(max_effects):
        names, _ = available(d, accepted)
        alpha = bar(len(names))
        with clock.stage("candidates"):
            round_ = _round(d, base, names, cell + accepted, len(steps) + 1, folds, current, judge, r_cur, shown,
                            sigma, alpha, last, cost, progress, jobs, clock, screening)
        candidates += [x.candidate for x in round_]
        last = {x.candidate.effect: x for x in round_ if not x.candidate.screened}
        ok = [x for x in round_ if x.candidate.accept_share >= 0.5]  # accepted in most judgements
        if not ok:
            break
        # the effect carried may be one at the edge that the held-out blocks cannot tell from the best
        won = chosen(ok, [x for x in round_ if stability.EDGE < x.candidate.accept_share], judge, alpha, names)
        best, b_vals, b_folds, b_r = won.candidate, won.values, won.folds, won.residual
        with clock.stage("rivals"):
            rivals, rival_votes = rivals_of(d, best, b_r, round_, judge)
        with clock.stage("stand-ins"):
            refereed = stood_in(d, base, cell + accepted, best, b_folds, b_r, folds, judge, rival_votes)
        with clock.stage("refit"):
            b_vals, b_folds, b_r, shares, traded = _refit(d, base, cell, accepted, best.effect, b_vals, b_folds, b_r,
                                                          folds, judged, preds)
        form_of = [(e, sh) for e, sh in shares if sh >= FORM_SHARE]
        steps.append(Step(best.effect, scores(d.F, r_cur, shown)["nrmse_heldout"], best.nrmse_heldout,
                          best.parameters, best.ci, best.p_value, r_cur, b_r, traded, form_of,
                          # the earlier effects whose form this one may be compensating, in acceptance order
                          [e for e in accepted if e in dict(traded) or e in dict(form_of)], rivals=rivals,
                          stand_in=refereed.stand_in, referee=refereed.faced, relevance=best.relevance,
                          accept_votes=best.accept_votes, rival_votes=rival_votes, stand_in_votes=refereed.votes))
        accepted.append(best.effect)
        values, current, r_cur = b_vals, b_folds, b_r
        progress(f"accepted {best.effect}")
    with clock.stage("final"):
        accepted, values, current, r_cur, replaced = _replaced(d, base, cell, folds, judge, accepted, values,
                                                               current, r_cur, progress)
        held = judged | shown
        for st in steps:
            st.replaced_by = replaced.get(st.effect)
            if st.effect in accepted:
                for k, v in describe(d, st.effect, st.residual_after - st.residual_before, held).items():
                    setattr(st, k, v)
        _sized(steps, float(np.mean(r0[judged] ** 2)) - sigma ** 2, sigma)
        out = Diagnosis(d, holdout, held, shown, base_res, sigma, locate(d.take(held), r0[held], sigma),
                        locate(d.take(held), r_cur[held], sigma), candidates, accepted, steps, not_assessed,
                        left_over(r_cur, judge, sigma), _final(d, Model(d, cell + accepted, base), values, r_cur, shown),
                        noise_from(d), repeats=differing_repeats(channels, events), judge=judge)
    out.timing = clock.report()
    return out


def _base(d, baseline, folds, progress):
    """The baseline model: minimal (None), Spencer's MR model ((name, SPENCER)) or a damper model's."""
    if baseline is None:
        return Minimal(d)
    if baseline[1] == SPENCER:
        return FromSpencer(d, folds, progress)
    progress(f"simulating {baseline[0]} along the recorded motion")
    return FromModel(baseline[1], d, baseline[0])


def _refit(d, base, cell, accepted, effect, b_vals, b_folds, b_r, folds, judged, preds):
    """A round's winner refitted with everything where it was screened with the open terms
    held (from the screening's values, close to the optimum: a few evaluations per
    parameter); its predictions added to preds; with the earlier effects' form shares and
    trades (compensation.py): (values, per fold, residual, shares, trades)."""
    m_best = Model(d, cell + accepted + [effect], base)
    if open_params(d, accepted + [effect]):
        b_folds, f_sds, b_r = cross_fit(m_best, d, folds, b_folds, effort=REFIT_EFFORT)
        b_vals = pooled(b_folds, f_sds)[0]
    preds.append([m_best.force(d, v) for v in b_folds])
    shares = [(e, form_share(d, folds, judged, preds[-2], changes(preds, j + 1), changes(preds, len(preds) - 1)))
              for j, e in enumerate(accepted)]
    return b_vals, b_folds, b_r, shares, trades(m_best, d, folds[0][0], b_folds[0], accepted)


def _final(d, model, values, r, shown):
    return Final(**scores(d.F, r, shown), parameters=values, force=model.force(d, values))


def repeated(first: Diagnosis, channels: Channels, events: list[Event], n: int, **kw) -> dict:
    """`dyno diagnose --repeats N`: the diagnosis `first` and N - 1 more, each of a copy of
    the recording with its force rescaled by 1 + k 1e-9 (k = -1, 1, -2, 2, ...: a millionth of
    any load cell's resolution) and its own bootstrap draws (seed k): {"n": N, "named":
    {effect: share of the N in which it is named}, "at_edge": {...}} of every effect named
    or at the edge in any of them. Costs N diagnoses."""
    t, F = channels["force"]
    runs = [first]
    for k in range(1, n):
        scale = 1.0 + (-1) ** k * ((k + 1) // 2) * 1e-9
        runs.append(diagnose({**channels, "force": (t, F * scale)}, events, seed=k, **kw))
    effects = dict.fromkeys(e for r in runs for e in r.named() + r.at_edge())
    return {"n": n, "named": {e: sum(e in r.named() for r in runs) / n for e in effects},
            "at_edge": {e: sum(e in r.at_edge() for r in runs) / n for e in effects}}


def _fit_baseline(d, base, cell, folds, shown):
    """(Baseline, values per fold, pooled values) of the baseline with the cell's part: the
    channels' alignment is fitted with it, never a candidate, since every recording has one
    and as a candidate it took the first round of every null (docs/diagnosis.md)."""
    model = Model(d, cell, base=base)
    stopped = []
    fold_vals, sds, r0 = cross_fit(model, d, folds, [{}] * len(folds), restart=True, more=_starts(d, base),
                                   stopped=stopped)
    values, sd = pooled(fold_vals, sds)
    r_train = model.force(d, fold_vals[0]) - d.F
    fit0 = folds[0][0]
    res = Baseline(base.name, values, sd, nrmse(d.F[fit0] + r_train[fit0], d.F[fit0]), **scores(d.F, r0, shown),
                   residual=r0, model_gas_force=getattr(base, "Fg_m", None), cell=_cell_fits(d, cell, values, sd),
                   stopped=sum(stopped))
    return res, fold_vals, values


def _starts(d, base):
    """The minimal baseline's starts besides the data's, the lowest cost kept (cross_fit's
    more): valve curves that are lines, a seal that grips, and a gas spring that carries
    the loop's stiffness. From one start the trust region settled in whichever valley the
    last bits sent it to (a repeats file of five currents: costs 10 % apart on two
    machines); from these, in the same one. The stiff gas: on the UTFSM 2 mm 5 Hz 1 A file
    (an MR fluid's pre-yield stiffness) only one of six fits found the valley where the gas
    carries it (held-out error 4.0 % against 6.3 %), and with the force x (1 + 1e-9) none."""
    if not isinstance(base, Minimal):
        return []
    ps = {p.name: p for p in base.params(d)}
    x0, Fmax = {n: p.x0 for n, p in ps.items()}, max(np.percentile(np.abs(d.F), 99), 10.0)
    out = [{**x0, "c2_c": 0.0, "c2_r": 0.0}, {**x0, "F_c": 0.15 * Fmax}]
    k = _stiffness(d)
    if k > 0:  # eq 3.19 about x_m: dF_G/dx = gamma G0 / L; L twice the amplitude, G0 from k
        L = float(np.clip(np.ptp(d.x), ps["L"].lo, ps["L"].hi))
        out.append({**x0, "L": L, "G0": float(np.clip(k * L / GAMMA, ps["G0"].lo, ps["G0"].hi))})
    return out


def _stiffness(d):
    """The force's slope against position [N/m], fitted with velocity and direction beside
    it (least squares): the loop's stiffness, whatever carries it."""
    A = np.column_stack([np.ones_like(d.x), d.x - np.mean(d.x), d.v, np.sign(d.v)])
    return float(np.linalg.lstsq(A, d.F, rcond=None)[0][1])


def _cell_fits(d, cell, values, sd):
    """The cell's effects as fitted with the baseline, each with its 95 % interval and
    whether the recording resolves it (resolved)."""
    out = []
    for e in cell:
        own = {p.name: values[p.name] for p in EFFECTS[e].params(d, e)}
        ci = {k: [v - 1.96 * sd[k], v + 1.96 * sd[k]] for k, v in own.items()}
        out.append(CellFit(e, own, ci, resolved(d, e, own, ci)))
    return out


def _sized(steps, excess, sigma):
    """Each step's practical size (NAMED_SHARE): its gain's share of the held-out
    mean-square error above the noise that the damper's physics has to explain: the
    baseline's excess (its alignment fitted with it) less what the cell's timing beyond it
    and interference and the valve curve's form took. Only physics and terms outside the catalogue can be small:
    the cell's and the valve curve's form are never said as physics left out. Then how
    firmly each is named (held_in): the share of the judgements in which it is accepted,
    with no rival and no stand-in, times its size against the practical size's band."""
    is_physics = [EFFECTS[s.effect.split(":")[0]].nature in MECHANISMS for s in steps]
    left = excess - sigma ** 2 * sum(s.relevance for s, ph in zip(steps, is_physics) if not ph)
    for s, ph in zip(steps, is_physics):
        sized = 1.0
        if ph:
            s.excess_share = s.relevance * sigma ** 2 / max(left, 1e-30)
            s.small = left > 0 and s.excess_share < NAMED_SHARE
            sized = stability.against(s.excess_share, NAMED_SHARE) if left > 0 else 1.0
        alone = 1.0 - np.max([s.stand_in_votes, *s.rival_votes.values()], axis=0)  # neither rival nor stand-in
        s.held_in = float(np.mean(s.accept_votes * alone)) * sized


def _round(d, base, names, fitted, number, folds, current, judge, r_cur, shown, sigma, alpha, last, cost, progress,
           jobs, clock, screening=True):
    """Each candidate fitted beside the effects fitted so far (the cell's and those
    accepted) and judged on the held-out blocks: [Tried] of round `number`. A candidate is accepted where it is significant
    (p < alpha), worth having (RELEVANCE noise variances, SHARE of the error it starts from)
    and resolved: accept_share is the share of the judgements in which it is."""
    judged = judge.judged
    n_judged = int(np.sum(judged))
    sse_cur = judge.sse(r_cur, judge.main)
    mse = float(np.mean(r_cur[judged] ** 2))

    sieve = screen.Sieve(Model(d, fitted, base), d, folds, current, open_params(d, fitted), sigma, screening)

    def fitted_and_judged(e):
        """(Tried, its fit's seconds, its judgement's seconds): in a fitting process of its own
        when there are several, where the judgement's bootstrap runs beside the others' fits.
        Screened first: one the screen rules out is not fitted (screen.Sieve)."""
        t0 = time.perf_counter()
        m = Model(d, fitted + [e], base)
        sc = sieve.screen(m, judged, last[e].candidate.gain if e in last else 0.0)
        if sieve.rules_out(sc):
            c = Candidate(e, number, {}, {}, **scores(d.F, r_cur, shown), p_value=1.0, gain=sc * sigma ** 2,
                          relevance=sc, accept_votes=np.zeros(len(judge.variants)), screen=sc, screened=True)
            return Tried(c, {}, None, r_cur), time.perf_counter() - t0, 0.0
        if EFFECTS[e.split(":")[0]].linear:
            f_vals, f_sds, r = linear_fit(m, d, folds, current, hold=open_params(d, fitted))
        else:  # the open terms' coefficients held: they are refitted with the rest once accepted
            f_vals, f_sds, r = cross_fit(m, d, folds, current, hold=open_params(d, fitted), warm=getattr(last.get(e), "folds", None))
        t1 = time.perf_counter()
        vals, sds = pooled(f_vals, f_sds)
        gain = float((sse_cur - judge.sse(r, judge.main)).sum() / n_judged)  # held-out mean-square gain [N^2]
        own = {p.name: vals[p.name] for p in EFFECTS[e.split(":")[0]].params(d, e)}
        c = Candidate(e, number, own, {k: [own[k] - 1.96 * sds[k], own[k] + 1.96 * sds[k]] for k in own},
                      **scores(d.F, r, shown), p_value=judge.p(r, r_cur, alpha), gain=gain, relevance=gain / sigma ** 2)
        # each block counts alike whatever its force, and symmetrically: a block made ten
        # times worse weighs what one made ten times better does (Judge.log_ratio)
        worth = stability.against(c.relevance, RELEVANCE) * stability.against(gain / max(mse, 1e-30), SHARE)
        c.accept_votes = np.zeros(len(judge.variants))
        c.screen = sc
        if worth > 0 and resolved(d, e, c.parameters, c.ci):
            c.accept_votes = judge.votes(r, r_cur, alpha) * worth
        return Tried(c, vals, f_vals, r), t1 - t0, time.perf_counter() - t1

    # the costliest first (by the last round's time; before that, the nonlinear fits), so
    # that no process is left with a Bouc-Wen fit while the other waits
    order = sorted(names, key=lambda e: -cost.get(e, 0.0 if EFFECTS[e.split(":")[0]].linear else 1.0))
    judge.drawn(alpha)  # the resamples every process's judgements share, drawn once here
    done = dict(zip(order, threads.forked(fitted_and_judged, [(e,) for e in order], jobs)))
    cost.update({e: seconds for e, (_, seconds, _) in done.items()})
    clock.inner("p-values", sum(s for _, _, s in done.values()) / max(min(jobs, len(order)), 1))
    for e in names:
        c = done[e][0].candidate
        progress(f"  {e:28s} screened out: a linear step gains {c.screen:.2g} noise variances" if c.screened else
                 f"  {e:28s} held-out {100 * c.nrmse_heldout:.3f} %  p = {c.p_value:.2g}"
                 f"  gain {c.relevance:+.3f} noise variances")
    return [done[e][0] for e in names]


def _replaced(d, base, cell, folds, judge, accepted, values, current, r_cur, progress):
    """A term outside the catalogue replaces catalogue names whose sum it explains better:
    each catalogue effect accepted before an open term is dropped again when the model
    without it, refitted, does as well on the held-out cycles (its gain no longer
    significant, by the test that accepted it, in at least half of the judgements). Returns
    the new (accepted, values, per fold values, residual, {dropped: replacing term})."""
    replaced = {}
    open_ = [e for e in accepted if term(e)]
    if not open_:
        return accepted, values, current, r_cur, replaced
    for e in [e for e in accepted if not term(e) and accepted.index(e) < accepted.index(open_[0])]:
        rest = [a for a in accepted if a != e]
        m = Model(d, cell + rest, base)
        f_vals, f_sds, r = cross_fit(m, d, folds, current)
        if judge.share(r_cur, r, ALPHA) < 0.5:
            replaced[e] = open_[0]
            progress(f"{e} dropped: {open_[0]} explains it as well without it")
            accepted, current, r_cur = rest, f_vals, r
            values = pooled(f_vals, f_sds)[0]
    return accepted, values, current, r_cur, replaced


def resolved(d: Data, effect: str, params: dict, ci: dict) -> bool:
    """False when an effect's size is below what the recording can resolve (Effect.resolved)."""
    spec = EFFECTS[effect.split(":")[0]]
    return spec.resolved is None or spec.resolved(d, params, ci)


def left_over(r: np.ndarray, judge: Judge, sigma: float) -> LeftOver:
    """Is the final held-out residual within the noise? The excess over the noise variance
    per block, SSE_b / (n_b sigma^2 (1 + RELEVANCE)) - 1, tested against zero by the
    catalogue's bootstrap, in every judgement (within when it is in at least half); with the
    RMS above the noise [N]. The excess itself, not its logarithm: a misfit that lives in a
    few blocks (the reversals) has a negative mean log however large it is, and a residual
    six times the noise was said to be within it. Nor is a left-over whose RMS above the
    noise exceeds the noise's own, where the blocks' spread leaves the test unsure."""
    def p(v):
        sse = judge.sse(r, v)
        n = np.bincount(v.block, weights=judge.judged.astype(float), minlength=v.ids.max() + 1)[v.ids]
        ok = n > 0
        return p_value(sse[ok] / (n[ok] * sigma ** 2 * (1 + RELEVANCE)) - 1.0, v.seed)
    within = float(np.mean([p(v) >= ALPHA for v in judge.variants]))
    mse = float(np.mean(r[judge.judged] ** 2))
    above = float(np.sqrt(max(mse - sigma ** 2, 0.0)))
    # a misfit larger than the noise itself is not within it, however few blocks hold it
    return LeftOver(p(judge.main), above, within >= 0.5 and above <= sigma, within)


# --- where the residual lives ---------------------------------------------------------


