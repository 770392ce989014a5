"""The minimal baseline's valves (thesis eq 3.26, 3.27, 3.30): a two-stage asymmetric
valve curve, low- and mid-speed paths in parallel, per direction, and its exact derivatives
in its parameters (the diagnosis's fits read them instead of differences). Compiled (numba);
speeds in m/s, forces in N, compression positive."""
from __future__ import annotations

import numpy as np
from numba import njit

from models.diagnose import kernels


@njit(cache=True, nogil=True)
def _magnitude(v, c1, c2, C, Fcr):
    """Force magnitude [N] at speed v >= 0 [m/s] of low (c1 v + c2 v^2) and mid
    ((F - Fcr)/C) paths in parallel, eq 3.30. Above the cracking force the low path's speed
    w solves c1 w + c2 w^2 = Fcr + C (v - w), a quadratic whose root is taken in the form
    with no difference of near equals: the form in F it replaces subtracted c1^2 from about
    c1^2 and, with c2 near zero (where many fits end), lost the cracking force's effect
    below the last bit and the cost surface with it."""
    FL = c1 * v + c2 * v * v
    if not FL > Fcr:  # (a nan stays nan)
        return FL
    b, q = c1 + C, Fcr + C * v
    w = 2 * q / (b + np.sqrt(b * b + 4 * c2 * q))
    return max(Fcr + C * (v - w), Fcr)


@njit(cache=True, nogil=True)
def _direction(v, c1, c2, C, Fcr):
    """_magnitude along speeds v [m/s]."""
    out = np.empty(len(v))
    for i in range(len(v)):
        out[i] = _magnitude(v[i], c1, c2, C, Fcr)
    return out


@njit(cache=True, nogil=True)
def _magnitude_grad(v, c1, c2, C, Fcr, out, k, i, sign):
    """sign times _magnitude's derivatives in (c1, c2, C, Fcr), written into out[k:k + 4, i].
    Below the cracking force F = c1 v + c2 v^2; above it F solves v = v_L(F) + (F - Fcr) / C
    (eq 3.30), whose derivatives follow by the implicit function theorem: with
    v_L = v - (F - Fcr) / C and S = c1 + 2 c2 v_L (dF/dv_L of the low path),
    dF/dq = -(dG/dq) / (1 / S + 1 / C)."""
    if not c1 * v + c2 * v * v > Fcr:
        out[k, i], out[k + 1, i] = sign * v, sign * v * v
        return
    F = _magnitude(v, c1, c2, C, Fcr)
    if F <= Fcr:  # held at the cracking force
        out[k + 3, i] = sign
        return
    vL = max(v - (F - Fcr) / C, 0.0)
    S = max(c1 + 2 * c2 * vL, 1e-30)
    D = sign / (1.0 / S + 1.0 / C)
    out[k, i], out[k + 1, i] = vL / S * D, vL * vL / S * D
    out[k + 2, i], out[k + 3, i] = (F - Fcr) / (C * C) * D, 1.0 / C * D


@njit(cache=True, nogil=True)
def damping_grad(v, c1_c, c2_c, C_c, Fcr_c, c1_r, c2_r, C_r, Fcr_r):
    """The damping force's derivatives in VALVES' parameters along v: (8, len(v)), one
    row per parameter (a column of the fit's Jacobian each)."""
    out = np.zeros((8, len(v)))
    for i in range(len(v)):
        s = v[i]
        if s >= 0:
            _magnitude_grad(s, c1_c, c2_c, C_c, Fcr_c, out, 0, i, 1.0)
        else:
            _magnitude_grad(-s, c1_r, c2_r, C_r, Fcr_r, out, 4, i, -1.0)
    return out


VALVES = ("c1_c", "c2_c", "C_c", "Fcr_c", "c1_r", "c2_r", "C_r", "Fcr_r")  # damping's parameters, in order


@njit(cache=True, nogil=True)
def _damping(v, c1_c, c2_c, C_c, Fcr_c, c1_r, c2_r, C_r, Fcr_r):
    out = np.empty(len(v))
    for i in range(len(v)):
        s = v[i]
        out[i] = _magnitude(s, c1_c, c2_c, C_c, Fcr_c) if s >= 0 else -_magnitude(-s, c1_r, c2_r, C_r, Fcr_r)
    return out


_damping_recent = kernels.recent(_damping)


def damping(v: np.ndarray, p: dict) -> np.ndarray:
    """Damping force [N], positive in compression, from velocity v [m/s]."""
    return _damping_recent(v, *(p[k] for k in VALVES))


@kernels.recent
def _slope_of(v, *valves):
    dv = 1e-3  # m/s: the finite difference
    return np.abs(_damping(v + dv, *valves) - _damping(v - dv, *valves)) / (2 * dv)


def slope(v: np.ndarray, p: dict) -> np.ndarray:
    """Local slope dF/dv of the damping curve [N s/m] (finite difference)."""
    return _slope_of(v, *(p[k] for k in VALVES))


@njit(cache=True, nogil=True)
def _slope_grad(v, c1_c, c2_c, C_c, Fcr_c, c1_r, c2_r, C_r, Fcr_r):
    """slope's derivatives, (8, len(v)): the difference of damping_grad's over slope's own
    step, signed as the difference of the forces (slope is its size)."""
    dv = 1e-3  # m/s, slope's step
    out = np.zeros((8, len(v)))
    up, dn = np.zeros((8, 1)), np.zeros((8, 1))
    for i in range(len(v)):
        for q in range(8):
            up[q, 0] = 0.0
            dn[q, 0] = 0.0
        a, b = v[i] + dv, v[i] - dv
        Fa = _magnitude(a, c1_c, c2_c, C_c, Fcr_c) if a >= 0 else -_magnitude(-a, c1_r, c2_r, C_r, Fcr_r)
        Fb = _magnitude(b, c1_c, c2_c, C_c, Fcr_c) if b >= 0 else -_magnitude(-b, c1_r, c2_r, C_r, Fcr_r)
        if a >= 0:
            _magnitude_grad(a, c1_c, c2_c, C_c, Fcr_c, up, 0, 0, 1.0)
        else:
            _magnitude_grad(-a, c1_r, c2_r, C_r, Fcr_r, up, 4, 0, -1.0)
        if b >= 0:
            _magnitude_grad(b, c1_c, c2_c, C_c, Fcr_c, dn, 0, 0, 1.0)
        else:
            _magnitude_grad(-b, c1_r, c2_r, C_r, Fcr_r, dn, 4, 0, -1.0)
        sign = 1.0 if Fa > Fb else -1.0 if Fa < Fb else 0.0
        for q in range(8):
            out[q, i] = sign * (up[q, 0] - dn[q, 0]) / (2 * dv)
    return out


_slope_grad_recent = kernels.recent(_slope_grad)


def slope_grad(v: np.ndarray, p: dict) -> np.ndarray:
    """slope's derivatives in VALVES' parameters [N s/m per unit]: (8, len(v))."""
    return _slope_grad_recent(v, *(p[k] for k in VALVES))
