"""The damper between the frame's mount and the load cell, with the hidden effects that
act in the load path (sim_backend/effects/: each changes the step's forces in its turn),
and the adjuster current a semi-active valve can follow."""
from __future__ import annotations

import math

from sim_backend.effects.base import PlantStep


def damper_step(pl, h, v_prev):
    """The damper between the mount (at x_d) and the load cell, with the hidden
    effects in its load path: (force on the load cell, damping, P1, P2, P_gas)."""
    x, v = pl.x_d, pl.v_d
    for e in pl.hidden:
        x, v = e.rod(pl, h, v_prev, x, v)
    F, F_d, F_g, F_f, P1, P2, Pg = pl.stepper.step(x, v)
    if pl.extra is not None:  # the user's own physics, on the rod's motion
        F += pl.extra(x, v, pl.t, pl.T)
    if pl.load_path:
        s = PlantStep(h, x, v, v_prev, F, F_d, F_f, P1, P2)
        for e in pl.load_path:
            e.load(pl, s)
        F, P1, P2 = s.F, s.P1, s.P2
    return F, F_d, P1, P2, Pg


def adjuster(pl, h):
    """The adjuster current wanders (Ornstein-Uhlenbeck, 2 s, 0.3 A about 1 A)."""
    pl.i_valve += h / 2.0 * (1.0 - pl.i_valve) + 0.3 * math.sqrt(2 * h / 2.0) * pl.aux_noise()
