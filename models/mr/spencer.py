"""Spencer's modified Bouc-Wen model of an MR damper (Spencer, Dyke, Sain and Carlson 1997,
J. Eng. Mech. 123(3), its eqs 4-10), SI units, compression positive:

    F   = c1 y' + k1 x + f0                                    force [N]        (Spencer eq 4)
    z'  = -gamma |x' - y'| z |z|^(n-1) - beta (x' - y') |z|^n + A (x' - y')      (eq 5)
    y'  = (alpha z + c0 x' + k0 (x - y)) / (c0 + c1)           internal travel  (eq 6)
    alpha = alpha_a + alpha_b u,  c1 = c1_a + c1_b u,  c0 = c0_a + c0_b u        (eqs 7-9)
    u'  = -eta (u - v)                                         the coil's lag   (eq 10)

x [m] the rod's displacement, v [V] the command to the coil's driver, u [V] the effective
voltage; k1 x + f0 is Spencer's k1 (x - x0) written with its offset f0 = -k1 x0 [N].
Choices where the paper leaves one (docs/mr-damper.md): n = 2 as Spencer fits it; A fixed
at Spencer's 301 (z's scale is free: A, gamma, beta and alpha trade one for another, so one
is fixed for the rest to be identifiable); the states start at rest (z = 0, y = x, u = v).
Integrated by Heun's method (second order) in substeps, as many in each sample as the yield's
stiffness needs (STABLE), the motion and command interpolated linearly between samples: on
the NEES record's last transient (0.96 m/s through a yield of some 20 um) a fixed four
substeps a sample overflowed, and Euler in two was unstable at Spencer's values anywhere."""
from __future__ import annotations

from dataclasses import astuple, dataclass, fields

import numpy as np
from numba import njit

N_EXP = 2.0  # Spencer's n
A_BW = 301.0  # Spencer's A [-]: fixed, z's scale (see the docstring)
STABLE = 0.1  # lambda dt of a substep: Heun's method is stable to 2, accurate to 1e-4 of the force here


@dataclass
class Spencer:
    """The model's parameters, SI. Bounds (BOUNDS) keep it physical: damping, stiffness and
    the yield's size non-negative at no current and as the current rises."""
    alpha_a: float  # N/m: the Bouc-Wen element's size at u = 0 (z is a length)
    alpha_b: float  # N/(m V): its rise with the effective voltage
    c0_a: float  # N s/m: viscous damping at large velocity, u = 0
    c0_b: float  # N s/(m V)
    c1_a: float  # N s/m: the damping that rolls the force off at low velocity, u = 0
    c1_b: float  # N s/(m V)
    k0: float  # N/m: the series stiffness (controls the loop's width at large velocity)
    k1: float  # N/m: the accumulator's stiffness
    f0: float  # N: the force at x = 0 with the rest at rest (-k1 x0)
    gamma: float  # 1/m^2: the yield's shape (with beta)
    beta: float  # 1/m^2
    eta: float  # 1/s: the coil's first-order lag (eq 10)


NAMES = tuple(f.name for f in fields(Spencer))
UNITS = {"alpha_a": "N/m", "alpha_b": "N/(m V)", "c0_a": "N s/m", "c0_b": "N s/(m V)", "c1_a": "N s/m",
         "c1_b": "N s/(m V)", "k0": "N/m", "k1": "N/m", "f0": "N", "gamma": "1/m^2", "beta": "1/m^2", "eta": "1/s"}
# Spencer et al. 1997's fitted values of their prototype (Table 1, converted to SI): starts and a reference
SPENCER_1997 = Spencer(alpha_a=14000.0, alpha_b=69500.0, c0_a=2100.0, c0_b=350.0, c1_a=28300.0, c1_b=295.0,
                       k0=4690.0, k1=500.0, f0=0.0, gamma=3.63e6, beta=3.63e6, eta=190.0)
BOUNDS = {"alpha_a": (0.0, 1e7), "alpha_b": (0.0, 1e7), "c0_a": (0.0, 1e6), "c0_b": (0.0, 1e6),
          "c1_a": (1.0, 1e8), "c1_b": (0.0, 1e8), "k0": (0.0, 1e7), "k1": (-1e6, 1e6), "f0": (-1e5, 1e5),
          "gamma": (0.0, 1e10), "beta": (1.0, 1e10), "eta": (1.0, 1e4)}


@njit(cache=True)
def _rates(z, y, u, x, xd, v, p):
    a = p[0] + p[1] * u  # eqs 7-9
    c0 = p[2] + p[3] * u
    c1 = p[4] + p[5] * u
    yd = (a * z + c0 * xd + p[6] * (x - y)) / (c0 + c1)  # eq 6
    w = xd - yd
    zd = -p[9] * abs(w) * z * abs(z) ** (N_EXP - 1.0) - p[10] * w * abs(z) ** N_EXP + A_BW * w  # eq 5
    ud = -p[11] * (u - v)  # eq 10
    return zd, yd, ud, c1


@njit(cache=True)
def _stiffness(z, u, xd, y_rate, p):
    """|d(rates)/d(state)| bounded from above [1/s]: the step Heun's method is stable in."""
    a, c0, c1 = p[0] + p[1] * u, p[2] + p[3] * u, p[4] + p[5] * u
    w = abs(xd - y_rate)
    return ((abs(p[9]) + abs(p[10])) * N_EXP * w * abs(z) ** (N_EXP - 1.0) + A_BW * abs(a) / (c0 + c1)
            + p[6] / (c0 + c1) + p[11])


@njit(cache=True)
def _simulate(x, xd, v, h, p, stable):
    n = len(x)
    F = np.empty(n)
    z, y, u = 0.0, x[0], v[0]
    for i in range(n):
        j = min(i + 1, n - 1)
        zd, yd, ud, c1 = _rates(z, y, u, x[i], xd[i], v[i], p)
        F[i] = c1 * yd + p[7] * x[i] + p[8]  # eq 4, at the sample
        # substeps where the yield is stiff (a fast stroke through a narrow yield): lambda dt <= stable
        lam = max(_stiffness(z, u, xd[i], yd, p), _stiffness(z, u, xd[j], yd, p))
        m = min(max(int(np.ceil(h * lam / stable)), 2), 4096)
        dt = h / m
        for s in range(m):
            f0, f1 = s / m, (s + 1.0) / m
            xa, xda, va = x[i] + f0 * (x[j] - x[i]), xd[i] + f0 * (xd[j] - xd[i]), v[i] + f0 * (v[j] - v[i])
            xb, xdb, vb = x[i] + f1 * (x[j] - x[i]), xd[i] + f1 * (xd[j] - xd[i]), v[i] + f1 * (v[j] - v[i])
            if s > 0:
                zd, yd, ud, c1 = _rates(z, y, u, xa, xda, va, p)
            # Heun: Euler's predictor, the trapezoid's corrector
            z1, y1, u1 = z + dt * zd, y + dt * yd, u + dt * ud
            zd1, yd1, ud1, _ = _rates(z1, y1, u1, xb, xdb, vb, p)
            z += 0.5 * dt * (zd + zd1)
            y += 0.5 * dt * (yd + yd1)
            u += 0.5 * dt * (ud + ud1)
    return F


def force(m: Spencer, x, x_dot, v_cmd, h, stable=STABLE):
    """The model's force [N] along displacement x [m], its velocity x_dot [m/s] and the coil's
    command v_cmd [V], sampled every h [s]."""
    return _simulate(np.ascontiguousarray(x, float), np.ascontiguousarray(x_dot, float),
                     np.ascontiguousarray(v_cmd, float), float(h), np.array(astuple(m), float), float(stable))
