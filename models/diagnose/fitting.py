"""Fitting a diagnosis model on training samples: least squares over every free
parameter (grid starts for piecewise ones), two-fold cross-fitting, and one Gauss-Newton
step for an open term (terms.py)."""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from models.diagnose.candidates import EFFECTS, Model
from models.diagnose.data import Data
from models.statistics import covariance
from workers.threads import each

SHORT = 4  # function evaluations per free parameter in a grid start's brief fit
TIE = 1e-6  # of two starts, a fit no lower in cost than the earlier's by this share keeps the earlier
SETTLE_STEPS = 2  # Gauss-Newton steps of the baseline at each grid value
# steps (each a finite-difference Jacobian, a model evaluation per parameter) after which a
# fit is crawling along a valley, not converging: on a crank recording one Bouc-Wen fit
# took 900 steps (13,000 evaluations, a third of the diagnosis) for a candidate refused;
# every other fit of the benchmarks and the shared recordings converges within 80
MAX_STEPS = 100
# a fit has converged when a step the model predicted well (scipy's ratio > 0.25) lowers the
# cost by less than FTOL of it: where the residual is noise, 1e-6 noise variances, 1e-5 of the
# smallest gain a decision counts (referees.RELEVANCE). The trust region is scaled by the
# Jacobian's columns (scipy's x_scale "jac"): with a fixed scale a third of the fits crawled
# along the valve curve's flat valley (c1, c2, C and Fcr trading) to the step limit, and a
# lag's and a compressibility's gains on one recording differed by 2 % between two
# processors' rounding; scaled by the Jacobian they agree to 1e-6, in half the time
FTOL = 1e-6
EPS = np.finfo(float).eps ** 0.5  # the relative step of a forward difference (of a parameter's own scale)
# an open term's step in the other parameters, damped by these shares of its largest
# curvature; the one that fits the training samples best is kept: at any one damping the
# baseline can stay where it bent to absorb part of the term (a zero drifting over a matrix
# whose amplitudes rise in time then reads as an elastic force along the stroke)
STEP_DAMPING = (1e-6, 1e-4, 1e-3, 1e-2)


def fit(model: Model, d: Data, train: np.ndarray, start: dict, hold: tuple | list | set = (), effort: int = 60,
        warm: dict | None = None) -> tuple[dict, dict, bool]:
    """Least squares over the training samples; returns (values, sd per parameter, whether
    it stopped at its step limit before converging).
    Parameters named in `hold` stay at their start (sd nan); at most `effort` function
    evaluations per free parameter. warm: values of parameters not in `start` from an
    earlier fit (the same candidate last round), tried against the grid starts."""
    params = [p for p in model.params if p.name not in hold]
    names = [p.name for p in params]
    held = {p.name: start.get(p.name, p.x0) for p in model.params if p.name in hold}
    lo = np.array([p.lo for p in params])
    hi = np.array([p.hi for p in params])
    warm = warm or {}
    z0 = np.clip([start.get(p.name, warm.get(p.name, p.x0)) for p in params], lo, hi)
    scale = np.maximum(np.abs(hi - lo) * 1e-3, np.abs(z0) * 0.1)
    Fs = max(float(np.std(d.F)), 1e-9)
    # the training samples as indices, and their forces, taken once: every evaluation and
    # Jacobian column picks them (a boolean mask is read whole at each pick)
    train = np.flatnonzero(train) if np.asarray(train).dtype == bool else train
    F_train = d.F[train]

    last = {}  # the last evaluation, which the Jacobian at the same point starts from

    def resid(z):
        # settled() and a grid start ask again for the point they just tried (an eighth of a
        # diagnosis's evaluations): the same Forces, not the same work twice
        if "z" not in last or not np.array_equal(last["z"], z):
            last["z"], last["f"] = z.copy(), model.forces(d, {**held, **dict(zip(names, z))})
        return (last["f"].F[train] - F_train) / Fs

    # parameters whose effect is piecewise or far from linear start from a grid over their
    # whole range: at each grid value the new effect's other parameters are fitted briefly
    # (a size is zero until its shape is right), and the best start is kept. A warm start
    # (last round's fit of the same candidate) competes with the grid: it is usually near the
    # optimum, and the grid guards against a shape the accepted effect has since taken over
    new = [i for i, p in enumerate(params) if p.name not in start]
    for i, p in enumerate(params):
        if not p.grid or p.name in start:
            continue
        free = [j for j in new if j != i and not params[j].grid]
        tried = [(float(np.sum(resid(z0) ** 2)), z0)] if p.name in warm else []
        for val in (min(max(g, p.lo), p.hi) for g in p.grid):
            z = z0.copy()
            z[i] = val
            if free:
                def part(y, z=z):
                    zz = z.copy()
                    zz[free] = y
                    return resid(zz)
                z[free] = solve(part, None, z[free], lo[free], hi[free], scale[free], SHORT * len(free)).x
            z = settled(model, resid, last, z, i, names, lo, hi, scale, train, Fs)
            tried.append((float(np.sum(resid(z) ** 2)), z))
        z0 = min(tried, key=lambda c: c[0])[1]  # the earliest of equal costs
    # the step's and gradient's tolerances are scipy's (1e-8), the cost's FTOL. (In raw units,
    # not each parameter's, a cost tolerance of 1e-5 stopped a real MR recording's
    # compressibility fit at a quarter of its gain, and another effect won.)
    jac = jacobian(model, d, train, F_train, held, names, lo, hi, Fs, last, scale)
    r = solve(resid, jac, z0, lo, hi, scale, min(effort * len(z0), MAX_STEPS))
    values = {**held, **dict(zip(names, r.x))}
    try:
        sd = dict(zip(names, covariance(r.jac, r.fun)[0]))
    except np.linalg.LinAlgError:
        sd = {n: float("nan") for n in names}
    return values, {**{n: float("nan") for n in held}, **sd}, r.status == 0


def settled(model, resid, last, z, i, names, lo, hi, scale, train, Fs):
    """z with the parameters whose derivatives the model knows exactly (the baseline's:
    Model.columns) moved by Gauss-Newton steps, parameter i held: what the rest becomes
    at a grid value, for the price of an evaluation a step (resid(z) leaves its Forces in
    last["f"], whose columns the step reads). A 2 ms lag tried with the valves the
    baseline had bent towards it cost more than none, and was never fitted."""
    for _ in range(SETTLE_STEPS):
        r0 = resid(z)
        cols = model.columns(last["f"])
        k = [j for j, n in enumerate(names) if n in cols and j != i and lo[j] < hi[j]]
        if not k:
            return z
        A = np.column_stack([cols[names[j]][train] / Fs * scale[j] for j in k])
        AtA, g = A.T @ A, A.T @ r0
        big = float(np.max(np.diag(AtA)))
        for lam in STEP_DAMPING[1:] + (1e-1, 1.0):  # damped as Levenberg-Marquardt: the valley's flat ways stay put
            try:
                step = -np.linalg.solve(AtA + lam * big * np.eye(len(k)), g) * scale[k]
            except np.linalg.LinAlgError:
                continue
            trial = z.copy()
            trial[k] = np.clip(z[k] + step, lo[k], hi[k])
            if np.sum(resid(trial) ** 2) < np.sum(r0 ** 2):
                break
        else:
            return z
        z = trial
    return z


def solve(resid, jac, z0, lo, hi, scale, max_nfev):
    """scipy's trust-region least squares over parameters z within [lo, hi], in units of
    their scale: its step tolerance (xtol) compares a step with the parameters' norm, so
    in raw units a stiffness of 1e4 N s/m hid every step of a compliance of 1e-7 m/N and
    stopped the fit where it started. The result's x and jac are in z's units.
    A stop short of the step limit is checked by a fresh start where it stopped, until one
    gains less than FTOL: at a kink of the residual (a delay's interpolation between
    samples, a friction's reversal) scipy's trust region shrinks to steps too small to gain
    FTOL while the fit is still far from its optimum, and where it stopped was then the last
    bits' choice (on a real 10 mm 1 Hz MR file, 9 of 46 fits stopped 0.05 to 0.9 noise
    variances short, and a valve form was named on one processor and not on another)."""
    run = lambda u0, n, method="trf": least_squares(
        lambda u: resid(u * scale), u0, bounds=(lo / scale, hi / scale), max_nfev=n, ftol=FTOL, x_scale="jac",
        method=method, jac="2-point" if jac is None else (lambda u: jac(u * scale) * scale))
    r = run(z0 / scale, max_nfev)
    used = r.nfev
    while r.status > 0:  # stopped by a tolerance, not by the step limit
        if used >= max_nfev:
            r.status = 0  # the step limit, reached by fresh starts that still gained
            break
        again = run(r.x, max_nfev - used)
        used += again.nfev
        cost = float(np.sum(r.fun ** 2))
        gained = cost - float(np.sum(again.fun ** 2))
        if gained > 0:
            r = again
        if gained <= FTOL * cost:
            # a kink can hold a trust region of either shape: a rectangular one (dogbox) from the
            # same place, kept only where it gains FTOL (the UTFSM 25 mm 0.5 Hz file's baseline:
            # one start 2.5e-3 of the cost short of its optimum, 6e-7 after it)
            if used >= max_nfev:
                break
            other = run(r.x, max_nfev - used, "dogbox")
            used += other.nfev
            cost = float(np.sum(r.fun ** 2))
            if cost - float(np.sum(other.fun ** 2)) <= FTOL * cost:
                break
            r = other
    r.x = np.clip(r.x * scale, lo, hi)
    r.jac = r.jac / scale
    return r


def jacobian(model: Model, d: Data, train, F_train, held, names, lo, hi, Fs, last, scale):
    """fit()'s residual's Jacobian: forward differences (a step of EPS of the parameter or of
    its scale, whichever is larger, away from a bound: scipy's step of EPS of at least 1 was
    15 % of a compliance of 1e-7 m/N),
    except for the coefficients whose derivative the model knows exactly (Model.columns),
    which a difference would evaluate the model for one by one (a valve form has 14).
    train: the training samples' indices, F_train their forces; last: the residual's last
    evaluation {"z", "f"}."""
    def jac(z):
        f = last["f"] if np.array_equal(last.get("z"), z) else model.forces(d, {**held, **dict(zip(names, z))})
        exact = model.columns(f)
        r0 = (f.F[train] - F_train) / Fs  # as scipy differences the residual (the same rounding)
        J = np.empty((len(z), len(r0))).T  # column-major as scipy's (its SVD rounds by the layout)
        for i, name in enumerate(names):
            if name in exact:
                J[:, i] = exact[name][train] / Fs
                continue
            h = EPS * np.copysign(max(scale[i], abs(z[i])), z[i])
            if not lo[i] <= z[i] + h <= hi[i] and lo[i] <= z[i] - h <= hi[i]:
                h = -h
            zz = z.copy()
            zz[i] += h
            r = (model.force(d, {**held, **dict(zip(names, zz))})[train] - F_train) / Fs
            J[:, i] = (r - r0) / (zz[i] - z[i])
        return J
    return jac


def cross_fit(model: Model, d: Data, folds: list, starts: list[dict], hold: tuple | list | set = (), effort: int = 60,
              restart: bool = False, warm: list[dict] | None = None, more: tuple | list = (),
              stopped: list | None = None) -> tuple[list[dict], list[dict], np.ndarray]:
    """Fit on each fold's training cycles, predict its held-out ones: (values per fold,
    sd per fold, residual [N] where every judged sample comes from a fit that never saw it).
    restart: each fold is fitted again from every other fold's values, and keeps whichever
    fits its own training cycles better. From the data's rough starts one fold can stop in
    a local minimum the other did not (on a null with designed sines added, the odd
    cycles' valve lost its quadratic term: 19 N RMS against 2.3 N), and the difference
    between the folds is then read as physics. warm: per fold, fit()'s warm. more: other
    starts each fold is fitted from too, the lowest cost kept (a cost no lower by TIE keeps
    the earlier: the same choice on any machine). stopped: a list, given, to which each
    fold's kept fit adds whether it stopped at its step limit before converging."""
    cost = lambda v, train: float(np.sum((model.force(d, v) - d.F)[train] ** 2))

    def best(train, start, w):
        out = None
        for s in [start, *more]:
            v, sd, limit = fit(model, d, train, s, hold, effort, w)
            c = cost(v, train)
            if out is None or c < out[2] * (1.0 - TIE):
                out = (v, sd, c, limit)
        return out[0], out[1], out[3]
    got = each(best, [(train, start, w) for (train, _), start, w in zip(folds, starts, warm or [None] * len(folds))])
    vals, sds, limits = [g[0] for g in got], [g[1] for g in got], [g[2] for g in got]
    for i, (train, _) in enumerate(folds):  # one after the other: a fold restarts from the one before
        # restart: every fold from every other's values; else a fold stopped at its step limit
        # from those of a fold that converged: where it stopped was the path's, and the path
        # the last bits' (a real 2 mm 5 Hz MR file's gain drift: 15050 or 18042 N^2 by
        # processor, both short of the other fold's 13776, and a friction named on one only)
        others = [j for j in range(len(folds)) if j != i and (restart or (limits[i] and not limits[j]))]
        for j in others:
            v, sd, limit = fit(model, d, train, vals[j], hold, effort)
            if cost(v, train) < cost(vals[i], train) * (1.0 - TIE):
                vals[i], sds[i], limits[i] = v, sd, limit
    r = np.zeros(len(d.F))
    for (_, test), v in zip(folds, vals):
        r = np.where(test, model.force(d, v) - d.F, r)
    if stopped is not None:
        stopped += limits
    return vals, sds, r


def linear_fit(model: Model, d: Data, folds: list, starts: list[dict], hold: tuple | list | set = ()
              ) -> tuple[list[dict], list[dict], np.ndarray]:
    """cross_fit for a model whose last effect is an open term (terms.py), by one
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
        f0 = model.forces(d, z)
        F0, exact = f0.F, model.columns(f0)
        cols = [exact[p.name] if p.name in exact else model.force(d, {**z, p.name: 1.0}) - F0 for p in own]
        for p in rest:  # the model's exact derivative, else a forward difference
            dz = max(abs(z[p.name]) * 1e-4, (p.hi - p.lo) * 1e-7)
            cols.append(exact[p.name] if p.name in exact else (model.force(d, {**z, p.name: z[p.name] + dz}) - F0) / dz)
        A = np.column_stack(cols)
        At, y = A[train], (d.F - F0)[train]
        # the term alone, and the term with a damped step in the rest (their columns are
        # nearly collinear with a spline's); whichever the model itself fits better wins
        c = np.linalg.lstsq(At[:, :len(own)], y, rcond=None)[0]
        v = {**z, **{p.name: float(np.clip(ci, p.lo, p.hi)) for p, ci in zip(own, c)}}
        F1 = model.force(d, v)
        if rest:
            norm = np.maximum(np.linalg.norm(At, axis=0), 1e-300)
            As = At / norm
            AtA, Aty = As.T @ As, As.T @ y
            big = float(np.linalg.norm(As, 2)) ** 2
            cost = np.sum((F1 - d.F)[train] ** 2)
            for lam in STEP_DAMPING:  # whichever damping the model itself fits best (Levenberg-Marquardt's choice)
                damp = np.r_[np.zeros(len(own)), np.full(len(rest), lam * big)]
                try:
                    sol = np.linalg.solve(AtA + np.diag(damp), Aty) / norm
                except np.linalg.LinAlgError:  # a column the data leaves at zero: least squares
                    sol = np.linalg.lstsq(AtA + np.diag(damp), Aty, rcond=None)[0] / norm
                w = dict(z)
                for p, ci in zip(own + rest,
                                 sol[:len(own)].tolist() + [z[q.name] + dq for q, dq in zip(rest, sol[len(own):])]):
                    w[p.name] = float(np.clip(ci, p.lo, p.hi))
                F2 = model.force(d, w)
                if (c2 := np.sum((F2 - d.F)[train] ** 2)) < cost:
                    v, F1, cost = w, F2, c2
        sd = covariance(At[:, :len(own)], (F1 - d.F)[train])[0]
        r = np.where(test, F1 - d.F, r)
        vals.append(v)
        sds.append({**{k: float("nan") for k in v}, **{p.name: float(s_) for p, s_ in zip(own, sd)}})
    return vals, sds, r


def open_params(d: Data, effects: list[str]) -> set[str]:
    """Names of the coefficients of the effects among `effects` that are smooth bases."""
    return {p.name for e in effects if EFFECTS[e.split(":")[0]].linear for p in EFFECTS[e.split(":")[0]].params(d, e)}


def pooled(vals: list[dict], sds: list[dict]) -> tuple[dict, dict]:
    """The folds' estimates averaged, with the sd of that mean (independent halves)."""
    mean = {k: float(np.mean([v[k] for v in vals])) for k in vals[0]}
    sd = {k: float(np.sqrt(sum(s[k] ** 2 for s in sds)) / len(sds)) for k in sds[0]}
    return mean, sd
