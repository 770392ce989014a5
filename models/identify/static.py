"""Identification from a static test (thesis 4.2.1): friction against displacement as the
look-up table of eq 3.1, and the gas charge P0, V0 by the regression of eq 3.7 (Table 4.1),
each with a bootstrap confidence interval over the hold points.

Arrays in, numbers out: x [m], forces [N]. `static_holds` takes a recording's channels
{name: (t, values)} and events (docs/recording.md) as plain data.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from records.data import segments

from models.physics.gas_spring import fit_charge


@dataclass
class Estimate:
    name: str
    value: float
    ci_low: float  # 95 % interval
    ci_high: float
    unit: str
    identifiable: bool = True  # False: the data cannot determine it; value is a default
    note: str = ""


def static_holds(channels, events, window_s=1.0, name="force", extrapolate=False):
    """(x [m], `name` after a compression stroke, after an extension stroke) at each hold
    of a static run: means over the last window_s of each hold (force [N] by default),
    or with extrapolate the value each hold settles to (`settled`)."""
    rows = {}
    spans = [(p, t0, t1) for _, p, t0, t1 in segments(events, kinds=("hold",))]
    ends = settled(*channels[name], [(t0, t1) for _, t0, t1 in spans]) if extrapolate else None
    for i, (params, _t0, t1) in enumerate(spans):
        means = []
        for ch in (name, "x"):
            t, v = channels[ch]
            k = (t >= t1 - window_s) & (t <= t1)
            means.append(float(v[k].mean()) if k.any() else np.nan)
        if ends is not None:
            means[0] = ends[i]
        if "x_mm" in params and "approach" in params:  # a hold another dyno made may say neither
            rows.setdefault(params["x_mm"], {})[params["approach"]] = means
    keys = sorted(k for k, r in rows.items() if {"compression stroke", "extension stroke"} <= set(r))  # not "unknown"
    x = np.array([(rows[k]["compression stroke"][1] + rows[k]["extension stroke"][1]) / 2 for k in keys])
    up = np.array([rows[k]["compression stroke"][0] for k in keys])
    down = np.array([rows[k]["extension stroke"][0] for k in keys])
    return x, up, down


def settled(t, y, spans, tau_range=(0.5, 60.0)):
    """The value each hold (t0, t1) settles to: y = y_inf + A exp(-(t - t0) / tau) with
    one time constant for all holds (the gas's heat exchange, eq 3.7 wants it finished),
    fitted over the second half of each hold. Falls back to the last second's mean when
    the decay is not resolved (tau at its bounds)."""
    from scipy.optimize import minimize_scalar
    parts = []
    for t0, t1 in spans:
        k = (t >= t0 + 0.25 * (t1 - t0)) & (t <= t1)
        parts.append((t[k] - t0, y[k]))

    def solve(tau):
        out, sse = [], 0.0
        for tt, yy in parts:
            if len(tt) < 4:
                out.append(np.nan)
                continue
            A = np.column_stack([np.ones_like(tt), np.exp(-tt / tau)])
            c, *_ = np.linalg.lstsq(A, yy, rcond=None)
            sse += float(np.sum((yy - A @ c) ** 2))
            out.append(float(c[0]))
        return out, sse

    lo, hi = np.log(tau_range)
    best = minimize_scalar(lambda z: solve(np.exp(z))[1], bounds=(lo, hi), method="bounded")
    if not lo + 0.05 < best.x < hi - 0.05:
        return [float(yy[tt >= tt[-1] - 1.0].mean()) if len(tt) else np.nan for tt, yy in parts]
    return solve(np.exp(best.x))[0]


def identify_static(x, F_comp, F_ext, A_r, n_boot=400, seed=0):
    """{"P0": Estimate, "V0": Estimate, "friction": (x_table, F_table)} from hold forces:
    the gas force is the mean of the two approaches, the friction half their difference."""
    x, up, down = (np.asarray(a, float) for a in (x, F_comp, F_ext))
    if len(x) < 3:
        raise ValueError(f"the static step needs at least 3 hold positions, got {len(x)}")
    gas, friction = (up + down) / 2, (up - down) / 2
    P0, V0, _ = fit_charge(x, gas, A_r)
    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(n_boot):  # resample hold positions (at least two distinct)
        k = rng.integers(0, len(x), len(x))
        if len(np.unique(x[k])) > 1:
            boot.append(fit_charge(x[k], gas[k], A_r)[:2])
    lo, hi = np.percentile(np.array(boot), [2.5, 97.5], axis=0)
    order = np.argsort(x)
    return {"P0": Estimate("P0", P0, lo[0], hi[0], "Pa"), "V0": Estimate("V0", V0, lo[1], hi[1], "m^3"),
            "friction": (x[order], friction[order])}
