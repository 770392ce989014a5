"""Spencer's MR model (spencer.py) identified from a recording with the coil's command in it:
starts from the data, a staged least-squares fit, each parameter's interval and whether the
recording determines it, and the held-out error as published work splits a record (fitted
on the first 1 - F of it, judged on the last F).

Stages (each from the last's values): the passive model (the current's terms held at zero,
the coil's lag at its start), then the current's terms, then everything with the lag.
Starts: the force regressed on the motion, a yield (tanh) and their products with the
command, so that the viscous and the yield's size and their rise with the current come from
the data; the yield's travel tried over a grid (X_YIELD), the best after a brief fit kept."""
from __future__ import annotations

from dataclasses import astuple, dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from models.mr.spencer import A_BW, BOUNDS, NAMES, SPENCER_1997, UNITS, Spencer, force
from models.statistics import covariance

X_YIELD = (1e-5, 3e-5, 1e-4, 3e-4, 1e-3)  # m: the yield's travel z_max / A tried as starts
ETA_START = 100.0  # 1/s: the coil's lag before it is fitted (Spencer's prototype: 190)
BRIEF = 40  # evaluations of a start's brief fit
EFFORT = 400  # evaluations of a stage at most
PASSIVE = ("alpha_b", "c0_b", "c1_b")  # held at zero in the first stage
WORST_S = 0.5  # s: the window the held-out error's worst stretch is said in
DETERMINED = 0.5  # a parameter is determined when its 95 % interval's half-width is under this share of it


@dataclass
class SpencerParameter:
    name: str
    value: float
    unit: str
    ci: tuple  # 95 % interval
    determined: bool  # its interval within DETERMINED of its value, off its bounds


@dataclass
class Held:
    """Errors on the held-out stretch [N] and R^2 over the samples judged."""
    rmse: float
    r2: float
    samples: int
    from_s: float
    # where the error lives: the WORST_S window holding the largest share of its squared error
    worst_s: tuple = (float("nan"), float("nan"))
    worst_share: float = float("nan")


@dataclass
class Fitted:
    model: Spencer
    estimates: list  # [Estimate]
    train_rmse: float
    held: Held | None
    force: np.ndarray  # the model's force along the whole record [N]
    stages: list  # [(stage, train RMSE [N])]


def starts(x, xd, v, F, train) -> list:
    """Spencer models to start from: the data's linear view (module docstring), one per X_YIELD."""
    w = 0.02 * max(float(np.percentile(np.abs(xd[train]), 90)), 1e-6)  # m/s: the yield's velocity scale
    s = np.tanh(xd / w)
    A = np.column_stack([x, np.ones_like(x), xd, xd * v, s, s * v])[train]
    k1, f0, c, cv, fy, fyv = np.linalg.lstsq(A, F[train], rcond=None)[0]
    out = []
    for xy in X_YIELD:
        zmax = A_BW * xy  # z's ceiling: A / (gamma + beta) = z_max^2 (eq 5 at steady yield)
        g = A_BW / (2 * zmax ** 2)
        c0 = max(c, 1.0)
        out.append(Spencer(alpha_a=max(fy, 0.0) / zmax, alpha_b=max(fyv, 0.0) / zmax, c0_a=c0, c0_b=max(cv, 0.0),
                           c1_a=10 * c0, c1_b=0.0, k0=0.0, k1=k1, f0=f0, gamma=g, beta=g, eta=ETA_START))
    return out


def _fit(m: Spencer, free, args, train, effort):
    """(model, least-squares result) with the parameters `free` fitted on the training samples."""
    x, xd, v, h, F = args
    z0 = np.array(astuple(m), float)
    k = [NAMES.index(n) for n in free]
    lo = np.array([BOUNDS[n][0] for n in free])
    hi = np.array([BOUNDS[n][1] for n in free])
    # each parameter in units of its value, or of Spencer's prototype's where it is near zero (a
    # current's term starting at zero would otherwise be differenced by a step with no effect)
    typical = np.abs(np.array(astuple(SPENCER_1997), float))[k]
    scale = np.maximum(np.abs(z0[k]), np.where(typical > 0, typical, 10.0))

    def resid(u):
        z = z0.copy()
        z[k] = u * scale
        return (force(Spencer(*z), x, xd, v, h) - F)[train]
    r = least_squares(resid, np.clip(z0[k], lo, hi) / scale, bounds=(lo / scale, hi / scale), x_scale="jac",
                      diff_step=1e-4, max_nfev=effort)
    z = z0.copy()
    z[k] = r.x * scale
    r.jac = r.jac / scale
    return Spencer(*z), r


def identify(t, x, xd, v, F, holdout=0.15, judged=None, say=lambda s: None) -> Fitted:
    """Spencer's model fitted on the first 1 - holdout of the record (all of it: holdout 0),
    judged on the rest where `judged` (a mask: samples no check flagged) holds. x [m], xd
    [m/s], v [V], F [N] sampled at t [s]."""
    n = len(t)
    cut = n - int(round(holdout * n))
    train = np.zeros(n, bool)
    train[:cut] = True
    judged = np.ones(n, bool) if judged is None else judged
    train &= judged
    h = float(np.median(np.diff(t)))
    args = (x, xd, v, h, F)
    rms = lambda r: float(np.sqrt(np.mean(r.fun ** 2)))
    passive = [p for p in NAMES if p not in PASSIVE and p != "eta"]
    tried = [_fit(replace(s, alpha_b=0.0, c0_b=0.0, c1_b=0.0), passive, args, train, BRIEF)
             for s in starts(x, xd, v, F, train)]
    m, r = min(tried, key=lambda mr: float(np.sum(mr[1].fun ** 2)))
    stages = [("start (best of the yield's travels)", rms(r))]
    m, r = _fit(m, passive, args, train, EFFORT)
    stages.append(("passive", rms(r)))
    say(f"passive: training RMSE {rms(r):.1f} N")
    m, r = _fit(m, [p for p in NAMES if p != "eta"], args, train, EFFORT)
    stages.append(("with the current", rms(r)))
    say(f"with the current: training RMSE {rms(r):.1f} N")
    m, r = _fit(m, list(NAMES), args, train, EFFORT)
    stages.append(("with the coil's lag", rms(r)))
    say(f"with the coil's lag: training RMSE {rms(r):.1f} N")
    sd = covariance(r.jac, r.fun)[0]
    est = []
    for name, value, s in zip(NAMES, astuple(m), sd):
        lo, hi = BOUNDS[name]
        ci = (value - 1.96 * s, value + 1.96 * s)
        on_bound = min(abs(value - lo), abs(hi - value)) <= 1e-6 * max(abs(value), 1.0)
        est.append(SpencerParameter(name, float(value), UNITS[name], ci,
                            bool(np.isfinite(s) and 1.96 * s < DETERMINED * abs(value) and not on_bound)))
    Fm = force(m, x, xd, v, h)
    held = None
    if cut < n:
        k = np.zeros(n, bool)
        k[cut:] = True
        k &= judged
        e, y = Fm[k] - F[k], F[k]
        held = Held(float(np.sqrt(np.mean(e ** 2))), 1.0 - float(np.sum(e ** 2) / np.sum((y - y.mean()) ** 2)),
                    int(k.sum()), float(t[cut]), *_worst(t[k], e))
    return Fitted(m, est, rms(r), held, Fm, stages)


def _worst(t, e):
    """((from, to) [s], share): the WORST_S window of samples t holding most of the squared errors e."""
    c = np.r_[0.0, np.cumsum(e ** 2)]
    j = np.searchsorted(t, t + WORST_S)  # each window's end
    i = int(np.argmax(c[j] - c[:-1]))
    return (float(t[i]), float(t[min(j[i], len(t)) - 1])), float((c[j[i]] - c[i]) / max(c[-1], 1e-300))
