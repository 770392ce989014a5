"""Simplified asymmetric damper models I and II (thesis 6.4, eqs 6.1-6.2, Table 6.7).

Damping only: no gas spring, friction, compliance or temperature. Velocity in m/s,
compression positive; force in N.
"""
from __future__ import annotations

import numpy as np


def _direction(v, d):
    """One side of eq 6.2: c_low up to the transition velocity alpha, then c_mid."""
    if d.v_transition is None:  # model I, eq 6.1
        return d.c_low * v
    a = d.v_transition
    return np.where(np.abs(v) <= abs(a), d.c_low * v, d.c_low * a + d.c_mid * (v - a))


def force(damper, v):
    v = np.asarray(v, float)
    return np.where(v >= 0, _direction(v, damper.compression), _direction(v, damper.rebound))
