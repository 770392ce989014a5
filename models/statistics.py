"""How well a fit fits, and how well its parameters are known: the statistics every
identification and diagnosis shares."""
from __future__ import annotations

import numpy as np


def nrmse(F_model, F_meas):
    """RMS error over the measured force's peak-to-peak range [-]."""
    return float(np.sqrt(np.mean((F_model - F_meas) ** 2)) / max(np.ptp(F_meas), 1e-9))


def covariance(jac, residual):
    """(standard deviations, correlation matrix) of least-squares parameters from the
    Jacobian: the residual variance per effective independent sample (neighbouring
    samples' errors are correlated; one independent error per sign change of the
    residual). A parameter without influence on the fit gets an infinite deviation."""
    J, r = np.asarray(jac), np.asarray(residual)
    n, p = J.shape
    n_eff = max(int(np.sum(np.diff(np.sign(r)) != 0)), p + 1)
    norms = np.linalg.norm(J, axis=0)
    live = norms > 1e-6 * max(norms.max(), 1e-300)
    sd = np.full(p, np.inf)
    rho = np.zeros((p, p))
    if live.any():
        Jl = J[:, live]
        # sigma^2 (J^T J)^-1 with the residual variance counted per independent error
        cov = (r @ r) / max(n_eff - p, 1) * np.linalg.pinv(Jl.T @ Jl)
        var = np.diag(cov)
        # pinv gives a direction the data does not see no variance at all: not "exact"
        sdl = np.where(var > 0, np.sqrt(np.abs(var)), np.inf)
        sd[live] = sdl
        with np.errstate(invalid="ignore", divide="ignore"):
            rho[np.ix_(live, live)] = np.clip(np.nan_to_num(cov / np.outer(sdl, sdl)), -1.0, 1.0)
    return sd, rho
