"""The screen before the fits (issue 90): what each candidate could gain, from one linear
step at the current model, before it is fitted in full.

A candidate's force near where the round starts is the current model's plus what the
candidate adds, linearised: at each of its starts s (its parameters' start values, and each
value of a gridded parameter's grid with the rest at their starts, as fit() tries them) the
jump F_s - F_cur and its own parameters' derivatives there, beside the derivatives of the
parameters already fitted (the score test's nuisance columns, taken once a round at the
current model). Least squares on each fold's training samples: the mean-square gain a
sample [N^2] there, or the candidate's own step's on the judged held-out samples where that
is larger, of the best start. One evaluation per start and own parameter, against a
nonlinear fit's hundreds."""
from __future__ import annotations

import numpy as np

from models.diagnose.candidates import EFFECTS, Model
from models.diagnose.data import Data
from models.diagnose.referees import RELEVANCE
from models.diagnose.stability import BAND

# A candidate below RELEVANCE / BAND noise variances is accepted in no judgement
# (stability.against); the screen rules one out only MARGIN times below that. Of the
# candidates that reach it fitted in full, the audit's least screen was 2.9 times BAR
# (tests/screen_audit.py, docs/results/screen.md)
MARGIN = 8.0
BAR = RELEVANCE / BAND / MARGIN  # noise variances
# a candidate that gained SURE noise variances last round is not screened (the screen's own
# time saved): no round of the audit took a gain that large below the bar (docs/diagnosis.md);
# a tenth of a noise variance (10 bars) would not do: an MR term's 0.84 fell to 0.004 when
# another took its residual
SURE = 10.0
INERT = 0.01  # of the force noise: a candidate that cannot move the force this much is not screened (gain)


class Sieve:
    """A round's screen: the current model's derivatives and force per fold, taken once; it
    rules out only where screening is asked and the current model is settled (settled())."""

    def __init__(self, model: Model, d: Data, folds: list, current: list[dict], hold: set, sigma: float,
                 screening: bool):
        self.d, self.folds, self.current, self.sigma, self.screening = d, folds, current, sigma, screening
        self.bases = nuisance(model, d, folds, current, hold)
        self.F_cur = [model.force(d, z) for z in current]
        self.active = screening and settled(d, folds, self.bases, self.F_cur, sigma)

    def screen(self, model: Model, judged: np.ndarray, last_gain: float = 0.0) -> float:
        """The screen of the candidate last in model [noise variances] (gain()); nan, not
        computed, for an open term (one linear step is its whole fit), and while screening,
        for one that gained SURE noise variances last round (last_gain [N^2]) and any in a
        round not settled. Without screening every one is computed (the audit)."""
        sigma2 = self.sigma ** 2
        if EFFECTS[model.effects[-1].split(":")[0]].linear or (
                self.screening and (last_gain >= SURE * sigma2 or not self.active)):
            return float("nan")
        return gain(model, self.d, self.folds, self.current, self.bases, self.F_cur, judged, self.sigma) / sigma2

    def rules_out(self, screened: float) -> bool:
        """Is a candidate of this screen [noise variances] left unfitted?"""
        return self.active and screened < BAR


def settled(d: Data, folds: list, bases: list, F_cur: list[np.ndarray], sigma: float) -> bool:
    """Does the current model sit at its optimum: does a linear step in its own parameters
    alone gain less than BAR noise variances on the training samples? Where it does not (an
    accepted term's one linear step, a refit of a few evaluations), every candidate's full
    fit also takes the rest of the way, which no screen of the candidate can tell: the
    round is not screened (on a null after an open term: 5.5 noise variances each)."""
    gained = 0.0
    for (train, _), (Q, _), F0 in zip(folds, bases, F_cur):
        y = (d.F - F0)[train]
        gained += float(np.sum((Q.T @ y) ** 2))
    return gained / sum(np.count_nonzero(train) for train, _ in folds) < BAR * sigma ** 2


def nuisance(model: Model, d: Data, folds: list, current: list[dict], hold: set) -> list[tuple]:
    """Per fold, the current model's derivatives in its free parameters (those not held, and
    not at a bound: the fit's constraint holds them there, as it holds a channels' alignment
    at its half sample where the force lags more): an orthonormal basis of their span on the
    fold's training samples, and what a unit step along each of its columns changes on every
    sample [N]."""
    out = []
    for (train, _), z in zip(folds, current):
        f = model.forces(d, z)
        exact = model.columns(f)  # the model's own derivatives, else a forward difference
        A = np.column_stack([exact[p.name] if p.name in exact else _derivative(model, d, z, p, f.F, 1e-4)
                             for p in model.params if p.name not in hold and _inside(p, z[p.name])])
        A = A / np.maximum(np.linalg.norm(A[train], axis=0), 1e-300)
        u, s, vt = np.linalg.svd(A[train], full_matrices=False)
        k = s > s[0] * 1e-10
        out.append((u[:, k], A @ (vt[k].T / s[k])))  # (the basis, a unit step along each of its columns on every sample)
    return out


def starts(d: Data, effect: str) -> list[dict]:
    """The candidate's own start values: all at their x0, and each grid value of each
    gridded parameter with the rest at theirs (clipped to the bounds, as fit() does)."""
    own = EFFECTS[effect.split(":")[0]].params(d, effect)
    x0 = {p.name: p.x0 for p in own}
    out = [x0]
    for p in own:
        out += [{**x0, p.name: min(max(g, p.lo), p.hi)} for g in p.grid]
    return out


def gain(model: Model, d: Data, folds: list, current: list[dict], bases: list, F_cur: list[np.ndarray],
         judged: np.ndarray, sigma: float) -> float:
    """The candidate's screened gain [N^2 a sample]: of its best start (above), the larger of
    the linear step's mean-square gain on the training samples and the candidate's own step's
    on the judged held-out samples. model: the current model with the candidate last; bases:
    nuisance()'s per fold; F_cur: the current model's force per fold; sigma: the force noise
    [N]. nan (no screen) where the candidate cannot move the force by INERT of the noise
    over its parameters' ranges at any start: it acts through a part the current model holds
    at zero (a pre-sliding friction on a sliding friction of zero, which the full fit raises
    with it: 0.61 noise variances on a real MR file, a screen of 2e-15)."""
    effect = model.effects[-1]
    own = [p for p in model.params[-len(EFFECTS[effect.split(":")[0]].params(d, effect)):] if p.lo < p.hi]
    n_train, n_judged = sum(np.count_nonzero(train) for train, _ in folds), np.count_nonzero(judged)
    best, reach = -np.inf, 0.0
    for s in starts(d, effect):
        steps = [_step_gains(model, d, fold, {**z, **s}, own, basis, F0, judged)
                 for fold, z, basis, F0 in zip(folds, current, bases, F_cur)]
        best = max(best, sum(g[0] for g in steps) / n_train, sum(g[1] for g in steps) / n_judged)
        reach = max([reach] + [g[2] for g in steps])
    return best if reach >= INERT * sigma else float("nan")


def _step_gains(model, d, fold, z, own, basis, F0, judged):
    """(training, held-out) squared error [N^2] one linear step from start z takes off, and
    the candidate's reach there [N]: its columns (the jump to the start and its own
    parameters' derivatives) and the fitted parameters' (basis), least squares together on
    the fold's training samples; held out, on its judged samples, the candidate's part with
    what of it the fitted parameters take up (a trend in time gains more on a later stretch
    than on the fit's). The reach: the largest RMS on the training samples of the jump and of
    each derivative times its parameter's range."""
    train, test = fold
    Q, moves = basis
    Fs = model.force(d, z)
    cols = [Fs - F0] if np.any(Fs != F0) else []  # the jump to the start
    cols += [_derivative(model, d, z, p, Fs, 1e-3) for p in own]
    reach = max([0.0] + [float(np.sqrt(np.mean(c[train] ** 2))) * w
                         for c, w in zip(cols, [1.0] * (len(cols) - len(own)) + [p.hi - p.lo for p in own])])
    y = (d.F - F0)[train]
    y_out = y - Q @ (Q.T @ y)  # what the fitted parameters' own step leaves
    C = np.column_stack(cols) if cols else np.zeros((len(d.F), 0))
    C_train = C[train]
    Ct = C_train - Q @ (Q.T @ C_train)  # Frisch-Waugh: the candidate's columns beyond the fitted parameters' span
    norm = np.linalg.norm(Ct, axis=0)
    keep = norm > 1e-12 * max(norm.max(initial=0.0), 1e-300)
    if not np.any(keep):
        return float(y @ y - y_out @ y_out), 0.0, reach
    c = np.linalg.lstsq(Ct[:, keep] / norm[keep], y_out, rcond=None)[0] / norm[keep]
    r = y_out - Ct[:, keep] @ c
    k = test & judged
    step = C[k][:, keep] @ c - moves[k] @ (Q.T @ (C_train[:, keep] @ c))
    r0 = (F0 - d.F)[k]
    return float(y @ y - r @ r), float(r0 @ r0 - (r0 + step) @ (r0 + step)), reach


def _derivative(model, d, z, p, F, rel):
    """The force's forward difference [N per unit] in parameter p at z (force F there), by
    rel of its value or rel / 1000 of its range, inward at a bound."""
    dz = max(abs(z[p.name]) * rel, (p.hi - p.lo) * rel * 1e-3)
    up = z[p.name] + dz if z[p.name] + dz <= p.hi else z[p.name] - dz
    return (model.force(d, {**z, p.name: up}) - F) / (up - z[p.name])


def _inside(p, value):
    """Is a parameter free to move both ways: strictly within its bounds (by 1e-9 of its range)?"""
    tol = 1e-9 * (p.hi - p.lo)
    return p.lo + tol < value < p.hi - tol
