"""Identification from low-speed cycling (thesis 4.2.2.1): the dynamic breakaway friction
at each stroke reversal by the thesis's extrapolation, normalised by the static friction
at the same displacement (eq 3.2), and its temperature coefficients by the regression of
eq 4.1 (Table 4.2), or the mean ratio of eq 4.2 when the temperatures do not spread.

Arrays in, numbers out: x [m], F [N], T [K].
"""
from __future__ import annotations

import numpy as np

from models.physics.friction import static_friction
from models.damper import T_STD
from models.identify.static import Estimate

SKIP_M = 0.37e-3  # data next to the reversal dropped (thesis: 2.9 x the DAQ resolution)
BAND_M = 1.5e-3  # then a straight line through this much stroke on each side
MIN_T_SPREAD_K = 15.0  # less than this and the slope C_sfT is not identifiable


def reversals(x, F):
    """Dynamic breakaway friction [N] at each interior stroke reversal of a slow sine:
    [(x_reversal, friction, index)]. Each side's force within SKIP_M..SKIP_M + BAND_M of
    the reversal is fitted by a line and extrapolated to the reversal; the friction is half
    the jump (the approach carries +F_f into compression, the departure -F_f)."""
    from scipy.signal import find_peaks  # here: scipy.signal takes half a second to import
    x, F = np.asarray(x, float), np.asarray(F, float)
    out = []
    for s in (1.0, -1.0):  # compression ends (maxima of x), then rebound ends
        for i in find_peaks(s * x, prominence=2 * (SKIP_M + BAND_M))[0]:
            r = _jump(x, F, i, s)
            if r is not None:
                out.append((float(x[i]), r, int(i)))
    return sorted(out, key=lambda row: row[2])


def _side(x, ext, s, step):
    """Indices on one side of the reversal at ext whose distance from it lies in the band."""
    idx = np.arange(ext + step, -1 if step < 0 else len(x), step)
    d = (x[ext] - x[idx]) * s
    beyond = np.nonzero(d > SKIP_M + BAND_M)[0]
    idx, d = (idx, d) if not len(beyond) else (idx[:beyond[0]], d[:beyond[0]])
    return idx[d >= SKIP_M], len(beyond) > 0


def _jump(x, F, ext, s):
    """Half the force jump at the reversal at index ext; s = +1 at a compression end."""
    sides = []
    for step in (-1, 1):
        k, whole = _side(x, ext, s, step)
        if not whole or len(k) < 5:
            return None
        sides.append(np.polyfit(x[k] - x[ext], F[k], 1)[1])
    approach, departure = sides
    return s * (approach - departure) / 2.0


def breakaway_ratios(x, F, T, x_table, F_table):
    """(x, ratio, T) at each reversal: dynamic breakaway over the static friction at the
    same displacement (eq 3.2)."""
    rows = []
    for xr, Ff, i in reversals(x, F):
        Fs = float(static_friction(xr, x_table, F_table))
        if Fs > 0:
            rows.append((xr, Ff / Fs, float(T[i])))
    return np.array(rows).reshape(-1, 3)


def fit_ratio(ratio, T):
    """{"C_sfT", "C_ifT"} Estimates by eq 4.1's regression, or the eq 4.2 mean with
    C_sfT = 0 reported as not identifiable when the temperatures spread less than
    MIN_T_SPREAD_K. Intervals: 95 % from the regression's standard errors."""
    ratio, T = np.asarray(ratio, float), np.asarray(T, float)
    dT = T - T_STD
    n = len(ratio)
    if n < 2:
        raise ValueError(f"the low-speed step needs at least 2 stroke reversals, got {n}")
    if np.ptp(T) < MIN_T_SPREAD_K or n < 4:
        m, se = ratio.mean(), ratio.std(ddof=1) / np.sqrt(n)
        note = f"temperatures spread {np.ptp(T):.1f} K (< {MIN_T_SPREAD_K:g} K): slope not identifiable, eq 4.2 mean"
        return {"C_sfT": Estimate("friction.C_sfT", 0.0, np.nan, np.nan, "1/K", identifiable=False, note=note),
                "C_ifT": Estimate("friction.C_ifT", m, m - 1.96 * se, m + 1.96 * se, "-",
                                  note=f"mean ratio at {T.mean() - 273.15:.0f} C")}
    A = np.column_stack([dT, np.ones(n)])
    coef, *_ = np.linalg.lstsq(A, ratio, rcond=None)
    resid = ratio - A @ coef
    cov = resid @ resid / (n - 2) * np.linalg.inv(A.T @ A)
    se = np.sqrt(np.diag(cov))
    return {name: Estimate(f"friction.{name}", c, c - 1.96 * s, c + 1.96 * s, unit)
            for name, c, s, unit in (("C_sfT", coef[0], se[0], "1/K"), ("C_ifT", coef[1], se[1], "-"))}
