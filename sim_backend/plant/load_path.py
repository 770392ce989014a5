"""The damper between the frame's mount and the load cell, with the hidden effects that
live in the load path (sim_backend/effects.py): free play in the mount, a Stribeck seal,
a hysteretic element, oil-column inertia, the adjuster current's damping change, cavitation."""
from __future__ import annotations

import math

import numpy as np

from sim_backend import effects as fx_mod


def damper_step(pl, h, v_prev):
    """The damper between the mount (at x_d) and the load cell, with the hidden
    effects that live in its load path: (force on the load cell, damping, P1, P2, P_gas)."""
    fx = pl.fx
    c = fx.get("free_play", 0.0)
    if c > 0:
        x_rod, v_rod = rod_in_clearance(pl, h, c, v_prev)
    else:
        x_rod, v_rod = pl.x_d, pl.v_d
    F, F_d, F_g, F_f, P1, P2, Pg = pl.stepper.step(x_rod, v_rod)
    if fx.get("breakaway_friction", 1.0) != 1.0:  # Stribeck: the seal grips harder near rest
        F += F_f * (fx["breakaway_friction"] - 1.0) * stribeck(v_rod / fx_mod.STRIBECK_V, pl.forms.get("breakaway_friction"))
    if fx.get("bouc_wen"):
        F += fx["bouc_wen"] * hysteresis(pl, x_rod)
    if fx.get("fluid_inertia"):
        pl.a_f += h / 1e-3 * ((v_rod - v_prev) / h - pl.a_f)
        F += fx["fluid_inertia"] * pl.a_f
    if fx.get("aux_channel"):
        F += fx["aux_channel"] * (pl.i_lag - 1.0) * F_d
    if "cavitation" in fx:  # a chamber below the floor holds the floor: the piston loses that push
        geo, floor = pl.damper.geometry, fx["cavitation"]
        if P2 < floor:
            F -= (floor - P2) * (geo.A_p - geo.A_r)
            P2 = floor
        if P1 < floor:
            F += (floor - P1) * geo.A_p
            P1 = floor
    if c > 0:
        pl.F_rest, pl.F_grip = F - F_d - F_f, abs(F_f)
        if pl.contact == 0:
            return 0.0, F_d, P1, P2, Pg  # crossing the clearance: the load cell feels nothing
    return F, F_d, P1, P2, Pg


def stribeck(u, form=None):
    """Breakaway share [-] at speed u in Stribeck velocities: Gaussian (default),
    exponential or Lorentzian."""
    if form == "exponential":
        return math.exp(-abs(u))
    if form == "lorentzian":
        return 1.0 / (1.0 + u * u)
    return math.exp(-u * u)


def hysteresis(pl, x):
    """State z [-] of the hidden Bouc-Wen element (n = 1, beta = gamma = 1/2) at x [m]:
    loading (z dx >= 0) dz/dx = (1 - |z|) / BW_YIELD, unloading dz/dx = 1 / BW_YIELD (linear
    back to zero); exact over the step."""
    dx, z, y = x - pl.x_bw, pl.z_bw, fx_mod.BW_YIELD
    pl.x_bw = x
    s = math.copysign(1.0, dx) if dx else 0.0
    if s and z * s < 0:  # unloading: straight back to zero
        back = min(abs(dx), abs(z) * y)
        z += s * back / y
        dx -= s * back
    if s and abs(dx) > 0:
        z = s * (1.0 - (1.0 - abs(z)) * math.exp(-abs(dx) / y))
    pl.z_bw = z
    return z


def damping_curve(pl):
    """(v [m/s], F [N]): the damper's damping at steady speed, mid-stroke, at its present
    temperature (incompressible), rising with v; what a free rod floats on."""
    from models.physics.simulate import simulate
    v = np.r_[-np.geomspace(5.0, 1e-6, 120), 0.0, np.geomspace(1e-6, 5.0, 120)]
    x = np.full(len(v), pl.stepper.x_e)
    F = simulate(pl.damper, np.arange(len(v)) * 1e-3, x, v, T=pl.T, compressible=False,
                 x_e=pl.stepper.x_e).damping
    return v, np.maximum.accumulate(F)


def rod_in_clearance(pl, h, c, v_prev):
    """(x [m], mean v over the step [m/s]) of the damper's rod when its mount has a
    clearance c [m]. In contact the rod moves with the mount, whose speed ramps from
    v_prev to v_d over the step. The contact opens where the force it carries would change
    sign; the rod (massless) then floats at the speed v_f where the damper's force on it
    is zero (its damping curve against the rest: gas, friction), and the mount moves away
    from it at v - v_f until the gap is crossed. Followed within the step, so a crossing
    shorter than a step ends when it ends: the load cell reads zero only at the
    instants inside one."""
    v_tab, F_tab = pl.curve
    rest = pl.F_rest + pl.F_grip * math.copysign(1.0, pl.v_d)  # force besides damping
    v_f = float(np.interp(-rest, F_tab, v_tab))
    side, g0 = pl.contact, pl.gap
    g, t_a = g0, 0.0
    if side:
        if side * (rest + float(np.interp(pl.v_d, v_tab, F_tab))) >= 0:  # stays in contact
            t_a = h
        elif pl.v_d != v_prev:  # opens within the step, where the mount passes v_f
            t_a = h * min(max((v_f - v_prev) / (pl.v_d - v_prev), 0.0), 1.0)
    if t_a < h:
        u = np.linspace(t_a, h, 65)
        v = v_prev + (pl.v_d - v_prev) * u / h  # the mount's speed
        gap = g + np.r_[0.0, np.cumsum(0.5 * (v[1:] + v[:-1] - 2 * v_f) * np.diff(u))]
        hit = np.nonzero(np.abs(gap[1:]) >= c / 2)[0] + 1
        if len(hit):  # the gap closes on one side within the step: contact from there on
            side = 1 if gap[hit[0]] > 0 else -1
            g = side * c / 2
        else:
            side, g = 0, float(gap[-1])
    pl.contact, pl.gap = side, g
    pl.x_rod = pl.x_d - g
    pl.v_rod = pl.v_d - (g - g0) / h  # the mount's motion less the gap's change
    return pl.x_rod, pl.v_rod


def adjuster(pl, h):
    """The adjuster current wanders (Ornstein-Uhlenbeck, 2 s, 0.3 A about 1 A); the valve
    follows it through its solenoid's 20 ms lag."""
    pl.i_valve += h / 2.0 * (1.0 - pl.i_valve) + 0.3 * math.sqrt(2 * h / 2.0) * pl.aux_rng.standard_normal()
    pl.i_lag += h / 0.02 * (pl.i_valve - pl.i_lag)
