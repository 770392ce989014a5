"""Effective oil compressibility (thesis 3.3.2, 4.2.3).

The tables print the effective *bulk modulus* beta^-1 (entrained air makes it 45-500 MPa,
far below pure oil's 1370 MPa). Pressure-dependent form, eq 3.32 read as a bulk modulus:
K(P) = C_ibeta + C_sbeta * P, capped at beta_min^-1 (the compressibility never drops below
beta_min). P is the chamber's absolute pressure. Units: Pa.
"""
from __future__ import annotations

from numba import njit


@njit(cache=True)
def bulk_modulus(P, K_const, C_ibeta, C_sbeta, K_max):
    """Effective bulk modulus [Pa] at chamber pressure P [Pa], eqs 3.31-3.32.

    K_const > 0 selects the constant model; otherwise the linear pressure model capped at
    K_max. The floor of 1 MPa keeps a (non-physical) negative pressure from flipping sign.
    """
    if K_const > 0.0:
        return K_const
    K = C_ibeta + C_sbeta * P
    if K > K_max:
        K = K_max
    if K < 1e6:
        K = 1e6
    return K

