"""A tight spot in the bore: the seal's friction rises over part of the stroke (a bump
above mid-stroke; a narrow one below; a step to a worn lower bore)."""
from __future__ import annotations

import dataclasses

import numpy as np

from sim_backend.effects.base import Hidden

TIGHT_SPOT = (0.006, 0.004)  # m: the tight spot's centre above mid-stroke and its half-width
NARROW_SPOT = (-0.003, 0.00075)  # m: the narrow form's


class PositionFriction(Hidden):
    name = "position_friction"
    listed = 60
    unit = "-"
    form = "a tight spot in the bore: extra friction at its peak over the table's"
    guess = 0.1
    hi = 10.0
    forms = {"narrow": "a tight spot 1.5 mm wide, 3 mm below mid-stroke",
             "step": "friction VALUE higher over the bore above mid-stroke + 2 mm (a worn lower bore), the step "
                     "over 0.5 mm"}

    def describe(self, d):
        if not self.value:
            return d
        f = d.friction
        x = np.linspace(0.0, d.geometry.stroke, 241)
        if self.variant == "step":
            shape = 0.5 * (1 + np.tanh((x - d.mid_stroke - 0.002) / 0.00025))
        else:
            c, w = NARROW_SPOT if self.variant == "narrow" else TIGHT_SPOT
            shape = np.exp(-((x - d.mid_stroke - c) / w) ** 2)
        F = np.interp(x, f.x_table, f.F_table) * (1 + self.value * shape)
        return dataclasses.replace(d, friction=dataclasses.replace(f, x_table=list(x), F_table=list(F)))
