"""Missing-physics diagnosis: fit the baseline, locate where its residual lives, try each
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

import numpy as np
from scipy.optimize import least_squares

from models.diagnose.candidates import EFFECTS, FromModel, Minimal, Model
from models.diagnose.result import Baseline, Candidate, Diagnosis, Final, LeftOver, Step
from models.diagnose.terms import TERMS, tone
from models.diagnose.data import Data, DiagnoseError, prepare
from models.recording import covariance, nrmse

ALPHA = 0.01
TRADE = 0.7  # |correlation| between an accepted effect's parameters and an earlier one's: may be compensating its form
FORM_SHARE = 0.5  # share of a later effect's held-out gain that a change in an earlier one's form also brings: may be compensating it
SHORT = 4  # function evaluations per free parameter in a grid start's brief fit
MIN_TRAIN = 4  # cycles or blocks a time split fits on at least
RELEVANCE = 0.1
REFIT_EFFORT = 4  # function evaluations per parameter when an accepted term is refitted with the rest
REGION_SHARE = 0.25  # where an effect lives: where its RMS is above this share of its largest
LAG_RESOLVED = 0.02  # of a sample period: a lag shorter than this, its interval reaching zero, is not resolved
SHARE = 0.01
BOOT = 2000


def fit(model: Model, d: Data, train, start: dict, hold=(), effort=60):
    """Least squares over the training samples; returns (values, sd per parameter).
    Parameters named in `hold` stay at their start (sd nan); at most `effort` function
    evaluations per free parameter."""
    params = [p for p in model.params if p.name not in hold]
    names = [p.name for p in params]
    held = {p.name: start.get(p.name, p.x0) for p in model.params if p.name in hold}
    lo = np.array([p.lo for p in params])
    hi = np.array([p.hi for p in params])
    z0 = np.clip([start.get(p.name, p.x0) for p in params], lo, hi)
    scale = np.maximum(np.abs(hi - lo) * 1e-3, np.abs(z0) * 0.1)
    Fs = max(float(np.std(d.F)), 1e-9)

    def resid(z):
        return (model.force(d, {**held, **dict(zip(names, z))})[train] - d.F[train]) / Fs

    # parameters whose effect is piecewise or far from linear start from a grid over their
    # whole range: at each grid value the new effect's other parameters are fitted briefly
    # (a size is zero until its shape is right), and the best start is kept
    new = [i for i, p in enumerate(params) if p.name not in start]
    for i, p in enumerate(params):
        if not p.grid or p.name in start:
            continue
        free = [j for j in new if j != i and not params[j].grid]
        best = (np.inf, z0)
        for val in (min(max(g, p.lo), p.hi) for g in p.grid):
            z = z0.copy()
            z[i] = val
            if free:
                def part(y, z=z):
                    zz = z.copy()
                    zz[free] = y
                    return resid(zz)
                z[free] = least_squares(part, z[free], bounds=(lo[free], hi[free]), x_scale=scale[free],
                                        max_nfev=SHORT * len(free), method="trf").x
            cost = float(np.sum(resid(z) ** 2))
            if cost < best[0]:
                best = (cost, z)
        z0 = best[1]
    r = least_squares(resid, z0, bounds=(lo, hi), x_scale=scale, max_nfev=effort * len(z0), method="trf")
    values = {**held, **dict(zip(names, r.x))}
    try:
        sd = dict(zip(names, covariance(r.jac, r.fun)[0]))
    except np.linalg.LinAlgError:
        sd = {n: float("nan") for n in names}
    return values, {**{n: float("nan") for n in held}, **sd}


def blocks(d: Data, per_cycle=4):
    """Block number of each sample: each cycle cut into `per_cycle` equal parts (strokes
    and reversals apart), the units the bootstrap resamples."""
    out = np.empty(len(d.cycle), int)
    starts = np.r_[0, np.nonzero(np.diff(d.cycle))[0] + 1, len(d.cycle)]
    for a, b in zip(starts[:-1], starts[1:]):
        out[a:b] = d.cycle[a] * per_cycle + (np.arange(b - a) * per_cycle) // (b - a)
    return out


def _block_sse(r, block, ids):
    return np.bincount(block, weights=r ** 2, minlength=ids.max() + 1)[ids]


def p_value(d_c, rng, alpha=ALPHA):
    """One-sided bootstrap p-value of mean(d_c) > 0 over blocks d_c, with enough resamples
    (at least BOOT, and 20 / alpha) that the smallest p it can give is well under alpha."""
    n = len(d_c)
    if n < 3:
        return 1.0
    m = d_c.mean()
    total = max(BOOT, int(np.ceil(20 / alpha)))
    hits = 0
    for k in range(0, total, BOOT):  # in chunks: a (resamples x blocks) index array each
        boot = d_c[rng.integers(0, n, (min(BOOT, total - k), n))].mean(axis=1)
        hits += int(np.sum(boot - m >= m))
    return float((hits + 1) / (total + 1))


NOISE_HARMONICS = 60  # at most, and at most a third of a cycle's samples


def noise_sd(r, d: Data, k):
    """Force noise [N] in the residual r over the samples k: what no periodic misfit
    explains. Per sine segment the residual is fitted with the motion's harmonics, each
    with an amplitude that may change linearly over the segment (warm-up), and a quadratic
    trend; the rest, with its degrees of freedom, is noise of any colour. The median over
    segments keeps one badly fitted segment from setting it. Sample-to-sample differences
    (the fallback for motion that does not repeat) see only the white part: first-order
    noise with a pole at 0.95 per sample reads as a third of its size, and every structured
    misfit above that third was then announced as physics."""
    same = (np.diff(d.cycle) == 0) & k[1:] & k[:-1]
    diff = float(np.median(np.abs(np.diff(r)[same])) / 0.6745 / np.sqrt(2))
    if not d.periodic:
        return diff
    out = []
    for s, (_, f) in enumerate(d.segments):
        j = (d.segment == s) & k
        n = int(j.sum())
        h = float(np.median(d.h[j])) if n else 0.0
        K = min(NOISE_HARMONICS, int(1.0 / (3 * f * h))) if n else 0
        if K < 2:
            continue
        tau = d.t[j] - d.t[j].mean()
        u = tau / max(np.ptp(tau), 1e-9)
        cols = [np.ones(n), u, u * u]
        for m in range(1, K + 1):
            c, sn = np.cos(2 * np.pi * m * f * tau), np.sin(2 * np.pi * m * f * tau)
            cols += [c, sn, u * c, u * sn]
        A = np.column_stack(cols)
        if n < 2 * A.shape[1]:
            continue
        e = r[j] - A @ np.linalg.lstsq(A, r[j], rcond=None)[0]
        out.append(float(np.sqrt(np.sum(e ** 2) / (n - A.shape[1]))))
    return float(np.median(out)) if out else diff


def available(d: Data, accepted):
    out, skipped = [], []
    taken = {a.split(":")[0] for a in accepted}
    for name, e in EFFECTS.items():
        if e.needs == "T" and d.T is None:
            skipped.append(name)
        elif e.needs == "tone":
            if d.tone_hz is not None and name not in accepted:
                out.append(name)
        elif e.needs == "aux?":  # one of its forms at most
            if name not in taken:
                out += [name] + [f"{name}:{n}" for n in d.aux]
        elif e.needs == "aux":
            out += [f"aux_channel:{n}" for n in d.aux if f"aux_channel:{n}" not in accepted]
            if not d.aux:
                skipped.append(name)
        elif name not in accepted:
            out.append(name)
    return out, skipped


def _cross_fit(model: Model, d: Data, folds, starts, hold=(), effort=60):
    """Fit on each fold's training cycles, predict its held-out ones: (values per fold,
    sd per fold, residual [N] where every judged sample comes from a fit that never saw it)."""
    r = np.zeros(len(d.F))
    vals, sds = [], []
    for (train, test), start in zip(folds, starts):
        v, sd = fit(model, d, train, start, hold, effort)
        r = np.where(test, model.force(d, v) - d.F, r)
        vals.append(v)
        sds.append(sd)
    return vals, sds, r


def _linear_fit(model: Model, d: Data, folds, starts, hold=()):
    """_cross_fit for a model whose last effect is an open term (terms.py), by one
    Gauss-Newton step from the current model's values (`starts`): the term's coefficients
    (it is linear in them: its columns are the force's change per unit coefficient) and a
    step in every other free parameter, solved together by linear least squares on each
    fold's training samples. A nonlinear refit of a dozen spline coefficients with every
    other parameter costs tens of times more; the step lets the baseline give way where
    the term takes over (a valve curve reshaped needs the baseline's valve to move with it)."""
    own = model.params[-len(EFFECTS[model.effects[-1].split(":")[0]].params(d, model.effects[-1])):]
    own_names = {p.name for p in own}
    rest = [p for p in model.params if p.name not in own_names and p.name not in hold]
    r = np.zeros(len(d.F))
    vals, sds = [], []
    for (train, test), start in zip(folds, starts):
        z = {**{p.name: p.x0 for p in model.params}, **start, **{p.name: 0.0 for p in own}}
        F0 = model.force(d, z)
        cols = [model.force(d, {**z, p.name: 1.0}) - F0 for p in own]
        steps_ = [max(abs(z[p.name]) * 1e-4, (p.hi - p.lo) * 1e-7) for p in rest]
        cols += [(model.force(d, {**z, p.name: z[p.name] + dz}) - F0) / dz for p, dz in zip(rest, steps_)]
        A = np.column_stack(cols)
        y = (d.F - F0)[train]
        # the term alone, and the term with a damped step in the rest (their columns are
        # nearly collinear with a spline's); whichever the model itself fits better wins
        c = np.linalg.lstsq(A[train][:, :len(own)], y, rcond=None)[0]
        v = {**z, **{p.name: float(np.clip(ci, p.lo, p.hi)) for p, ci in zip(own, c)}}
        F1 = model.force(d, v)
        if rest:
            norm = np.maximum(np.linalg.norm(A[train], axis=0), 1e-300)
            As = A[train] / norm
            lam = 1e-3 * float(np.linalg.norm(As, 2)) ** 2
            damp = np.r_[np.zeros(len(own)), np.full(len(rest), lam)]
            sol = np.linalg.solve(As.T @ As + np.diag(damp), As.T @ y) / norm
            w = dict(z)
            for p, ci in zip(own + rest, sol[:len(own)].tolist() + [z[q.name] + dq for q, dq in zip(rest, sol[len(own):])]):
                w[p.name] = float(np.clip(ci, p.lo, p.hi))
            F2 = model.force(d, w)
            if np.sum((F2 - d.F)[train] ** 2) < np.sum((F1 - d.F)[train] ** 2):
                v, F1 = w, F2
        sd = covariance(A[train][:, :len(own)], (F1 - d.F)[train])[0]
        r = np.where(test, F1 - d.F, r)
        vals.append(v)
        sds.append({**{k: float("nan") for k in v}, **{p.name: float(s_) for p, s_ in zip(own, sd)}})
    return vals, sds, r


def _open_params(d: Data, effects):
    """Names of the open terms' coefficients among effects."""
    return {p.name for e in effects if e in TERMS for p in TERMS[e].params(d, e)}


def _pooled(vals, sds):
    """The folds' estimates averaged, with the sd of that mean (independent halves)."""
    mean = {k: float(np.mean([v[k] for v in vals])) for k in vals[0]}
    sd = {k: float(np.sqrt(sum(s[k] ** 2 for s in sds)) / len(sds)) for k in sds[0]}
    return mean, sd


def holdout_masks(d: Data, holdout="interleaved"):
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


def scores(F, r, k):
    """Held-out measures of a residual r [N] on samples k: NRMSE (of the force range), RMSE
    [N] and R^2."""
    e = r[k]
    sst = float(np.sum((F[k] - np.mean(F[k])) ** 2))
    return {"nrmse_heldout": nrmse(F[k] + e, F[k]), "rmse_heldout": float(np.sqrt(np.mean(e ** 2))),
            "r2_heldout": 1.0 - float(np.sum(e ** 2)) / max(sst, 1e-30)}


def diagnose(channels, events, progress=lambda s: None, max_effects=4, seed=0, baseline=None,
             holdout="interleaved") -> Diagnosis:
    """The diagnosis (see protocols/app/diagnose.py for its JSON). baseline: None for
    `minimal`, or (name, damper model) to start from that model, refitted. holdout:
    "interleaved" or the tail's fraction (holdout_masks)."""
    d = prepare(channels, events)
    if baseline is None:
        base = Minimal(d)
    else:
        progress(f"simulating {baseline[0]} along the recorded motion")
        base = FromModel(baseline[1], d, baseline[0])
    rng = np.random.default_rng(seed)
    folds, judged, shown = holdout_masks(d, holdout)
    block = blocks(d)
    judged_blocks = np.unique(block[judged])
    model = Model(d, base=base)
    fold_vals, sds, r0 = _cross_fit(model, d, folds, [{}] * len(folds))
    values, sd = _pooled(fold_vals, sds)
    r_train = model.force(d, fold_vals[0]) - d.F
    fit0 = folds[0][0]
    base_res = Baseline(base.name, values, sd, nrmse(d.F[fit0] + r_train[fit0], d.F[fit0]), **scores(d.F, r0, shown),
                        residual=r0, model_gas_force=getattr(base, "Fg_m", None))
    sigma = noise_sd(r0, d, judged)
    d.tone_hz = tone(d, r0, judged)
    progress(f"baseline: held-out error {100 * base_res.nrmse_heldout:.2f} % of the force range, "
             f"force noise {sigma:.2f} N")
    accepted, steps, candidates = [], [], []
    current, r_cur = fold_vals, r0
    # each fold's prediction [N] on every sample after each round: what an effect changed
    preds = [[model.force(d, v) for v in fold_vals]]
    _, not_assessed = available(d, accepted)
    n_judged = int(np.sum(judged))
    for _ in range(max_effects):
        names, _ = available(d, accepted)
        alpha = ALPHA / max(len(names), 1)  # Bonferroni over this round's candidates
        sse_cur = _block_sse(np.where(judged, r_cur, 0.0), block, judged_blocks)
        n_before = len(Model(d, accepted, base).params)
        round_ = []  # (candidate, pooled values, values per fold, residual)
        for e in names:
            m = Model(d, accepted + [e], base)
            if e in TERMS:
                f_vals, f_sds, r = _linear_fit(m, d, folds, current, hold=_open_params(d, accepted))
            else:  # the open terms' coefficients held: they are refitted with the rest once accepted
                f_vals, f_sds, r = _cross_fit(m, d, folds, current, hold=_open_params(d, accepted))
            vals, sds = _pooled(f_vals, f_sds)
            d_c = sse_cur - _block_sse(np.where(judged, r, 0.0), block, judged_blocks)
            gain = float(d_c.sum() / n_judged)  # held-out mean-square improvement [N^2]
            # each block counts alike whatever its force, and symmetrically: a block made ten
            # times worse weighs what one made ten times better does
            rel = np.log(np.maximum(sse_cur, 1e-30) / np.maximum(sse_cur - d_c, 1e-30))
            own = {p.name: vals[p.name] for p in m.params[n_before:]}
            c = Candidate(e, len(accepted) + 1, own, {k: [own[k] - 1.96 * sds[k], own[k] + 1.96 * sds[k]] for k in own},
                          **scores(d.F, r, shown), p_value=p_value(rel, rng, alpha), gain=gain,
                          relevance=gain / sigma ** 2)
            round_.append((c, vals, f_vals, r))
            progress(f"  {e:28s} held-out {100 * c.nrmse_heldout:.3f} %  p = {c.p_value:.2g}"
                     f"  gain {c.relevance:+.3f} noise variances")
        candidates += [c for c, *_ in round_]
        mse = float(np.mean(r_cur[judged] ** 2))
        ok = [x for x in round_ if x[0].p_value < alpha and x[0].relevance >= RELEVANCE
              and x[0].gain >= SHARE * mse and resolved(d, x[0].effect, x[0].parameters, x[0].ci)]
        if not ok:
            break
        best, b_vals, b_folds, b_r = max(ok, key=lambda x: x[0].gain)
        m_best = Model(d, accepted + [best.effect], base)
        if _open_params(d, accepted + [best.effect]):  # screened with parts held: now all refitted
            # from the screening's values, close to the optimum: a few evaluations per parameter
            b_folds, f_sds, b_r = _cross_fit(m_best, d, folds, b_folds, effort=REFIT_EFFORT)
            b_vals = _pooled(b_folds, f_sds)[0]
        preds.append([m_best.force(d, v) for v in b_folds])
        shares = [(e, form_share(d, folds, judged, preds[-2], _changes(preds, j + 1), _changes(preds, len(preds) - 1)))
                  for j, e in enumerate(accepted)]
        traded = trades(m_best, d, folds[0][0], b_folds[0], accepted)
        form_of = [(e, sh) for e, sh in shares if sh >= FORM_SHARE]
        steps.append(Step(best.effect, scores(d.F, r_cur, shown)["nrmse_heldout"], best.nrmse_heldout,
                          best.parameters, best.ci, best.p_value, r_cur, b_r, traded, form_of,
                          # the earlier effects whose form this one may be compensating, in acceptance order
                          [e for e in accepted if e in dict(traded) or e in dict(form_of)]))
        accepted.append(best.effect)
        values, current, r_cur = b_vals, b_folds, b_r
        progress(f"accepted {best.effect}")
    accepted, values, current, r_cur, replaced = _replaced(d, base, folds, judged, block, judged_blocks, accepted,
                                                           values, current, r_cur, progress)
    final_model = Model(d, accepted, base)
    held = judged | shown
    for st in steps:
        st.replaced_by = replaced.get(st.effect)
        if st.effect in accepted:
            for k, v in describe(d, st.effect, st.residual_after - st.residual_before, held).items():
                setattr(st, k, v)
    return Diagnosis(d, holdout, held, shown, base_res, sigma, locate(d.take(held), r0[held], sigma),
                     locate(d.take(held), r_cur[held], sigma), candidates, accepted, steps, not_assessed,
                     left_over(r_cur, judged, block, judged_blocks, sigma, rng),
                     Final(**scores(d.F, r_cur, shown), parameters=values, force=final_model.force(d, values)))


def _replaced(d, base, folds, judged, block, judged_blocks, accepted, values, current, r_cur, progress):
    """A term outside the catalogue replaces catalogue names whose sum it explains better:
    each catalogue effect accepted before an open term is dropped again when the model
    without it, refitted, does as well on the held-out cycles (its gain no longer
    significant, by the test that accepted it). Returns the new (accepted, values, per fold
    values, residual, {dropped: replacing term})."""
    replaced = {}
    open_ = [e for e in accepted if e in TERMS]
    if not open_:
        return accepted, values, current, r_cur, replaced
    rng = np.random.default_rng(1)
    for e in [e for e in accepted if e not in TERMS and accepted.index(e) < accepted.index(open_[0])]:
        rest = [a for a in accepted if a != e]
        m = Model(d, rest, base)
        f_vals, f_sds, r = _cross_fit(m, d, folds, current)
        sse_with = _block_sse(np.where(judged, r_cur, 0.0), block, judged_blocks)
        sse_without = _block_sse(np.where(judged, r, 0.0), block, judged_blocks)
        rel = np.log(np.maximum(sse_without, 1e-30) / np.maximum(sse_with, 1e-30))
        if p_value(rel, rng, ALPHA) >= ALPHA:
            replaced[e] = open_[0]
            progress(f"{e} dropped: {open_[0]} explains it as well without it")
            accepted, current, r_cur = rest, f_vals, r
            values = _pooled(f_vals, f_sds)[0]
    return accepted, values, current, r_cur, replaced


def resolved(d: Data, effect, params, ci):
    """False when an effect's size is below what one sample can resolve: a pre-sliding
    travel shorter than the rod moves in the first sample after a reversal (half the
    reversal's acceleration times the sample period squared, the median over segments), or
    a lag under LAG_RESOLVED of a sample period whose interval reaches zero."""
    key = effect.split(":")[0]
    h = float(np.median(d.h))
    if key == "presliding_friction":
        a = [np.max(np.abs(d.a[d.segment == s])) for s in np.unique(d.segment)]
        return params["x_stick"] >= 0.5 * float(np.median(a)) * h * h
    if key == "sensor_delay":
        lo, hi = ci["tau"]
        return abs(params["tau"]) >= LAG_RESOLVED * h or lo * hi > 0
    return True


def describe(d: Data, effect, change, k):
    """What an accepted effect is, from what accepting it changed in the held-out
    prediction (`change` [N], its force and the refit of the rest, over the samples k): its
    size (RMS and peak [N]), where it lives (the band of the variable it depends on where
    its RMS is above REGION_SHARE of its largest, and the directions that hold a quarter of its energy or
    more), whether it stores or dissipates energy (the net work it takes from the rod over
    the cycles against the work it exchanges), what it depends on and what kind of thing it
    is (spec.NATURES)."""
    spec = EFFECTS[effect.split(":")[0]]
    c = change[k]
    x, v, t = d.x[k], d.v[k], d.t[k]
    E = c * c
    comp = float(E[v > 0].sum() / max(E.sum(), 1e-30))
    dirs = ("both directions" if 0.25 <= comp <= 0.75 else "in compression" if comp > 0.75 else "in rebound")
    moving = bool({"displacement", "velocity", "direction"} & set(spec.depends_on))
    shape = c
    if "displacement" in spec.depends_on:
        var, scale, unit, name = x, 1e3, "mm", "displacement"
        # less what a straight line in x carries: where a term takes over, the baseline's gas
        # spring gives back the stiffness it had bent to, which is no place of the effect
        A = np.column_stack([np.ones_like(x), x])
        shape = c - A @ np.linalg.lstsq(A, c, rcond=None)[0]
    elif "velocity" in spec.depends_on:
        var, scale, unit, name = np.abs(v), 1.0, "m/s", "speed"
    elif "time" in spec.depends_on:
        var, scale, unit, name = t, 1.0, "s", "time"
    else:
        var = None
    region = dirs if moving else "whatever the motion"
    if var is not None and np.ptp(var) > 0:
        edges = np.linspace(var.min(), var.max(), 13)
        i = np.clip(np.digitize(var, edges) - 1, 0, 11)
        rms = np.sqrt(np.bincount(i, weights=shape ** 2, minlength=12) / np.maximum(np.bincount(i, minlength=12), 1))
        big = np.nonzero(rms >= REGION_SHARE * rms.max())[0]
        region = (f"{name} {edges[big.min()] * scale:.3g}-{edges[big.max() + 1] * scale:.3g} {unit}"
                  + (f", {dirs}" if moving else ""))
    work = float(np.sum(c * v)), float(np.sum(np.abs(c * v)))
    ratio = work[0] / max(work[1], 1e-30)
    character = ("independent of the motion" if set(spec.depends_on) <= {"time", "temperature", "aux"}
                 else "dissipative" if ratio > 0.5 else "elastic" if abs(ratio) < 0.2 else "both elastic and dissipative")
    return {"depends_on": list(spec.depends_on), "nature": spec.nature, "region": region, "character": character,
            "size_rms_n": float(np.sqrt(np.mean(E))), "size_peak_n": float(np.max(np.abs(c))),
            **({"tone_hz": d.tone_hz} if spec.needs == "tone" else {})}


def left_over(r, judged, block, judged_blocks, sigma, rng):
    """Is the final held-out residual within the noise? The excess over the noise variance
    per block, log(SSE_b / (n_b sigma^2 (1 + RELEVANCE))), tested against zero by the
    catalogue's bootstrap; with the RMS above the noise [N]."""
    sse = _block_sse(np.where(judged, r, 0.0), block, judged_blocks)
    n = np.bincount(block, weights=judged.astype(float), minlength=judged_blocks.max() + 1)[judged_blocks]
    ok = n > 0
    rel = np.log(np.maximum(sse[ok], 1e-30) / (n[ok] * sigma ** 2 * (1 + RELEVANCE)))
    mse = float(np.mean(r[judged] ** 2))
    p = p_value(rel, rng)
    return LeftOver(p, float(np.sqrt(max(mse - sigma ** 2, 0.0))), bool(p >= ALPHA))


def trades(model: Model, d: Data, train, values, earlier):
    """[(earlier effect, |correlation|)] whose parameters the newly accepted effect's (the
    model's last) trade against beyond TRADE: then its gain may be a change in the form
    of that effect, not physics of its own."""
    if not earlier:
        return []
    names = [p.name for p in model.params]
    own = set(names[-len(EFFECTS[model.effects[-1].split(":")[0]].params(d, model.effects[-1])):])
    z = np.array([values[n] for n in names])
    Fs = max(float(np.std(d.F)), 1e-9)
    scale = np.maximum(np.abs(z) * 1e-4, 1e-12)
    base_r = model.force(d, values)[train]
    J = np.empty((int(np.sum(train)), len(z)))
    for i in range(len(z)):  # forward differences: one force evaluation per parameter
        zi = z.copy()
        zi[i] += scale[i]
        J[:, i] = (model.force(d, dict(zip(names, zi)))[train] - base_r) / scale[i] / Fs
    _, rho = covariance(J, (base_r - d.F[train]) / Fs)
    out = []
    for e in earlier:
        theirs = {p.name for p in (EFFECTS[e.split(":")[0]].params(d, e))}
        ii = [i for i, n in enumerate(names) if n in own]
        jj = [j for j, n in enumerate(names) if n in theirs]
        c = float(np.max(np.abs(rho[np.ix_(ii, jj)]))) if ii and jj else 0.0
        if c > TRADE:
            out.append((e, c))
    return out


def _changes(preds, k):
    """Per fold, what round k's accepted effect changed in the prediction [N] (its force and
    the refit of the rest)."""
    return [b - a for a, b in zip(preds[k - 1], preds[k])]


def reshapes(d: Data, c):
    """Columns [N] of the forms an effect's contribution c [N] may take that its one fitted
    shape lacks: c itself, and c sized by direction, with speed, along the stroke and with
    its own size, and c lagged (its rate of change over a sample period)."""
    rms = (lambda y: float(np.sqrt(np.mean(y ** 2))) or 1.0)
    dc = np.gradient(c, d.t) * float(np.median(d.h))
    dc[1:][np.diff(d.cycle) != 0] = 0.0  # not across a gap
    x = d.x - np.mean(d.x)
    return np.column_stack([c, c * np.sign(d.v), c * np.abs(d.v) / rms(d.v), c * x / rms(x), c * np.abs(c) / rms(c), dc])


def form_share(d: Data, folds, judged, pred, c_x, c_y):
    """Share (0-1) of a newly accepted effect's held-out gain that a change in an earlier
    effect's form also brings. Linearised about the model before the new effect (each fold's
    prediction `pred` [N]): the residual regressed on the new effect's change c_y alone,
    on the earlier one's reshapes (reshapes of c_x), and on both; judged held out. When
    adding c_y to the reshapes gains little of what c_y gains alone, the new effect's gain
    may be the difference between the earlier effect's real form and the candidate's."""
    def sse(cols, r, train, test):
        beta = np.linalg.lstsq(cols[train], -r[train], rcond=None)[0]
        return float(np.sum((r + cols @ beta)[test] ** 2))
    alone = with_form = 0.0
    for (train, test), p, cx, cy in zip(folds, pred, c_x, c_y):
        r, test = p - d.F, test & judged
        B, y = reshapes(d, cx), cy[:, None]
        alone += float(np.sum(r[test] ** 2)) - sse(y, r, train, test)
        with_form += sse(B, r, train, test) - sse(np.hstack([B, y]), r, train, test)
    return float(np.clip(1.0 - with_form / alone, 0.0, 1.0)) if alone > 0 else 0.0


# --- where the residual lives ---------------------------------------------------------

def _segment_peak(d: Data, y):
    """Each sample's segment's largest y (0 for a segment none of d's samples are in: the
    samples taken may leave a segment out)."""
    peak = np.zeros(len(d.segments))
    np.maximum.at(peak, d.segment, y)
    return peak[d.segment]


GAIN_ERROR = 0.02  # a load cell's and a valve curve's proportional misfit: the share of the force a residual is judged against


def locate(d: Data, r, sigma=0.0):
    """[{where, energy_share, sample_share, mean_residual}] of regions holding more than
    their share of the residual energy, strongest concentration first. The residual is
    judged against the force level (each sample's square weighed by 1 / (sigma^2 +
    (GAIN_ERROR F)^2)), so that a proportional misfit does not point at the high-force
    bins, and over single variables and pairs (stroke band x direction, speed x direction)."""
    E = r ** 2 / np.maximum(sigma ** 2 + (GAIN_ERROR * d.F) ** 2, 1e-30)
    tot = max(E.sum(), 1e-30)
    vpk, apk = _segment_peak(d, np.abs(d.v)), _segment_peak(d, np.abs(d.a))
    Fr = np.ptp(d.F)
    regions = {
        "in compression (v > 0)": d.v > 0,
        "in rebound (v < 0)": d.v < 0,
        "near velocity reversal (|v| < 5 % of the segment's peak)": np.abs(d.v) < 0.05 * vpk,
        "at high speed (|v| > 80 % of the segment's peak)": np.abs(d.v) > 0.8 * vpk,
        "near force zero-crossing (|F| < 5 % of its range)": np.abs(d.F) < 0.05 * Fr,
        "at high acceleration (|a| > 80 % of the segment's peak)":
            np.abs(d.a) > 0.8 * apk,
    }
    lo, hi = np.percentile(d.x, [20, 80])
    regions[f"at the compressed end (x > {hi * 1e3:.1f} mm)"] = d.x > hi
    regions[f"at the extended end (x < {lo * 1e3:.1f} mm)"] = d.x < lo
    mid = (d.x > np.percentile(d.x, 40)) & (d.x < np.percentile(d.x, 60))
    regions[f"mid-stroke ({np.percentile(d.x, 40) * 1e3:.1f}-{np.percentile(d.x, 60) * 1e3:.1f} mm)"] = mid
    for s, (name, f) in enumerate(d.segments):
        regions[f"in segment {name}"] = d.segment == s
    bands = np.linspace(d.x.min(), d.x.max(), 6)
    for a, b in zip(bands[:-1], bands[1:]):
        band = (d.x >= a) & (d.x <= b)
        for word, side in (("compression", d.v > 0), ("rebound", d.v < 0)):
            regions[f"at displacement {a * 1e3:.1f}-{b * 1e3:.1f} mm in {word}"] = band & side
    for word, side in (("compression", d.v > 0), ("rebound", d.v < 0)):
        regions[f"at low speed in {word} (|v| < 30 % of the segment's peak)"] = side & (np.abs(d.v) < 0.3 * vpk)
        regions[f"at high speed in {word} (|v| > 70 % of the segment's peak)"] = side & (np.abs(d.v) > 0.7 * vpk)
    if d.T is not None:
        Tq = np.percentile(d.T, 75)
        regions[f"when hottest (T > {Tq - 273.15:.1f} C)"] = d.T > Tq
    out = []
    for where, k in regions.items():
        n = k.mean()
        if n < 0.01 or n > 0.9:
            continue
        share = E[k].sum() / tot
        out.append({"where": where, "energy_share": float(share), "sample_share": float(n),
                    "mean_residual": float(np.mean(r[k])), "concentration": float(share / n)})
    out.sort(key=lambda o: -o["concentration"])
    lag = best_lag(d, r)
    if lag is not None:
        out.append(lag)
    return out


def best_lag(d: Data, r):
    """The residual against the force's rate of change: a lag between force and motion
    leaves residual = -lag dF/dt."""
    dF = np.gradient(d.F, d.t)
    same = np.r_[True, np.diff(d.cycle) == 0]
    k = same & np.isfinite(dF)
    denom = float(np.sum(dF[k] ** 2))
    if denom <= 0:
        return None
    lag = -float(np.sum(r[k] * dF[k]) / denom)
    share = float(np.sum((lag * dF[k]) ** 2) / max(np.sum(r[k] ** 2), 1e-30))
    return {"where": f"lag between force and displacement {1e3 * lag:+.3f} ms (force later when positive)",
            "energy_share": share, "sample_share": 1.0, "mean_residual": 0.0, "concentration": share,
            "lag_s": lag}
