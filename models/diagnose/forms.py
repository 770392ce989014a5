"""Small forms the baseline and the effects share: a friction's softened sign, a signal
delayed, a part's derivatives scaled, parameters that do not depend on the data."""
from __future__ import annotations

import numpy as np

from models.diagnose import kernels
from models.diagnose.spec import V_EPS


@kernels.recent
def soft_sign(v):
    """A friction's direction, softened over V_EPS [m/s]."""
    return np.tanh(v / V_EPS)


@kernels.recent
def shift(y, t, tau):
    """y [any unit] at t - tau [s] (linear between samples)."""
    return np.interp(t - tau, t, y)


def scaled(cols, part, g):
    """A part multiplied by g: its derivatives too ({part: {parameter: column}}, in place)."""
    cols[part] = {k: c * g for k, c in cols[part].items()}


def fixed(*ps):
    """An effect's parameters, the same whatever the data: Effect.params."""
    return lambda d, e: list(ps)
