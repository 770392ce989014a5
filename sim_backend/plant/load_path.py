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
    fx, forms = pl.fx, pl.forms
    c = fx.get("free_play", 0.0)
    if c > 0:
        x_rod, v_rod = rod_in_clearance(pl, h, c, v_prev)
    else:
        x_rod, v_rod = pl.x_d, pl.v_d
    F, F_d, F_g, F_f, P1, P2, Pg = pl.stepper.step(x_rod, v_rod)
    if fx.get("breakaway_friction", 1.0) != 1.0:  # Stribeck: the seal grips harder near rest
        shape, v_s = fx_mod.STRIBECK[forms.get("breakaway_friction")]
        F += F_f * (fx["breakaway_friction"] - 1.0) * stribeck(v_rod / v_s, shape)
    if fx.get("presliding_friction") and forms.get("presliding_friction"):
        # the stepper's friction is Coulomb here (plant.__init__); it builds elasto-plastically
        travels = (1.0,) if forms["presliding_friction"] == "jenkins" else (0.25, 0.75, 1.25, 1.75)
        z = elastoplastic(pl.z_pre, x_rod - pl.x_pre, [k * fx["presliding_friction"] for k in travels])
        pl.z_pre, pl.x_pre = z, x_rod
        F += abs(F_f) * float(np.mean(z)) - F_f
    if fx.get("bouc_wen"):
        if forms.get("bouc_wen") == "elastoplastic":
            pl.z_bw = elastoplastic([pl.z_bw], x_rod - pl.x_bw, [fx_mod.BW_YIELD])[0]
            pl.x_bw = x_rod
            F += fx["bouc_wen"] * pl.z_bw
        else:
            F += fx["bouc_wen"] * hysteresis(pl, x_rod, 5 * fx_mod.BW_YIELD if forms.get("bouc_wen") == "wide"
                                             else fx_mod.BW_YIELD)
    if fx.get("fluid_inertia"):
        F += fx["fluid_inertia"] * column(pl, h, (v_rod - v_prev) / h, v_rod, forms.get("fluid_inertia"))
    if fx.get("aux_channel"):
        i = pl.i_lag
        F += fx["aux_channel"] * ((i * i - 1.0) / 2 if forms.get("aux_channel") == "quadratic" else i - 1.0) * F_d
    if pl.extra is not None:  # the user's own physics, on the rod's motion
        F += pl.extra(x_rod, v_rod, pl.t, pl.T)
    if "cavitation" in fx:  # a chamber below the floor holds the floor: the piston loses that push
        geo, floor, form = pl.damper.geometry, fx["cavitation"], forms.get("cavitation")
        P1c, P2c = floored(P1, floor, form), floored(P2, floor, form)
        if form == "lingering":  # the released air redissolves over CAV_REDISSOLVE_S
            keep = math.exp(-h / fx_mod.CAV_REDISSOLVE_S)
            pl.cav_loss = (max(P1c - P1, pl.cav_loss[0] * keep), max(P2c - P2, pl.cav_loss[1] * keep))
            P1c, P2c = P1 + pl.cav_loss[0], P2 + pl.cav_loss[1]
        F += (P1c - P1) * geo.A_p - (P2c - P2) * (geo.A_p - geo.A_r)
        P1, P2 = P1c, P2c
    if c > 0:
        pl.F_rest, pl.F_grip = F - F_d - F_f, abs(F_f)
        if pl.contact == 0:
            return 0.0, F_d, P1, P2, Pg  # crossing the clearance: the load cell feels nothing
    return F, F_d, P1, P2, Pg


def stribeck(u, shape="gaussian"):
    """Breakaway share [-] at speed u in Stribeck velocities: Gaussian, exponential,
    Lorentzian or a power law."""
    if shape == "exponential":
        return math.exp(-abs(u))
    if shape == "lorentzian":
        return 1.0 / (1.0 + u * u)
    if shape == "power":
        return 1.0 / (1.0 + abs(u)) ** 2
    return math.exp(-u * u)


def floored(P, floor, form=None):
    """A chamber's pressure [Pa] where the oil releases air at `floor` [Pa]: held at the
    floor, or (soft) approaching it exponentially from twice the floor down."""
    if form == "soft":
        return P if P >= 2 * floor else floor + floor * math.exp((P - 2 * floor) / floor)
    return max(P, floor)


def column(pl, h, a, v, form=None):
    """Acceleration [m/s^2] the oil column's mass is multiplied by: the damper's, through a
    1 ms lag; (resonant) through the column's 150 Hz resonance on the oil's spring, damping
    ratio 0.3; (direction) weighed 1.5 in compression flow, 0.5 in rebound."""
    if form == "resonant":  # semi-implicit: y'' = w^2 (a - y) - 2 zeta w y'
        w = 2 * math.pi * 150.0
        pl.a_f_rate += h * (w * w * (a - pl.a_f) - 2 * 0.3 * w * pl.a_f_rate)
        pl.a_f += h * pl.a_f_rate
        return pl.a_f
    pl.a_f += h / 1e-3 * (a - pl.a_f)
    if form == "direction":
        return pl.a_f * (1.5 if v > 0 else 0.5)
    return pl.a_f


def elastoplastic(z, dx, travels):
    """States [-] of elasto-plastic (Jenkins) elements after a travel dx [m]: each follows
    the travel over its own stick travel [m] and slides at +-1."""
    return [min(max(zi + dx / y, -1.0), 1.0) for zi, y in zip(z, travels)]


def hysteresis(pl, x, y):
    """State z [-] of the hidden Bouc-Wen element (n = 1, beta = gamma = 1/2) at x [m]:
    loading (z dx >= 0) dz/dx = (1 - |z|) / y, unloading dz/dx = 1 / y (linear back to
    zero), y the yield travel [m]; exact over the step."""
    dx, z = x - pl.x_bw, pl.z_bw
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
    give0 = pl.give
    form = pl.forms.get("free_play")
    if form and side:  # the contact gives way under the force it carries (last step's)
        f = abs(pl.F) / fx_mod.CONTACT_F
        target = c * (f if form == "contact" else (f + 0.01) ** (2 / 3) - 0.01 ** (2 / 3))
        # the massless rod relaxes onto it over damping slope / contact stiffness
        k = fx_mod.CONTACT_F / c * (1.0 if form == "contact" else 1.5 * (f + 0.01) ** (1 / 3))
        pl.give += min(1.0, k * h / slope(v_tab, F_tab, pl.v_d)) * (side * target - pl.give)
    else:
        pl.give = 0.0
    pl.x_rod = pl.x_d - g - pl.give
    pl.v_rod = pl.v_d - (g + pl.give - g0 - give0) / h  # the mount's motion less the gap's change
    return pl.x_rod, pl.v_rod


def slope(v_tab, F_tab, v):
    """The damping curve's slope dF/dv [N s/m] at v [m/s]."""
    dv = max(abs(v) * 0.05, 1e-4)
    return max((float(np.interp(v + dv, v_tab, F_tab)) - float(np.interp(v - dv, v_tab, F_tab))) / (2 * dv), 1.0)


def adjuster(pl, h):
    """The adjuster current wanders (Ornstein-Uhlenbeck, 2 s, 0.3 A about 1 A); the valve
    follows it through its solenoid's 20 ms lag (2 ms in the fast form)."""
    pl.i_valve += h / 2.0 * (1.0 - pl.i_valve) + 0.3 * math.sqrt(2 * h / 2.0) * pl.aux_noise()
    pl.i_lag += h / (0.002 if pl.forms.get("aux_channel") == "fast" else 0.02) * (pl.i_valve - pl.i_lag)
