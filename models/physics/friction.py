"""Seal and bearing friction (thesis 3.2.1, 4.2.2.1).

Units: x in m, forces in N, temperatures in K. Friction opposes motion, so with the
force-positive-in-compression convention it carries the sign of the velocity.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from models.damper import T_STD


def static_friction(x, x_table, F_table):
    """Static breakaway friction magnitude vs displacement, eq 3.1  [N].

    Linear interpolation in the look-up table; outside it the end segments are
    extrapolated as eq 3.1 prints for x < X_1, clamped at zero.
    """
    return np.maximum(np.interp(x, *extended_table(x_table, F_table)), 0.0)


def extended_table(x_table, F_table, reach=1.0):
    """The look-up table with its end segments extended `reach` [m] beyond each end, so
    that plain interpolation gives eq 3.1's extrapolation (a stroke is well under 1 m)."""
    X, F = np.asarray(x_table, float), np.asarray(F_table, float)
    if len(X) < 2:
        return X, F
    lo = F[0] - (F[1] - F[0]) / (X[1] - X[0]) * reach
    hi = F[-1] + (F[-1] - F[-2]) / (X[-1] - X[-2]) * reach
    return np.r_[X[0] - reach, X, X[-1] + reach], np.r_[lo, F, hi]


def breakaway_ratio(T, C_sfT, C_ifT):
    """Dynamic-to-static breakaway ratio R_fxT vs temperature, eqs 3.2 and 4.1  [-].

    R = C_sfT * dT + C_ifT with dT = T - 20 C (C_sfT in 1/K). A temperature-independent
    damper (the thesis's Fox, Table 4.3) has C_sfT = 0 and C_ifT = the mean ratio (eq 4.2).
    """
    return np.maximum(C_sfT * (np.asarray(T, float) - T_STD) + C_ifT, 0.0)


def friction_force(x, v, T, x_table, F_table, C_sfT, C_ifT):
    """Friction force, eq 3.3: F = F_sx * (C_sfT dT + C_ifT) * sgn(v)  [N]."""
    return static_friction(x, x_table, F_table) * breakaway_ratio(T, C_sfT, C_ifT) * np.sign(v)


@njit(cache=True)
def dahl_step(F, dx, F_c, x_stick):
    """Friction force [N] after a displacement increment dx [m], Dahl's model (not the
    thesis's): the force approaches +-F_c (eq 3.3's magnitude) exponentially over x_stick of
    travel, F = sgn(dx) F_c + (F - sgn(dx) F_c) exp(-|dx| / x_stick), and stays put at rest.
    The virtual rig uses it: the seal holds what it carried when the motion stopped (what
    the static test measures), and an explicit loop with a compliant frame cannot chatter
    on it as it would on sgn(v). Compiled: the quarter car's loop calls it too."""
    if dx == 0.0 or F_c <= 0.0:
        return min(max(F, -F_c), F_c)
    target = F_c if dx > 0 else -F_c
    return target + (F - target) * math.exp(-abs(dx) / x_stick)


@njit(cache=True, nogil=True)
def dahl_series(x, F_c, x_stick, F0):
    """dahl_step along a displacement record x [m] with friction magnitudes F_c [N] per
    sample, from F0 [N]: the friction force [N] at each sample."""
    out = np.empty(x.shape[0])
    F = F0
    out[0] = F
    for i in range(1, x.shape[0]):
        dx = x[i] - x[i - 1]
        if dx != 0.0:
            target = F_c[i] if dx > 0.0 else -F_c[i]
            F = target + (F - target) * math.exp(-abs(dx) / x_stick)
        out[i] = F
    return out


def mean_ratio(ratios):
    """Mean normalised breakaway friction over a temperature series, eq 4.2  [-]."""
    return float(np.mean(ratios))
