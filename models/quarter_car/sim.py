"""Time-domain quarter car (thesis eqs 5.3-5.14) driven by a damper force from any source.

Coordinates are deviations from static equilibrium, positive up [m]: y1 sprung, y2
unsprung, y_in road; z1 = y1 - y2, z2 = y2 - y_in. The damper is compressed by
x = x_install - z1 (eq 5.5) and its force F(x, v) is positive in compression: it pushes
the sprung mass up and the unsprung mass down. `damper_force(x, v) -> F` is called once
per step, so the same loop can run with a damper model or, in hardware-in-the-loop, with
the force the load cell measured for the motion commanded on the previous tick.

Two entry points share one compiled step: `simulate(qc, damper_force, ...)` calls a Python
callable each step (hardware-in-the-loop, any force source); `run(qc, damper, ...)` runs a
damper model from models/ coupled to the car entirely in compiled code, one implicit
damper step per car step (what the sweeps use).

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
from numba import njit

from models.physics import simplified
from models.damper import Damper, DamperError, SimplifiedDamper, load
from models.physics.friction import breakaway_ratio, dahl_step, static_friction
from models.physics.kernel import pack
from models.quarter_car import G, QuarterCar, static_deflections
from models.physics.simulate import ASSEMBLY, ATOL_OIL, NOUT, C_to_K
from models.physics.assemblies import CODE, incompressible
from models.physics.stiff import integrate, new_history

K_STOP = 1e7  # N/m, rigid limit stops (assumed; the thesis gives no number)
V_TABLE = 100.0  # m/s, end knot of a simplified model's force table (never reached)

# car parameters q[...] and state s = [y1, y2, v1, v2, p1, p3] (p: friction forces, N)
MS, MU, KS, KT, CT, FC1, FC3, ZPRE1, ZPRE2, XINST, STROKE, TTRAVEL, H = range(13)
# columns of the record: y1, y2, v1, v2, tire force, damper force, damper x, friction
NREC = 8


@dataclass
class QuarterCarResult:
    t: np.ndarray  # s
    y1: np.ndarray  # sprung displacement from equilibrium [m]
    y2: np.ndarray  # unsprung displacement [m]
    v1: np.ndarray  # sprung velocity [m/s]
    v2: np.ndarray  # unsprung velocity [m/s]
    y_in: np.ndarray  # road input [m]
    v_in: np.ndarray  # road input velocity [m/s]
    tire_force: np.ndarray  # N, >= 0 (0 = wheel off the ground)
    damper_force: np.ndarray  # N, compression positive: damping, gas, its friction, stops
    damper_x: np.ndarray  # m from full extension
    friction_su: np.ndarray  # N on the sprung mass from the sprung-unsprung bearing
    static_tire_force: float  # N


@njit(cache=True)
def _friction_impulse(w1f, w3f, W00, W01, W11, F1, F3, p1, p3):
    """Projected Gauss-Seidel on two Coulomb contacts: relative velocities
    w = w_free + W @ [p1, p3] (W in m/s per N, symmetric); returns forces within
    [-F_i, F_i] making each contact either stick (w = 0) or slide against its motion."""
    for _ in range(50):
        q1, q3 = p1, p3
        if F1 > 0.0:
            p1 = min(max(p1 - (w1f + W00 * p1 + W01 * p3) / W00, -F1), F1)
        if F3 > 0.0:
            p3 = min(max(p3 - (w3f + W01 * p1 + W11 * p3) / W11, -F3), F3)
        if abs(p1 - q1) + abs(p3 - q3) < 1e-9 * (1.0 + F1 + F3):
            break
    return p1, p3


@njit(cache=True)
def _motion(s, q):
    """Damper compression x [m] (eq 5.5) and its velocity [m/s] from the car state."""
    return q[XINST] - (s[0] - s[1]), -(s[2] - s[3])


@njit(cache=True)
def _step(s, q, Fd, Fc_d, yin, vin, vin_next, rec):
    """Record the present state and forces in rec, then advance s by one step of q[H]
    with damper force Fd [N] (eqs 5.3-5.14) and damper Coulomb friction Fc_d [N]: that
    acts between the same two masses as the bearing friction F_c1, so it joins that
    implicit contact (explicit sgn(v) would chatter whenever the suspension sticks)."""
    ms, mu, h = q[MS], q[MU], q[H]
    y1, y2, v1, v2 = s[0], s[1], s[2], s[3]
    z1, z2 = y1 - y2, y2 - yin
    x = q[XINST] - z1  # eq 5.5
    if x < 0.0:
        Fd += K_STOP * x  # eq 5.6: full-extension stop pulls the ends together
    elif x > q[STROKE]:
        Fd += K_STOP * (x - q[STROKE])  # eq 5.7: bottoming
    Fs1 = max(q[KS] * (q[ZPRE1] - z1), 0.0)  # eq 5.10 (preloaded coil unloads, not pulls)
    Ft = 0.0
    if z2 < q[ZPRE2]:  # eq 5.9: lift-off
        Ft = max(q[KT] * (q[ZPRE2] - z2) - q[CT] * (v2 - vin), 0.0)  # eq 5.14; cannot pull
    if z2 < -q[TTRAVEL]:
        Ft += K_STOP * (-q[TTRAVEL] - z2)  # eq 5.8
    # smooth forces (eqs 5.3-5.4, 5.12-5.13), then friction at the new velocities
    v1f = v1 + h * (-ms * G + Fs1 + Fd) / ms
    v2f = v2 + h * (-mu * G - Fs1 - Fd + Ft) / mu
    # friction contacts: w1 = v1 - v2, w3 = v1 - v_in; force p acts +p on the sprung mass
    p1, p3 = _friction_impulse(v1f - v2f, v1f - vin_next, h * (1 / ms + 1 / mu), h / ms, h / ms,
                               q[FC1] + Fc_d, q[FC3], s[4], s[5])
    rec[0], rec[1], rec[2], rec[3] = y1, y2, v1, v2
    # while stuck the split of p1 between bearing and damper is indeterminate: share it
    # in proportion to their limits
    share = Fc_d / (q[FC1] + Fc_d) if Fc_d > 0.0 else 0.0
    rec[4], rec[5], rec[6], rec[7] = Ft, Fd + share * p1, x, p1 - share * p1
    s[2] = v1f + h * (p1 + p3) / ms
    s[3] = v2f - h * p1 / mu
    s[0] = y1 + h * s[2]
    s[1] = y2 + h * s[3]
    s[4], s[5] = p1, p3


def _setup(qc, t, y_in, v_in, F_static, x_install, stroke, tire_travel):
    t = np.asarray(t, float)
    y_in = np.asarray(y_in, float)
    if t.ndim != 1 or len(t) < 2 or t.shape != y_in.shape:
        raise DamperError("t and y_in must be 1-D arrays of the same length (>= 2)")
    v_in = np.gradient(y_in, t) if v_in is None else np.asarray(v_in, float)
    h = float(t[1] - t[0])
    if not h > 0 or not np.allclose(np.diff(t), h, rtol=1e-6, atol=1e-12):
        raise DamperError("t must be increasing and uniformly spaced")
    z_pre1, z_pre2 = static_deflections(qc, F_static)
    q = np.array([qc.m_s, qc.m_u, qc.k_s, qc.k_t, qc.c_tire, qc.F_c1, qc.F_c3, z_pre1, z_pre2,
                  x_install, stroke, tire_travel, h])
    return t, y_in, v_in, q, np.zeros(6), np.empty((len(t), NREC))


def _result(qc, t, y_in, v_in, rec):
    return QuarterCarResult(t, *rec[:, :4].T, y_in, v_in, *rec[:, 4:].T, float((qc.m_s + qc.m_u) * G))


def simulate(qc: QuarterCar, damper_force, t, y_in, v_in=None, F_static=0.0, x_install=np.inf,
             stroke=np.inf, tire_travel=0.05) -> QuarterCarResult:
    """Run the quarter car over road input y_in(t) [m] (uniform t, s), calling
    damper_force(x [m], v [m/s]) -> N once per step.

    F_static: the damper force at rest at x_install (its gas force, which carries part of
    the sprung weight, eq 5.1); x_install, stroke: where the damper sits and its stroke
    [m] (infinite by default: no damper limit stops); tire_travel: tire compression
    beyond static before its collapsed-length stop (eq 5.8) [m].
    """
    t, y_in, v_in, q, s, rec = _setup(qc, t, y_in, v_in, F_static, x_install, stroke, tire_travel)
    n = len(t)
    for k in range(n):
        x, v = _motion(s, q)
        _step(s, q, float(damper_force(x, v)), 0.0, y_in[k], v_in[k], v_in[min(k + 1, n - 1)], rec[k])
    return _result(qc, t, y_in, v_in, rec)


@njit(cache=True)
def _coupled_loop(layout, s, q, y_in, v_in, mode, y, prm, vp, vh, atol, hist, fx, fF, f_ratio, x_stick, rec):
    """Car + damper model (assemblies.CODE `layout`), compiled together; mode 2:
    compressible, 1: incompressible. x_stick > 0: the damper's friction in Dahl's form
    (the damper model's friction.x_stick), part of its force rather than of the contact."""
    n = y_in.shape[0]
    xs, vs = np.empty(2), np.empty(2)
    out = np.empty((2, 5))
    x, v = _motion(s, q)
    xs[1], vs[1] = min(max(x, 0.0), q[STROKE]), v
    Ff = 0.0
    for k in range(n):
        x, v = _motion(s, q)
        x = min(max(x, 0.0), q[STROKE])  # beyond the stroke the stops take over
        xs[0], vs[0] = xs[1], vs[1]
        xs[1], vs[1] = x, v
        if mode == 2:
            integrate(layout, y, xs, vs, 1, q[H], prm, vp, vh, atol, out, hist)
        else:
            incompressible(layout, xs[1:], vs[1:], prm, vp, vh, out[1:])
        Fc_d = np.interp(x, fx, fF) * f_ratio  # eq 3.3's magnitude; its sign is solved
        Fd = out[1, 0] + out[1, 1]
        if x_stick > 0.0:
            Ff = dahl_step(Ff, xs[1] - xs[0], Fc_d, x_stick)
            Fd, Fc_d = Fd + Ff, 0.0
        _step(s, q, Fd, Fc_d, y_in[k], v_in[k], v_in[min(k + 1, n - 1)], rec[k])


@njit(cache=True)
def _table_loop(s, q, y_in, v_in, tv, tF, rec):
    """Car with a damper force tabulated against velocity (the simplified models)."""
    n = y_in.shape[0]
    for k in range(n):
        x, v = _motion(s, q)
        _step(s, q, np.interp(v, tv, tF), 0.0, y_in[k], v_in[k], v_in[min(k + 1, n - 1)], rec[k])


def run(qc: QuarterCar, damper, t, y_in, v_in=None, T=C_to_K(94.0), compressible=True,
        tire_travel=0.05, x_install=None) -> QuarterCarResult:
    """Run the quarter car with a damper model (preset name, JSON path, Damper or
    SimplifiedDamper) at temperature T [K], in compiled code.

    A comprehensive damper sits at x_install [m from full extension] at static
    equilibrium (mid-stroke by default: the thesis does not say), carries its gas
    force (eq 5.1), adds its friction (eq 3.3) and meets its stops at the stroke ends;
    the compressible model takes one implicit step per car step. A simplified model
    (eqs 6.1-6.2) is damping only: no gas force, no stops."""
    d = load(damper)
    if isinstance(d, SimplifiedDamper):
        tv = np.array([-V_TABLE, 0.0, V_TABLE])
        if d.rebound.v_transition is not None:
            tv = np.insert(tv, 1, -abs(d.rebound.v_transition))
        if d.compression.v_transition is not None:
            tv = np.insert(tv, len(tv) - 1, abs(d.compression.v_transition))
        t, y_in, v_in, q, s, rec = _setup(qc, t, y_in, v_in, 0.0, np.inf, np.inf, tire_travel)
        _table_loop(s, q, y_in, v_in, tv, simplified.force(d, tv), rec)
        return _result(qc, t, y_in, v_in, rec)
    if not isinstance(d, Damper):
        raise DamperError(f"not a damper model: {damper!r}")
    x_mid, stroke = d.mid_stroke if x_install is None else float(x_install), d.geometry.stroke
    prm, vp, vh = pack(d, float(T), x_mid)
    asm = ASSEMBLY[d.layout]
    y = asm.initial_state(prm, x_mid)
    out = np.empty((1, NOUT))
    asm.outputs(y, x_mid, 0.0, prm, vp, vh, out[0])
    F_static = float(out[0, 0] + out[0, 1])
    t, y_in, v_in, q, s, rec = _setup(qc, t, y_in, v_in, F_static, x_mid, stroke, tire_travel)
    fr = d.friction
    # eq 3.1's table with its clamped end extrapolation, tabulated finely for np.interp
    fx = np.unique(np.concatenate([np.linspace(0.0, stroke, 257), fr.x_table]))
    fF = static_friction(fx, fr.x_table, fr.F_table)
    _coupled_loop(CODE[d.layout], s, q, y_in, v_in, 2 if compressible else 1, y, prm, vp, vh,
                  np.full(asm.NSTATE, ATOL_OIL), new_history(asm.NSTATE), fx, fF,
                  float(breakaway_ratio(float(T), fr.C_sfT, fr.C_ifT)), float(fr.x_stick), rec)
    return _result(qc, t, y_in, v_in, rec)


class CarStepper:
    """The quarter car one step at a time, with the damper force from outside (the load
    cell, in hardware-in-the-loop): `step(F)` takes the force [N] that answered the present
    damper motion, advances the car one step of the road's period, and returns the damper
    motion it asks for next (x [m] from full extension, v [m/s], a [m/s^2], compression
    positive). Same equations and integrator as `simulate` (eqs 5.3-5.14)."""

    def __init__(self, qc: QuarterCar, t, y_in, v_in=None, F_static=0.0, x_install=np.inf, stroke=np.inf,
                 tire_travel=0.05):
        self.qc = qc
        self.t, self.y_in, self.v_in, self.q, self.s, self.rec = _setup(qc, t, y_in, v_in, F_static, x_install,
                                                                        stroke, tire_travel)
        self.k = 0
        self.h = self.q[H]
        self.a1 = self.a2 = 0.0  # sprung and unsprung accelerations over the last step [m/s^2]

    @property
    def done(self):
        return self.k >= len(self.t)

    def motion(self):
        """(x, v, a) of the damper the car's present state asks for."""
        x, v = _motion(self.s, self.q)
        return x, v, -(self.a1 - self.a2)

    def step(self, F):
        k, n, s = self.k, len(self.t), self.s
        v1, v2 = s[2], s[3]
        _step(s, self.q, float(F), 0.0, self.y_in[k], self.v_in[k], self.v_in[min(k + 1, n - 1)], self.rec[k])
        self.a1, self.a2 = (s[2] - v1) / self.h, (s[3] - v2) / self.h
        self.k += 1
        return self.motion()

    def result(self) -> QuarterCarResult:
        """The steps taken so far."""
        k = self.k
        return _result(self.qc, self.t[:k], self.y_in[:k], self.v_in[:k], self.rec[:k])
