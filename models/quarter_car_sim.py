"""Time-domain quarter car (thesis eqs 5.3-5.14) driven by a damper force from any source.

Coordinates are deviations from static equilibrium, positive up [m]: y1 sprung, y2
unsprung, y_in road; z1 = y1 - y2, z2 = y2 - y_in. The damper is compressed by
x = x_install - z1 (eq 5.5) and its force F(x, v) is positive in compression: it pushes
the sprung mass up and the unsprung mass down. `damper_force(x, v) -> F` is called once
per step, so the same loop can run with a damper model or, in hardware-in-the-loop, with
the force the load cell measured for the motion commanded on the previous tick.

Integration: fixed-step semi-implicit (symplectic) Euler with Moreau-style implicit
Coulomb friction. Each step's friction forces are solved at the *new* velocities from the
set-valued law (|f| <= F_c while stuck, f = -F_c sgn(w) while sliding) by projected
Gauss-Seidel, so sticking is exact and cannot chatter, and no stick/slip event can be
missed. Tire lift-off (eq 5.9), spring unloading (eq 5.10) and the limit stops
(eqs 5.6-5.8, stiff springs) are piecewise-linear forces evaluated each step; with the
0.1 ms default step a stop of 10 MN/m is resolved with 130 steps per period of its
contact oscillation.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import friction, simplified
from .damper import SimplifiedDamper, load
from .kernel import pack
from .quarter_car import G, QuarterCar, static_deflections
from .simulate import ASSEMBLY, ATOL_OIL

K_STOP = 1e7  # N/m, rigid limit stops (assumed; the thesis gives no number)


@dataclass
class QuarterCarResult:
    t: np.ndarray  # s
    y1: np.ndarray  # sprung displacement from equilibrium [m]
    y2: np.ndarray  # unsprung displacement [m]
    v1: np.ndarray  # sprung velocity [m/s]
    v2: np.ndarray  # unsprung velocity [m/s]
    y_in: np.ndarray  # road input [m]
    tire_force: np.ndarray  # N, >= 0 (0 = wheel off the ground)
    damper_force: np.ndarray  # N, compression positive, limit stops included
    damper_x: np.ndarray  # m from full extension
    friction_su: np.ndarray  # N on the sprung mass from the sprung-unsprung bearing
    static_tire_force: float  # N


def _friction_impulse(w1f, w3f, W, F1, F3, p1, p3):
    """Projected Gauss-Seidel on two Coulomb contacts: relative velocities
    w = w_free + W @ [p1, p3] (W in m/s per N); returns forces within [-F_i, F_i]
    making each contact either stick (w = 0) or slide against its motion."""
    for _ in range(50):
        q1, q3 = p1, p3
        if F1 > 0.0:
            p1 = min(max(p1 - (w1f + W[0, 0] * p1 + W[0, 1] * p3) / W[0, 0], -F1), F1)
        if F3 > 0.0:
            p3 = min(max(p3 - (w3f + W[1, 0] * p1 + W[1, 1] * p3) / W[1, 1], -F3), F3)
        if abs(p1 - q1) + abs(p3 - q3) < 1e-9 * (1.0 + F1 + F3):
            break
    return p1, p3


def simulate(qc: QuarterCar, damper_force, t, y_in, v_in=None, F_static=0.0, x_install=np.inf,
             stroke=np.inf, tire_travel=0.05) -> QuarterCarResult:
    """Run the quarter car over road input y_in(t) [m] (uniform t, s).

    damper_force(x, v) -> N; F_static: the damper force at rest at x_install (its gas
    force, which carries part of the sprung weight, eq 5.1); x_install, stroke: where
    the damper sits and its stroke [m] (infinite by default: no damper limit stops);
    tire_travel: tire compression beyond static before its collapsed-length stop
    (eq 5.8) [m].
    """
    t = np.asarray(t, float)
    y_in = np.asarray(y_in, float)
    v_in = np.gradient(y_in, t) if v_in is None else np.asarray(v_in, float)
    h = t[1] - t[0]
    n = len(t)
    z_pre1, z_pre2 = static_deflections(qc, F_static)
    ms, mu = qc.m_s, qc.m_u
    # friction contacts: w1 = v1 - v2, w3 = v1 - v_in; friction force p acts +p on the sprung mass
    W = h * np.array([[1 / ms + 1 / mu, 1 / ms], [1 / ms, 1 / ms]])
    Y1, Y2, V1, V2, FT, FD, XD, F1s = (np.zeros(n) for _ in range(8))
    y1 = y2 = v1 = v2 = 0.0
    p1 = p3 = 0.0
    for k in range(n):
        z1, z2 = y1 - y2, y2 - y_in[k]
        x = x_install - z1  # eq 5.5
        Fd = damper_force(x, -(v1 - v2))
        if x < 0.0:
            Fd += K_STOP * x  # eq 5.6: full-extension stop pulls the ends together
        elif x > stroke:
            Fd += K_STOP * (x - stroke)  # eq 5.7: bottoming
        Fs1 = max(qc.k_s * (z_pre1 - z1), 0.0)  # eq 5.10 (preloaded coil unloads, not pulls)
        contact = z2 < z_pre2
        Ft = qc.k_t * (z_pre2 - z2) if contact else 0.0  # eq 5.9: lift-off
        if contact:
            Ft -= qc.c_tire * (v2 - v_in[k])  # eq 5.14
            Ft = max(Ft, 0.0)  # a tire cannot pull the wheel down
        if z2 < -tire_travel:
            Ft += K_STOP * (-tire_travel - z2)  # eq 5.8
        Y1[k], Y2[k], V1[k], V2[k], FT[k], FD[k], XD[k] = y1, y2, v1, v2, Ft, Fd, x
        if k == n - 1:
            break
        # smooth forces (eqs 5.3-5.4, 5.12-5.13), then friction at the new velocities
        F1 = -ms * G + Fs1 + Fd
        F2 = -mu * G - Fs1 - Fd + Ft
        v1f, v2f = v1 + h * F1 / ms, v2 + h * F2 / mu
        p1, p3 = _friction_impulse(v1f - v2f, v1f - v_in[k + 1], W, qc.F_c1, qc.F_c3, p1, p3)
        F1s[k] = p1
        v1 = v1f + h * (p1 + p3) / ms
        v2 = v2f - h * p1 / mu
        y1 += h * v1
        y2 += h * v2
    return QuarterCarResult(t, Y1, Y2, V1, V2, y_in, FT, FD, XD, F1s, float((ms + mu) * G))


@dataclass
class DamperSource:
    """A damper force for the quarter car: force(x, v) -> N plus where it sits."""
    force: object  # callable (x [m], v [m/s]) -> N
    F_static: float  # N at rest at x_install (gas force)
    x_install: float  # m from full extension at static equilibrium
    stroke: float  # m


def damper_source(damper, T, h=1e-4, compressible=True) -> DamperSource:
    """Wrap a model from models/ (preset, JSON or object) at temperature T [K].

    The compressible model is advanced one step per call (backward Euler restarted
    each tick, first order at the 0.1 ms step; a compiled coupled loop comes with the
    sweeps). Motion beyond the stroke is clipped for the model: the stops take over.
    """
    d = load(damper) if isinstance(damper, str) else damper
    if isinstance(d, SimplifiedDamper):
        return DamperSource(lambda x, v: float(simplified.force(d, v)), 0.0, np.inf, np.inf)
    x_mid, stroke = d.mid_stroke, d.geometry.stroke
    prm, vp, vh = pack(d, T, x_mid)
    asm = ASSEMBLY[d.layout]
    fr = d.friction
    xs, vs, out = np.full(2, x_mid), np.zeros(2), np.zeros((2, 5))
    y = asm.initial_state(prm, x_mid)
    atol = np.full(asm.NSTATE, ATOL_OIL)
    asm.outputs(y, x_mid, 0.0, prm, vp, vh, out[0])
    F_static = float(out[0, 0] + out[0, 1])

    def force(x, v):
        x = min(max(x, 0.0), stroke)
        xs[0], vs[0] = xs[1], vs[1]
        xs[1], vs[1] = x, v
        if compressible:
            asm.integrate(y, xs, vs, 1, h, prm, vp, vh, atol, out)
        else:
            asm.incompressible(xs[1:], vs[1:], prm, vp, vh, out[1:])
        Ff = friction.friction_force(x, v, T, fr.x_table, fr.F_table, fr.C_sfT, fr.C_ifT)
        return float(out[1, 0] + out[1, 1] + Ff)

    return DamperSource(force, F_static, x_mid, stroke)


def run(qc: QuarterCar, source: DamperSource, t, y_in, v_in=None, tire_travel=0.05) -> QuarterCarResult:
    """simulate() with a DamperSource."""
    return simulate(qc, source.force, t, y_in, v_in, source.F_static, source.x_install,
                    source.stroke, tire_travel)
