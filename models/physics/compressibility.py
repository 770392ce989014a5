"""Effective oil compressibility (thesis 3.3.2, 4.2.3).

The tables print the effective *bulk modulus* beta^-1 (entrained air makes it 45-500 MPa,
far below pure oil's 1370 MPa). Pressure-dependent form, eq 3.32 read as a bulk modulus:
K(P) = C_ibeta + C_sbeta * P, capped at beta_min^-1 (the compressibility never drops below
beta_min). P is the chamber's absolute pressure. Units: Pa.

The chamber models keep the *oil* a chamber holds as their state and get the pressure
from it: integrating eq 3.31, dP / K(P) = d(ln rho), over a chamber of volume V holding
oil of reference volume u gives
    strain(P) = integral_{P_ref}^{P} dP / K(P) = ln(u / V).
Using the oil content rather than the pressure as the state conserves oil mass exactly;
integrating dP/dt = K/V * net inflow instead drops the term from V changing with stroke
and lets oil creep from one side of the piston to the other cycle after cycle.

Entrained air (the cause section 3.3.2 gives for the low effective moduli; its form is our
choice, the thesis fits only eq 3.32): free air of volume fraction phi at atmospheric
pressure P_atm, compressed isothermally, in oil of constant modulus K. Its volume at P is
phi P_atm / P, so 1 / K_eff(P) = 1 / K + A / P^2 with A = phi P_atm [Pa]: soft at low
pressure, the oil's own modulus at high (held below AIR_P_MIN).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def bulk_modulus(P, K_const, C_ibeta, C_sbeta, K_max):
    """Effective bulk modulus [Pa] at chamber pressure P [Pa], eq 3.32.

    K_const > 0 selects the constant model; otherwise the linear pressure model capped at
    K_max (valid while C_ibeta + C_sbeta P > 0)."""
    if K_const > 0.0:
        return K_const
    return min(C_ibeta + C_sbeta * P, K_max)


@njit(cache=True)
def _log_ratio(a, b, P1, P2):
    return math.log((a + b * P2) / (a + b * P1)) / b


@njit(cache=True)
def strain(P, P_ref, K_const, a, b, K_max):
    """integral of dP / K(P) from P_ref to P [-] (eqs 3.31-3.32)."""
    if K_const > 0.0:
        return (P - P_ref) / K_const
    Pc = (K_max - a) / b  # pressure where the cap starts
    if P_ref <= Pc:
        if P <= Pc:
            return _log_ratio(a, b, P_ref, P)
        return _log_ratio(a, b, P_ref, Pc) + (P - Pc) / K_max
    if P >= Pc:
        return (P - P_ref) / K_max
    return (Pc - P_ref) / K_max + _log_ratio(a, b, Pc, P)


@njit(cache=True)
def strains(P, P_ref, K_const, a, b, K_max):
    """`strain` at each pressure of the array P [Pa]."""
    out = np.empty(P.shape[0])
    for i in range(P.shape[0]):
        out[i] = strain(P[i], P_ref, K_const, a, b, K_max)
    return out


P_ATM = 101325.0  # Pa
# Below this the entrained air's modulus is held at its value here (a choice: the air would
# otherwise expand without bound as the pressure falls, and the chamber model has no
# solution; cavitation, not air, governs that range)
AIR_P_MIN = 2e5  # Pa


@njit(cache=True)
def _air_strain(P, K, A):
    """integral of dP / K_eff from AIR_P_MIN to P [-], 1 / K_eff = 1/K + A / max(P, AIR_P_MIN)^2."""
    if P >= AIR_P_MIN:
        return (P - AIR_P_MIN) / K + A * (1.0 / AIR_P_MIN - 1.0 / P)
    return (P - AIR_P_MIN) * (1.0 / K + A / (AIR_P_MIN * AIR_P_MIN))


@njit(cache=True)
def strain_air(P, P_ref, K, A):
    """integral of dP / K_eff(P) from P_ref to P [-] with entrained air A = phi P_atm [Pa]."""
    return _air_strain(P, K, A) - _air_strain(P_ref, K, A)


@njit(cache=True)
def pressure_air(lam, P_ref, K, A):
    """Inverse of `strain_air` [Pa]: above AIR_P_MIN the positive root of
    P^2 - b P - K A = 0, below it linear."""
    g = lam + _air_strain(P_ref, K, A)
    if g < 0.0:
        return AIR_P_MIN + g / (1.0 / K + A / (AIR_P_MIN * AIR_P_MIN))
    b = AIR_P_MIN + K * g - K * A / AIR_P_MIN
    r = math.sqrt(b * b + 4.0 * K * A)
    return 0.5 * (b + r) if b >= 0.0 else 2.0 * K * A / (r - b)


def cap_point(P_ref, K_const, a, b, K_max):
    """(Pc, strain at Pc): where the pressure-dependent modulus reaches its cap. Computed
    once per run so that `pressure` costs one exp."""
    if K_const > 0.0:
        return 0.0, 0.0
    Pc = (K_max - a) / b
    return Pc, strain(Pc, P_ref, K_const, a, b, K_max)


@njit(cache=True)
def pressure(lam, P_ref, K_const, a, b, K_max, Pc, Gc):
    """Inverse of `strain`: the pressure [Pa] at which oil strained by lam = ln(u/V).
    (Pc, Gc) from `cap_point`."""
    if K_const > 0.0:
        return P_ref + K_const * lam
    if P_ref <= Pc:
        if lam <= Gc:
            return ((a + b * P_ref) * math.exp(b * lam) - a) / b
        return Pc + (lam - Gc) * K_max
    if lam >= Gc:
        return P_ref + lam * K_max
    return ((a + b * Pc) * math.exp(b * (lam - Gc)) - a) / b
