"""Monotube damper: chambers 1 (compression), 2 (rebound) and the gas behind a floating
piston in the same tube (thesis 3.3.3, Figs 3.9-3.12).

Compressible model state y = [P2 (Pa), dV2 (m^3)]: chamber 2 pressure and the oil volume
it stores by compressibility. Chamber 1 sits at the gas pressure (P_G = P1, eq 3.35).
Outputs per step: [F_d, F_G, P1, P2, P_gas].

Sign note: eq 3.36 prints V_c2 = V_c20 - x (A_p - A_r); with x positive in compression the
rebound chamber grows (it is smallest at full extension, Table 4.5 V20 = 6.7 cc), so we
use +x.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .compressibility import bulk_modulus
from .gas_spring import P_ATM
from .kernel import AR, AW, CIB, CSB, KCONST, KMAX, SEATC, SEATF, SEATOPEN, V20, gas_pressure, update_seat
from .stiff import make_integrator
from .valves import bypass_open_at, path_force, path_velocity

NSTATE = 2


def initial_state(prm, x0):
    """At rest: every chamber at the gas pressure for position x0."""
    P = gas_pressure(prm, x0, 0.0)
    return np.array([P, 0.0])


@njit(cache=True)
def rhs(y, x, xd, prm, vp, vh, dydt):
    P2, dV2 = y[0], y[1]
    P1 = gas_pressure(prm, x, dV2)  # eqs 3.38-3.39
    Q12 = prm[AW] * path_velocity((P1 - P2) * prm[AW], vp, prm[SEATC], prm[SEATOPEN] > 0.5)
    net = Q12 - xd * prm[AW]  # eq 3.35: dV_C2/dt = Q12 - Q12inc (eq 3.33)
    V2 = prm[V20] + x * prm[AW]  # eq 3.36
    dydt[0] = bulk_modulus(P2, prm[KCONST], prm[CIB], prm[CSB], prm[KMAX]) / V2 * net  # eq 3.31
    dydt[1] = net  # eq 3.37


@njit(cache=True)
def outputs(y, x, xd, prm, vp, vh, out):
    P2 = y[0]
    P1 = gas_pressure(prm, x, y[1])
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


integrate = make_integrator(rhs, outputs)  # compressible stepper for this assembly (models/stiff.py)
