"""Flat numeric layout of a damper for the compiled assembly kernels.

A Damper (plain data) is packed once per run into a float vector `prm` plus one
(2, NCOL) array per valve path; temperature enters here (gas equilibrium, eqs 4.4-4.5;
damping factor, eq 4.17), so a run at constant temperature costs nothing extra per step.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from models.physics import gas_spring, temperature, valves
from models.physics.compressibility import P_ATM, cap_point, pressure, pressure_air, strain, strain_air
from models.damper import Damper, Direction, ValvePath, check_temperature

(AP, AR, AW, V10, V20, XE, VXE, PXE, GAMMA,
 KCONST, CIB, CSB, KMAX, KPC, KGC, SEATC, SEATF, SEATOPEN, KAIR) = range(19)
NPRM = 19


def _direction_row(d: Direction, f_T: float) -> np.ndarray:
    row = np.zeros(valves.NCOL)
    row[[valves.A, valves.B, valves.C]] = d.low.C_orrpw, d.low.C_linpw, d.low.C_ipw
    if d.mid is not None:
        row[valves.MB], row[valves.MC] = d.mid.C_linw, d.mid.C_ilinw
    if d.high is not None:
        row[valves.HB], row[valves.HC] = d.high.C_linw, d.high.C_ilinw
        row[valves.VX] = (d.high.C_ilinw - d.mid.C_ilinw) / (d.mid.C_linw - d.high.C_linw)
    row[valves.FT] = f_T
    return row


def pack_path(p: ValvePath | None, f_comp: float, f_reb: float) -> np.ndarray:
    if p is None:  # a path that passes no flow is never called; keep a valid array
        out = np.zeros((2, valves.NCOL))
        out[:, valves.B] = 1.0
        out[:, valves.FT] = 1.0
        return out
    return np.stack([_direction_row(p.compression, f_comp), _direction_row(p.rebound, f_reb)])


def pack(d: Damper, T: float, x_e: float, T_gas: float | None = None):
    """(prm, piston path, head path) for a run at temperature T [K] about x_e [m]; the gas
    charge at T_gas [K] if it differs from the oil's (default T)."""
    check_temperature(d, T)
    T_gas = T if T_gas is None else T_gas
    geo, g, c, ts = d.geometry, d.gas_spring, d.compressibility, d.temperature
    prm = np.zeros(NPRM)
    prm[AP], prm[AR], prm[AW] = geo.A_p, geo.A_r, geo.A_w
    prm[V10], prm[V20] = geo.V_total - geo.V20, geo.V20
    V_e, P_e = gas_spring.equilibrium_state(x_e, T_gas, g.P0, g.V0, g.T0, geo.A_r, g.K_voil, g.K_voint)
    prm[XE], prm[VXE], prm[PXE], prm[GAMMA] = x_e, V_e, P_e, g.gamma
    if c.beta_inv is not None:
        prm[KCONST] = c.beta_inv
        prm[KAIR] = c.air_fraction * P_ATM
    else:
        prm[CIB], prm[CSB], prm[KMAX] = c.C_ibeta, c.C_sbeta, c.beta_min_inv
    prm[KPC], prm[KGC] = cap_point(P_e, prm[KCONST], prm[CIB], prm[CSB], prm[KMAX])
    if d.valves.bypass is not None:
        prm[SEATC], prm[SEATF] = d.valves.bypass.C_seatw, d.valves.bypass.dP_seat_Aw
    prm[SEATOPEN] = 1.0
    f_c = float(temperature.damping_factor(T, ts.T_ref, ts.compression.K_effoil, ts.compression.C_fd))
    f_r = float(temperature.damping_factor(T, ts.T_ref, ts.rebound.K_effoil, ts.rebound.C_fd))
    return prm, pack_path(d.valves.piston, f_c, f_r), pack_path(d.valves.head, f_c, f_r)


@njit(cache=True)
def gas_pressure(prm, x, dV):
    """Gas pressure [Pa] with the oil stored by compressibility dV [m^3] in the other
    chambers freeing gas volume, eqs 3.38-3.39 (monotube) and 3.51-3.52 (remote)."""
    V = prm[VXE] - (x - prm[XE]) * prm[AR] + dV
    V = max(V, 1e-3 * prm[VXE])
    return prm[PXE] * (prm[VXE] / V) ** prm[GAMMA]


@njit(cache=True)
def chamber_pressure(prm, excess, V):
    """Pressure [Pa] of a chamber of volume V [m^3] holding `excess` m^3 of oil beyond V
    (at the run's reference pressure, the gas equilibrium pressure): eqs 3.31-3.32."""
    lam = math.log1p(max(excess / V, -0.5))
    if prm[KAIR] > 0.0:
        return pressure_air(lam, prm[PXE], prm[KCONST], prm[KAIR])
    return pressure(lam, prm[PXE], prm[KCONST], prm[CIB], prm[CSB], prm[KMAX], prm[KPC], prm[KGC])


@njit(cache=True)
def excess_at(prm, P, V):
    """Oil beyond the chamber volume V [m^3] that puts the chamber at pressure P."""
    if prm[KAIR] > 0.0:
        return V * math.expm1(strain_air(P, prm[PXE], prm[KCONST], prm[KAIR]))
    return V * math.expm1(strain(P, prm[PXE], prm[KCONST], prm[CIB], prm[CSB], prm[KMAX]))


@njit(cache=True)
def update_seat(prm, F12):
    """Bypass disc state between steps (eq 4.15): seats when the piston force drops
    below dP_seat * A_w, lifts again once it rises above it."""
    if prm[SEATC] > 0.0:
        if prm[SEATOPEN] > 0.5 and F12 < prm[SEATF]:
            prm[SEATOPEN] = 0.0
        elif prm[SEATOPEN] < 0.5 and F12 > prm[SEATF]:
            prm[SEATOPEN] = 1.0
