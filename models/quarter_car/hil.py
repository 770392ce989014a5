"""Measures of a hardware-in-the-loop run against its reference (the same car, road and
damper model run entirely in simulation). Arrays in, numbers out; SI units.

J2 is the real-time hybrid simulation benchmark's normalised tracking error,
RMS(x_measured - x_target) / RMS(x_target), the target taken about its mean (the damper's
installed position is an offset, not motion to track); every NRMS here is normalised the
same way.
"""
from __future__ import annotations

import numpy as np

from models.quarter_car.sim import QuarterCarResult


def _ac(a):
    a = np.asarray(a, float)
    return a - a.mean()


def j2(x_measured, x_target):
    """RMS of the tracking error over RMS of the target's motion [-]."""
    return nrms(x_measured, x_target)


def nrms(a, b):
    """RMS(a - b) / RMS(b about its mean) [-]: how far a response is from its reference."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.sqrt(np.mean(np.square(a - b)) / max(np.mean(np.square(_ac(b))), 1e-30)))


def delay(x_from, x_to, h, max_s=0.05):
    """Seconds by which x_to follows x_from (sampled every h [s]): the peak of their
    cross-correlation on the motion's derivative (which weighs the fast content the delay
    matters for), refined by a parabola through the peak's neighbours."""
    a, b = np.diff(_ac(x_from)), np.diff(_ac(x_to))
    n = min(int(max_s / h), len(a) - 2)
    if n < 2:
        return float("nan")
    lags = np.arange(-n, n + 1)
    c = np.array([np.dot(a[max(0, -k):len(a) - max(0, k)], b[max(0, k):len(b) - max(0, -k)]) for k in lags])
    i = int(np.argmax(c))
    frac = 0.0
    if 0 < i < len(c) - 1:
        den = c[i - 1] - 2 * c[i] + c[i + 1]
        frac = 0.5 * (c[i - 1] - c[i + 1]) / den if den < 0 else 0.0
    return float((lags[i] + frac) * h)


def responses(r: QuarterCarResult):
    """{name: array} of what is compared: body acceleration [m/s^2], suspension travel
    (damper displacement) [m], tire load [N]."""
    h = r.t[1] - r.t[0]
    return {"body_acc": np.gradient(r.v1, h), "travel": r.damper_x, "tire_load": r.tire_force}


def transmissibility(t, y_in, y, f_lo, f_hi, n_points=40):
    """(f [Hz], |Y/Y_in|) from the cross- and auto-spectra (H1 estimate, Welch segments of
    a quarter of the record), on log-spaced frequencies within [f_lo, f_hi]."""
    from scipy.signal import csd, welch
    fs = 1.0 / (t[1] - t[0])
    nper = max(256, len(t) // 4)
    f, p_xy = csd(y_in, y, fs=fs, nperseg=nper)
    _, p_xx = welch(y_in, fs=fs, nperseg=nper)
    keep = (f >= f_lo) & (f <= f_hi) & (p_xx > 0)
    grid = np.geomspace(f_lo, f_hi, n_points)
    return grid, np.interp(grid, f[keep], np.abs(p_xy[keep]) / p_xx[keep])


def compare(hil: QuarterCarResult, ref: QuarterCarResult) -> dict:
    """{body_acc_nrmse, travel_nrmse, tire_load_nrmse}: each HIL response against the
    reference's."""
    a, b = responses(hil), responses(ref)
    return {f"{k}_nrmse": nrms(a[k], b[k]) for k in a}
