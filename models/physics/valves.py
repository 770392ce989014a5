"""Valves: orifice, flow-compensating and polynomial restrictions (thesis 3.3.1, 4.2.3).

Physical form (eqs 3.20-3.29): pressure drop dP [Pa] vs flow Q [m^3/s].
Weighted form (eqs 4.12-4.14, Tables 4.5-4.8): the coefficients already include the
working area A_w and the variable is the damper velocity v [m/s] that would pass that
flow, Q = v * A_w, while the force is F = dP * A_w [N]:
    orifice            F = C_orrw  v^2            + C_iorrw
    flow-compensating  F =               C_linw v + C_ilinw
    polynomial         F = C_orrpw v^2 + C_linpw v + C_ipw
Rebound uses the same form with v < 0 and the coefficients printed for rebound
(a negative C_orrpw keeps the force negative).

A valve *path* (piston or compression head) is, per direction, a low-speed restriction
always open, in parallel with a mid-speed valve that passes flow once |F| exceeds its
cracking force |C_ilinw| (eq 3.30): for a given force the velocities add. Optional extras:
a high-speed branch that replaces the mid-speed one beyond their crossover flow (Fox-heavy
rebound, 4.2.3.3), and a bypass seat valve (Mechformance, eqs 4.15-4.16).

Kernel layout: a path is a float array (2, NCOL), row 0 compression and row 1 rebound,
columns below. Everything here is scalar numba code so the ODE right-hand sides can call
it at nanosecond cost.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# columns of a path row
A, B, C, MB, MC, HB, HC, VX, FT = range(9)
NCOL = 9


# --- physical form, eqs 3.20-3.29 -------------------------------------------------------

def orifice_coefficient(Cd, A_eff, rho):
    """C_orr of eq 3.22 from discharge coefficient, effective area [m^2], density [kg/m^3]."""
    return (1.0 / (Cd * A_eff)) ** 2 * rho / 2.0


def flow_compensating_coefficient(Cd, K_v, rho):
    """C_lin of eq 3.25 for a valve whose area grows as K_v sqrt(Q) (eq 3.23)."""
    return (1.0 / (Cd * K_v)) ** 2 * rho / 2.0


def orifice_dp(Q, C_orr, C_ior=0.0):
    """Orifice pressure drop, eq 3.27: dP = C_orr Q^2 + C_ior  [Pa]."""
    return C_orr * np.asarray(Q) ** 2 + C_ior


def flow_compensating_dp(Q, C_lin, C_ilin=0.0):
    """Flow-compensating valve pressure drop, eq 3.28: dP = C_lin Q + C_ilin  [Pa]."""
    return C_lin * np.asarray(Q) + C_ilin


def polynomial_dp(Q, C_orrp, C_linp, C_ip=0.0):
    """Combined orifice and compensating flow, eq 3.29  [Pa]."""
    Q = np.asarray(Q)
    return C_orrp * Q**2 + C_linp * Q + C_ip


# --- weighted-form kernels ---------------------------------------------------------------

@njit(cache=True)
def branch_velocity(F, a, b, c):
    """Velocity share [m/s] of one branch F = a v^2 + b v + c at force F [N].

    No flow until |F| exceeds the constant c (a preload / cracking force). Closed-form
    inverse of eqs 4.12-4.14, written to stay accurate for a = 0 and for b = 0.
    """
    d = F - c
    if d * F <= 0.0:
        return 0.0
    return 2.0 * d / (b + math.sqrt(b * b + 4.0 * abs(a) * abs(d)))


@njit(cache=True)
def path_velocity(F, vp, C_seat, seat_open):
    """Velocity [m/s] whose flow a valve path passes at force F = dP * A_w [N], eq 3.30.

    vp: (2, NCOL) path array with the temperature factor f_FT in column FT (eq 3.62:
    the force at a given flow scales by f_FT). C_seat > 0 adds the bypass (eq 4.16)
    while seat_open is true.
    """
    row = 0 if F >= 0.0 else 1
    Fr = F / vp[row, FT]
    v = branch_velocity(Fr, vp[row, A], vp[row, B], vp[row, C])
    if vp[row, MB] > 0.0:
        vm = branch_velocity(Fr, 0.0, vp[row, MB], vp[row, MC])
        if vp[row, HB] > 0.0 and abs(vm) > abs(vp[row, VX]):
            vm = branch_velocity(Fr, 0.0, vp[row, HB], vp[row, HC])
        v += vm
    if C_seat > 0.0 and seat_open:
        v += Fr / C_seat
    return v


@njit(cache=True)
def bypass_open_at(v, vp, C_seat, F_seat):
    """Incompressible seat rule (eq 4.15): the bypass stays open while the open-branch
    solution keeps the force above the seating force F_seat = dP_seat * A_w."""
    if C_seat <= 0.0:
        return False
    return v >= path_velocity(F_seat, vp, C_seat, True)


@njit(cache=True)
def path_force(v, vp, C_seat, seat_open):
    """Force [N] of a valve path at velocity v [m/s] for incompressible flow: the root
    of path_velocity(F) = v (Fig 3.5), by bracketing and the Illinois method."""
    if v == 0.0:
        return 0.0
    s = 1.0 if v > 0.0 else -1.0
    lo, flo = 0.0, -v
    hi = 100.0 * s
    fhi = path_velocity(hi, vp, C_seat, seat_open) - v
    while fhi * s < 0.0:
        lo, flo = hi, fhi
        hi *= 4.0
        fhi = path_velocity(hi, vp, C_seat, seat_open) - v
        if abs(hi) > 1e9:
            return hi
    side = 0
    for _ in range(200):
        mid = (lo * fhi - hi * flo) / (fhi - flo)
        fm = path_velocity(mid, vp, C_seat, seat_open) - v
        if fm == 0.0 or abs(hi - lo) < 1e-9 * (1.0 + abs(mid)):
            return mid
        if fm * flo > 0.0:
            lo, flo = mid, fm
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi, fhi = mid, fm
            if side == 1:
                flo *= 0.5
            side = 1
    return 0.5 * (lo + hi)

