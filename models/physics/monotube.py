"""Monotube damper: chambers 1 (compression), 2 (rebound) and the gas behind a floating
piston in the same tube (thesis 3.3.3, Figs 3.9-3.12).

Compressible model state y = [e2]: the oil chamber 2 holds beyond its geometric volume
(m^3, eq 3.37's dV_12), from which its pressure follows (eqs 3.31-3.32). Chamber 1 sits at
the gas pressure (P_G = P1, eq 3.35) and the oil stored in chamber 2 frees gas volume
(eq 3.38). Outputs per step: [F_d, F_G, P1, P2, P_gas].

Sign note: eq 3.36 prints V_c2 = V_c20 - x (A_p - A_r); with x positive in compression the
rebound chamber grows (it is smallest at full extension, Table 4.5 V20 = 6.7 cc), so we
use +x.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from models.physics.gas_spring import P_ATM
from models.physics.kernel import AR, AW, SEATC, SEATF, SEATOPEN, V20, chamber_pressure, excess_at, gas_pressure, update_seat
from models.physics.valves import bypass_open_at, path_force, path_velocity

NSTATE = 1


def initial_state(prm, x0):
    """At rest at x0: chamber 2 at the gas pressure."""
    e = 0.0
    for _ in range(20):  # the stored oil shifts the gas pressure slightly: fixed point
        e = excess_at(prm, gas_pressure(prm, x0, e), prm[V20] + x0 * prm[AW])
    return np.array([e])


@njit(cache=True)
def _pressures(y, x, prm):
    P1 = gas_pressure(prm, x, y[0])  # eqs 3.38-3.39
    P2 = chamber_pressure(prm, y[0], prm[V20] + x * prm[AW])  # eqs 3.31, 3.36
    return P1, P2


@njit(cache=True)
def rhs(y, x, xd, prm, vp, vh, dydt):
    P1, P2 = _pressures(y, x, prm)
    Q12 = prm[AW] * path_velocity((P1 - P2) * prm[AW], vp, prm[SEATC], prm[SEATOPEN] > 0.5)
    dydt[0] = Q12 - xd * prm[AW]  # eq 3.35: dV_C2/dt = Q12 - Q12inc (eq 3.33)


@njit(cache=True)
def outputs(y, x, xd, prm, vp, vh, out):
    P1, P2 = _pressures(y, x, prm)
    out[0] = (P1 - P2) * prm[AW]  # eq 3.42
    out[1] = (P1 - P_ATM) * prm[AR]  # eq 3.4 with P_G = P1
    out[2], out[3], out[4] = P1, P2, P1
    update_seat(prm, out[0])


@njit(cache=True)
def incompressible(x, v, prm, vp, vh, out):
    """Incompressible solution (Fig 3.12): rows of out as in `outputs`."""
    for i in range(x.shape[0]):
        P1 = gas_pressure(prm, x[i], 0.0)
        Fd = path_force(v[i], vp, prm[SEATC], bypass_open_at(v[i], vp, prm[SEATC], prm[SEATF]))
        out[i, 0] = Fd  # eqs 3.33, 3.42
        out[i, 1] = (P1 - P_ATM) * prm[AR]
        out[i, 2], out[i, 3], out[i, 4] = P1, P1 - Fd / prm[AW], P1

