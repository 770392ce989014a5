"""Calibration of geometry the thesis leaves unstated, against numbers it does give.

The rod diameter sets how a gas-pressure rise becomes a force. Sections 2.2.2 and 4.3
quote gas-force / bias rises with temperature at mid-stroke; we solve eq 4.3 at the
equilibrium point (x = x_e = mid-stroke, isothermal rest, eqs 4.4-4.5) for the rod area
that reproduces them. models/presets/ASSUMPTIONS.md records the results.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from models.physics import gas_spring


def gas_rise(A_r, T1, T2, x_mid, P0, V0, T0, K_voil, K_voint):
    """Gas-force rise [N] at mid-stroke from T1 to T2 [K] (eqs 4.3-4.5 at x = x_e)."""
    F = [gas_spring.static_force(x_mid, T, P0, V0, T0, A_r, K_voil, K_voint) for T in (T1, T2)]
    return float(F[1] - F[0])


def rod_area_for_rise(target, T1, T2, stroke, P0, V0, T0, K_voil, K_voint):
    """Rod area [m^2] whose mid-stroke gas-force rise from T1 to T2 equals target [N]."""
    f = lambda A: gas_rise(A, T1, T2, stroke / 2, P0, V0, T0, K_voil, K_voint) - target
    return brentq(f, 1e-5, 0.9 * V0 / stroke)


def diameter(area):
    return float(np.sqrt(4 * area / np.pi))
