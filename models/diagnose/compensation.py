"""Whether an accepted effect may be compensating an earlier one's form: its parameters
trade against the earlier one's, or a change in the earlier one's form brings its gain."""
from __future__ import annotations

import numpy as np

from models.diagnose.candidates import EFFECTS, Model
from models.diagnose.data import Data
from models.statistics import covariance

TRADE = 0.7  # |correlation| between an accepted effect's parameters and an earlier one's: may be compensating its form


FORM_SHARE = 0.5  # share of a later effect's held-out gain that a change in an earlier one's form also brings: may be compensating it


def trades(model: Model, d: Data, train: np.ndarray, values: dict, earlier: list[str]) -> list[tuple[str, float]]:
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
    f = model.forces(d, values)
    base_r, exact = f.F[train], model.columns(f)
    J = np.empty((int(np.sum(train)), len(z)))
    for i in range(len(z)):  # forward differences: one force evaluation per parameter, or the basis
        if names[i] in exact:
            J[:, i] = exact[names[i]][train] / Fs
            continue
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


def changes(preds: list[list[np.ndarray]], k: int) -> list[np.ndarray]:
    """Per fold, what round k's accepted effect changed in the prediction [N] (its force and
    the refit of the rest)."""
    return [b - a for a, b in zip(preds[k - 1], preds[k])]


def reshapes(d: Data, c: np.ndarray) -> np.ndarray:
    """Columns [N] of the forms an effect's contribution c [N] may take that its one fitted
    shape lacks: c itself, and c sized by direction, with speed, along the stroke and with
    its own size, and c lagged (its rate of change over a sample period)."""
    rms = (lambda y: float(np.sqrt(np.mean(y ** 2))) or 1.0)
    dc = np.gradient(c, d.t) * float(np.median(d.h))
    dc[1:][np.diff(d.cycle) != 0] = 0.0  # not across a gap
    x = d.x - np.mean(d.x)
    return np.column_stack([c, c * np.sign(d.v), c * np.abs(d.v) / rms(d.v), c * x / rms(x), c * np.abs(c) / rms(c), dc])


def form_share(d: Data, folds: list, judged: np.ndarray, pred: np.ndarray, c_x: np.ndarray, c_y: np.ndarray) -> float:
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
