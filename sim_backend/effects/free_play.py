"""Free play in the damper's lower mount: a clearance the rod floats across when the force
it carries would change sign (rigid contact; a contact that gives way like a worn bush or
a ball joint). The load cell reads nothing while the gap is crossed."""
from __future__ import annotations

import math

import numpy as np

from sim_backend.effects.base import Hidden

CONTACT_F = 5000.0  # N: the load under which a free play's contact gives way one clearance more (a choice:
# about the cell's force range, so the clearance, not the contact's spring, dominates)


class FreePlay(Hidden):
    name = "free_play"
    listed = 30
    unit = "m"
    form = "clearance in the damper's lower mount, in the load path (rigid contact)"
    guess = 2e-05
    hi = 0.005
    forms = {"contact": "the clearance closes onto a linear contact stiffness that gives way VALUE more under "
                        "CONTACT_F (a worn elastomer bush)",
             "hertz": "the clearance closes onto a Hertzian contact, deflection (F / CONTACT_F)^(2/3) VALUE "
                      "(a worn ball joint)"}
    stage = 100  # last in the load path: the rest of the force is what the rod floats against

    def start(self, pl):
        # the rod sits a gap (mount less rod, [m]) from the mount, bearing on it in
        # compression (contact +1), in rebound (-1) or crossing the clearance (0)
        self.gap = self.value / 2
        pl.x_rod = pl.x_act - self.gap
        self.give = 0.0  # the contact's deflection under load (contact, hertz forms) [m]
        self.contact = 1
        self.F_rest = self.F_grip = 0.0  # the force besides damping and friction, the friction's size [N]
        self.curve = damping_curve(pl) if self.value > 0 else None

    def repacked(self, pl):
        if self.curve is not None:
            self.curve = damping_curve(pl)

    def rod(self, pl, h, v_prev, x, v):
        """In contact the rod moves with the mount, whose speed ramps from v_prev to v over
        the step. The contact opens where the force it carries would change sign; the rod
        (massless) then floats at the speed v_f where the damper's force on it is zero
        (its damping curve against the rest: gas, friction), and the mount moves away from
        it at v - v_f until the gap is crossed. Followed within the step, so a crossing
        shorter than a step ends when it ends: the load cell reads zero only at the
        instants inside one."""
        c = self.value
        if c <= 0:
            return x, v
        v_tab, F_tab = self.curve
        rest = self.F_rest + self.F_grip * math.copysign(1.0, v)  # force besides damping
        v_f = float(np.interp(-rest, F_tab, v_tab))
        side, g0 = self.contact, self.gap
        g, t_a = g0, 0.0
        if side:
            if side * (rest + float(np.interp(v, v_tab, F_tab))) >= 0:  # stays in contact
                t_a = h
            elif v != v_prev:  # opens within the step, where the mount passes v_f
                t_a = h * min(max((v_f - v_prev) / (v - v_prev), 0.0), 1.0)
        if t_a < h:
            u = np.linspace(t_a, h, 65)
            vm = v_prev + (v - v_prev) * u / h  # the mount's speed
            gap = g + np.r_[0.0, np.cumsum(0.5 * (vm[1:] + vm[:-1] - 2 * v_f) * np.diff(u))]
            hit = np.nonzero(np.abs(gap[1:]) >= c / 2)[0] + 1
            if len(hit):  # the gap closes on one side within the step: contact from there on
                side = 1 if gap[hit[0]] > 0 else -1
                g = side * c / 2
            else:
                side, g = 0, float(gap[-1])
        self.contact, self.gap = side, g
        give0 = self.give
        if self.variant and side:  # the contact gives way under the force it carries (last step's)
            f = abs(pl.F) / CONTACT_F
            target = c * (f if self.variant == "contact" else (f + 0.01) ** (2 / 3) - 0.01 ** (2 / 3))
            # the massless rod relaxes onto it over damping slope / contact stiffness
            k = CONTACT_F / c * (1.0 if self.variant == "contact" else 1.5 * (f + 0.01) ** (1 / 3))
            self.give += min(1.0, k * h / slope(v_tab, F_tab, v)) * (side * target - self.give)
        else:
            self.give = 0.0
        x_rod = x - g - self.give
        return x_rod, v - (g + self.give - g0 - give0) / h  # the mount's motion less the gap's change

    def load(self, pl, s):
        if self.value <= 0:
            return
        self.F_rest, self.F_grip = s.F - s.F_d - s.F_f, abs(s.F_f)
        if self.contact == 0:
            s.F = 0.0  # crossing the clearance: the load cell feels nothing


def damping_curve(pl):
    """(v [m/s], F [N]): the damper's damping at steady speed, mid-stroke, at its present
    temperature (incompressible), rising with v; what a free rod floats on."""
    from models.physics.simulate import simulate
    v = np.r_[-np.geomspace(5.0, 1e-6, 120), 0.0, np.geomspace(1e-6, 5.0, 120)]
    x = np.full(len(v), pl.stepper.x_e)
    F = simulate(pl.damper, np.arange(len(v)) * 1e-3, x, v, T=pl.T, compressible=False,
                 x_e=pl.stepper.x_e).damping
    return v, np.maximum.accumulate(F)


def slope(v_tab, F_tab, v):
    """The damping curve's slope dF/dv [N s/m] at v [m/s]."""
    dv = max(abs(v) * 0.05, 1e-4)
    return max((float(np.interp(v + dv, v_tab, F_tab)) - float(np.interp(v - dv, v_tab, F_tab))) / (2 * dv), 1.0)
