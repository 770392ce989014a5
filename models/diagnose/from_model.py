"""Baseline from a damper model (`dyno diagnose --baseline PRESET|FILE.json`)."""
from __future__ import annotations

import numpy as np

from models.diagnose.forms import shift
from models.diagnose.spec import P

LEAD = 20  # samples run before a stretch when a damper model is simulated along it


class FromModel:
    """Baseline from a damper model (the presets' JSON): its damping, gas and friction
    forces simulated once along the recorded motion (models/physics/simulate.py, compressible), then
    refitted where the data allows: a gain on the damping (valves), the static gas force and
    a gain on its slope with stroke (charge pressure and volume), a gain on the friction."""

    def __init__(self, damper, d, name):
        from models.physics.simulate import simulate
        self.name = name
        T = float(np.mean(d.T)) if d.T is not None else 293.15
        x_e = float(np.mean(d.x))
        out = {k: np.empty(len(d.t)) for k in ("Fd", "Fg", "Ff", "slope")}
        dv = 1e-3  # m/s, for the valves' slope (incompressible)
        cut = np.r_[0, np.nonzero(np.diff(d.t) > 1.5 * d.h[1:])[0] + 1, len(d.t)]
        for a, b in zip(cut[:-1], cut[1:]):
            if b - a < 2:
                out["Fd"][a:b] = out["Fg"][a:b] = out["Ff"][a:b] = out["slope"][a:b] = 0.0
                continue
            t = np.linspace(d.t[a], d.t[b - 1], b - a)  # uniform, as the compressible model needs
            x, v = np.interp(t, d.t[a:b], d.x[a:b]), np.interp(t, d.t[a:b], d.v[a:b])
            # a lead-in at the first sample's velocity, so the chambers are flowing when it starts
            lead = np.arange(-LEAD, 0)
            t = np.r_[t[0] + lead * (t[1] - t[0]), t]
            x = np.r_[x[0] + v[0] * (t[:LEAD] - t[LEAD]), x]
            v = np.r_[np.full(LEAD, v[0]), v]
            r = simulate(damper, t, x, v, T=T, compressible=True, x_e=x_e, substeps=4)
            up = simulate(damper, t, x, v + dv, T=T, compressible=False, x_e=x_e)
            dn = simulate(damper, t, x, v - dv, T=T, compressible=False, x_e=x_e)
            back = (lambda y: np.interp(d.t[a:b], t[LEAD:], y[LEAD:]))
            out["Fd"][a:b], out["Fg"][a:b], out["Ff"][a:b] = back(r.damping), back(r.gas), back(r.friction)
            out["slope"][a:b] = back(np.abs(up.damping - dn.damping) / (2 * dv))
        self.Fd, self.Fg, self.Ff, self.slope = out["Fd"], out["Fg"], out["Ff"], out["slope"]
        self.Fg_m = float(np.mean(self.Fg))
        self.Ff_level = float(np.percentile(np.abs(self.Ff), 90))  # sliding friction [N]

    def params(self, d):
        Fmax = max(np.percentile(np.abs(d.F), 99), 10.0)
        return [P("k_damping", 1.0, 0.0, 5.0, "-"), P("G0", self.Fg_m, -Fmax, Fmax, "N"),
                P("k_gas", 1.0, 0.0, 5.0, "-"), P("k_friction", 1.0, 0.0, 10.0, "-")]

    def friction_level(self, p):
        return p["k_friction"] * self.Ff_level

    def parts(self, d, p, x, v, tau):
        s = (lambda y: shift(y, d.t, -tau)) if tau else (lambda y: y)
        return (p["k_damping"] * s(self.Fd), p["G0"] + p["k_gas"] * (s(self.Fg) - self.Fg_m),
                p["k_friction"] * s(self.Ff), lambda: p["k_damping"] * s(self.slope))
