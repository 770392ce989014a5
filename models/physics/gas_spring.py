"""Gas spring: nitrogen charge behind the floating piston (thesis 3.2.2, 4.2.2.2).

Units: pressures in Pa absolute, volumes in m^3, areas in m^2, displacement x in m
from full extension (compression positive), temperatures in K, forces in N.

Sign note: the thesis prints eqs 3.18/3.19/4.3 with (x_e - x); with x positive in
compression the gas volume must *shrink* as x grows, so we use (x - x_e). Every other
equation is as printed.
"""
from __future__ import annotations

import numpy as np

from models.damper import T_STD

P_ATM = 101_325.0  # Pa


def force_from_pressure(P, A_r):
    """Gas spring force from gas pressure, eq 3.4: F_G = (P - P_atm) * A_r  [N]."""
    return (np.asarray(P) - P_ATM) * A_r


def pressure_from_force(F_G, A_r):
    """Inverse of eq 3.4 (eq 3.13): P = F_G / A_r + P_atm  [Pa]."""
    return np.asarray(F_G) / A_r + P_ATM


def isothermal_pressure(x, P0, V0, A_r):
    """Static isothermal gas pressure, eqs 3.5-3.6: P_x = P0 V0 / (V0 - x A_r)  [Pa]."""
    return P0 * V0 / (V0 - np.asarray(x) * A_r)


def thermal_volume_change(T, K_voil, K_voint=0.0):
    """Oil (and component) volume growth with temperature, eqs 3.8 and 3.15  [m^3].

    dV = dT * K_voil + K_voint, dT = T - 20 C; K_voil in m^3/K, K_voint in m^3.
    """
    return (np.asarray(T) - T_STD) * K_voil + K_voint


def equilibrium_state(x_e, T, P0, V0, T0, A_r, K_voil, K_voint=0.0):
    """Gas volume and pressure at rest at x_e and temperature T, eqs 4.4 and 4.5.

    Returns (V_xeT [m^3], P_xeT [Pa]). The isothermal equilibrium is the thesis's
    quasi-static thermal balance: the damper rested long enough at x_e.
    """
    V = V0 - np.asarray(x_e) * A_r - thermal_volume_change(T, K_voil, K_voint)  # eq 4.4
    P = P0 * V0 / V * (np.asarray(T) / T0)  # eq 4.5
    return V, P


def polytropic_pressure(x, x_e, V_xeT, P_xeT, A_r, gamma, dV_oil=0.0):
    """Dynamic gas pressure about the equilibrium point, eqs 3.17-3.18 and 3.38/3.51  [Pa].

    dV_oil is the oil volume stored by compressibility in the chambers (eq 3.37/3.50):
    compressed oil frees gas volume.
    """
    V = V_xeT - (np.asarray(x) - x_e) * A_r + dV_oil  # eq 3.18 (sign corrected), 3.38
    return P_xeT * (V_xeT / V) ** gamma  # eq 3.17 / 3.39


def static_force(x, T, P0, V0, T0, A_r, K_voil, K_voint=0.0):
    """Isothermal (static) gas spring force with oil expansion, eq 3.16  [N]."""
    _, P = equilibrium_state(x, T, P0, V0, T0, A_r, K_voil, K_voint)
    return force_from_pressure(P, A_r)


def fit_charge(x, F_G, A_r):
    """Recover P0, V0 from static gas-force data by the linear regression of eq 3.7.

    1/P_x = -(A_r / (P0 V0)) x + 1/P0. Returns (P0 [Pa], V0 [m^3], r2).
    """
    inv_P = 1.0 / pressure_from_force(F_G, A_r)
    slope, intercept = np.polyfit(np.asarray(x, float), inv_P, 1)
    P0 = 1.0 / intercept
    V0 = -A_r / (slope * P0)
    resid = inv_P - (slope * np.asarray(x) + intercept)
    r2 = 1.0 - resid.var() / inv_P.var()
    return P0, V0, r2


def fit_thermal_expansion(T, F_GxeT, x_e, P0, V0, T0, A_r):
    """Recover K_voil, K_voint from mid-stroke gas force vs temperature, eq 4.6.

    Returns (K_voil [m^3/K], K_voint [m^3]).
    """
    T = np.asarray(T, float)
    lhs = V0 - x_e * A_r - P0 * V0 * T / (pressure_from_force(F_GxeT, A_r) * T0)  # eq 4.6
    K_voil, K_voint = np.polyfit(T - T_STD, lhs, 1)
    return K_voil, K_voint
