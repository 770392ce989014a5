"""A hysteretic element in the load path (a rubber bush, an MR fluid's yield): Bouc-Wen
with exponent 1, elasto-plastic, or over a wider travel."""
from __future__ import annotations

import math

from sim_backend.effects.base import Hidden
from sim_backend.effects.presliding_friction import elastoplastic

BW_YIELD = 2e-4  # m: the element's yield travel (a choice: MR dampers yield over 0.1-1 mm)


class BoucWen(Hidden):
    name = "bouc_wen"
    listed = 120
    unit = "N"
    form = ("force at yield of a hysteretic element in the load path, Bouc-Wen with exponent n = 1 over "
            "BW_YIELD of travel (the diagnosis fits n = 2)")
    guess = 1.0
    hi = 1e4
    forms = {"elastoplastic": "elasto-plastic: linear up to VALUE over BW_YIELD of travel, then yields",
             "wide": "the default element over five times BW_YIELD"}
    stage = 30

    def start(self, pl):
        self.z, self.x = 0.0, pl.x_rod  # the element's state [-] and where it was [m]

    def load(self, pl, s):
        if not self.value:
            return
        if self.variant == "elastoplastic":
            self.z = elastoplastic([self.z], s.x - self.x, [BW_YIELD])[0]
        else:
            self.z = hysteresis(self.z, s.x - self.x, 5 * BW_YIELD if self.variant == "wide" else BW_YIELD)
        self.x = s.x
        s.F += self.value * self.z


def hysteresis(z, dx, y):
    """State z [-] of a Bouc-Wen element (n = 1, beta = gamma = 1/2) after a travel dx [m]:
    loading (z dx >= 0) dz/dx = (1 - |z|) / y, unloading dz/dx = 1 / y (linear back to
    zero), y the yield travel [m]; exact over the step."""
    s = math.copysign(1.0, dx) if dx else 0.0
    if s and z * s < 0:  # unloading: straight back to zero
        back = min(abs(dx), abs(z) * y)
        z += s * back / y
        dx -= s * back
    if s and abs(dx) > 0:
        z = s * (1.0 - (1.0 - abs(z)) * math.exp(-abs(dx) / y))
    return z
