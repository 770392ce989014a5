"""Remote-reservoir damper: chambers 1, 2 in the body, chamber 3 and the gas in the
reservoir, a compression head (foot valve) between 1 and 3 (thesis 3.3.4, Figs 3.13-3.15).

Compressible model state y = [e1, e2]: the oil chambers 1 and 2 hold beyond their
geometric volumes (m^3, eq 3.50), from which their pressures follow (eqs 3.31-3.32).
Chamber 3 sits at the gas pressure (eq 3.48). Outputs per step: [F_d, F_G, P1, P2,
P_gas (= P3)].
"""
from __future__ import annotations

import numpy as np
from numba import njit

from models.physics.gas_spring import P_ATM
from models.physics.kernel import AP, AR, AW, SEATC, SEATF, SEATOPEN, V10, V20, chamber_pressure, excess_at, gas_pressure, update_seat
from models.physics.valves import bypass_open_at, path_force, path_velocity

NSTATE = 2


def initial_state(prm, x0):
    """At rest at x0: chambers 1 and 2 at the gas pressure."""
    e1 = e2 = 0.0
    for _ in range(20):  # the stored oil shifts the gas pressure slightly: fixed point
        PG = gas_pressure(prm, x0, e1 + e2)
        e1 = excess_at(prm, PG, prm[V10] - x0 * prm[AP])
        e2 = excess_at(prm, PG, prm[V20] + x0 * prm[AW])
    return np.array([e1, e2])


@njit(cache=True)
def _pressures(y, x, prm):
    P1 = chamber_pressure(prm, y[0], prm[V10] - x * prm[AP])  # chamber 1 shrinks by A_p
    P2 = chamber_pressure(prm, y[1], prm[V20] + x * prm[AW])
    PG = gas_pressure(prm, x, y[0] + y[1])  # eqs 3.50-3.52
    return P1, P2, PG


@njit(cache=True)
def rhs(y, x, xd, prm, vp, vh, dydt):
    P1, P2, PG = _pressures(y, x, prm)
    Q12 = prm[AW] * path_velocity((P1 - P2) * prm[AW], vp, prm[SEATC], prm[SEATOPEN] > 0.5)
    Q13 = prm[AR] * path_velocity((P1 - PG) * prm[AR], vh, 0.0, False)
    dydt[0] = xd * prm[AP] - Q12 - Q13  # eq 3.47: chamber 1 loses A_p per unit stroke
    dydt[1] = Q12 - xd * prm[AW]  # eq 3.46


@njit(cache=True)
def outputs(y, x, xd, prm, vp, vh, out):
    P1, P2, PG = _pressures(y, x, prm)
    F12 = (P1 - P2) * prm[AW]
    out[0] = F12 + (P1 - PG) * prm[AR]  # eq 3.55
    out[1] = (PG - P_ATM) * prm[AR]  # eq 3.54 gas term
    out[2], out[3], out[4] = P1, P2, PG
    update_seat(prm, F12)


@njit(cache=True)
def incompressible(x, v, prm, vp, vh, out):
    """Incompressible solution (Fig 3.14): piston flow v A_w, head flow v A_r (eqs 3.44-3.45)."""
    for i in range(x.shape[0]):
        PG = gas_pressure(prm, x[i], 0.0)
        Fp = path_force(v[i], vp, prm[SEATC], bypass_open_at(v[i], vp, prm[SEATC], prm[SEATF]))
        Fh = path_force(v[i], vh, 0.0, False)
        out[i, 0] = Fp + Fh  # eq 3.55
        out[i, 1] = (PG - P_ATM) * prm[AR]
        P1 = PG + Fh / prm[AR]
        out[i, 2], out[i, 3], out[i, 4] = P1, P1 - Fp / prm[AW], PG

