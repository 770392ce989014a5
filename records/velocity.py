"""The velocity a displacement implies, where a recording has no velocity channel: a
Savitzky-Golay first derivative (quadratic over 11 samples, about 5 ms at 2 kHz), smoother
than a plain difference and without its half-sample lag."""
from __future__ import annotations

import numpy as np

from rig.config import quantity
from rig.errors import UsageError


def derived_velocity(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """velocity_from, refused in one line where no rod moves that fast (time steps far too
    small for their unit, a displacement spike): what import writes, the reader reads."""
    v = velocity_from(t, x)
    lo, hi = quantity("v")[1:]
    bad = np.nonzero(~((v >= lo) & (v <= hi)))[0]
    if len(bad):
        i = bad[0]
        raise UsageError(f"the velocity derived from displacement reaches {v[i]:.3g} m/s at t = {t[i]:.6g} s, outside "
                       f"{lo:g}..{hi:g} m/s: check the time and displacement columns' units")
    return v


SG_HALF = 5  # samples either side: the Savitzky-Golay window of 11


def savgol_slope(x: np.ndarray, h: float, m: int = SG_HALF) -> np.ndarray:
    """The Savitzky-Golay first derivative of a quadratic over 2m+1 samples spaced h [s]
    (scipy.signal.savgol_filter(x, 2m+1, 2, deriv=1, delta=h), whose import alone costs a
    second of every import): inside, the least-squares slope, sum(k x[i+k]) / sum(k^2) / h
    (a quadratic's slope at the centre of a symmetric window is the line's); in the first
    and last m samples, the derivative of the quadratic fitted to the edge window."""
    k = np.arange(-m, m + 1)
    out = np.empty(len(x))
    out[m:len(x) - m] = np.convolve(x, k[::-1] / (np.sum(k * k) * h), "valid")
    for sl, at in ((slice(0, 2 * m + 1), np.arange(m)), (slice(len(x) - 2 * m - 1, len(x)), np.arange(m + 1, 2 * m + 1))):
        c = np.polyfit(np.arange(2 * m + 1), x[sl], 2)
        out[sl][at] = (2 * c[0] * at + c[1]) / h
    return out


def velocity_from(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Velocity [m/s] from displacement: Savitzky-Golay derivative (this module's docstring).
    Rows sharing a time stamp share the velocity of their mean displacement."""
    tu, inverse = np.unique(t, return_inverse=True)
    if len(tu) < len(t):
        xu = np.bincount(inverse, weights=x) / np.bincount(inverse)
        return velocity_from(tu, xu)[inverse]
    h = np.diff(t)
    if len(x) >= 11 and np.allclose(h, h.mean(), rtol=1e-3):
        return savgol_slope(x, float(h.mean()))
    return np.gradient(x, t)
