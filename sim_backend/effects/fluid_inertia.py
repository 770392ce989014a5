"""The oil column's mass, accelerated through the valves with the piston (through a lag;
through the column's resonance on the oil's spring; weighed by the flow's direction)."""
from __future__ import annotations

import math

from sim_backend.effects.base import Hidden

COLUMN_LAG_S = 1e-3  # s: the default form's lag
RESONANCE_HZ, RESONANCE_ZETA = 150.0, 0.3  # the resonant form's


class FluidInertia(Hidden):
    name = "fluid_inertia"
    listed = 90
    unit = "kg"
    form = "mass of the oil column accelerated through the valves (1 ms lag)"
    guess = 0.5
    hi = 100.0
    forms = {"resonant": "the oil column on the oil's spring: its force through a 150 Hz resonance, damping ratio 0.3",
             "direction": "1.5 VALUE while oil flows in compression, 0.5 VALUE in rebound (longer path)"}
    stage = 40

    def start(self, pl):
        self.a = self.a_rate = 0.0  # acceleration through the oil column [m/s^2] and its rate

    def load(self, pl, s):
        if self.value:
            s.F += self.value * self.column(s.h, (s.v - s.v_prev) / s.h, s.v)

    def column(self, h, a, v):
        """Acceleration [m/s^2] the oil column's mass is multiplied by: the damper's,
        through COLUMN_LAG_S; (resonant) through the column's resonance; (direction)
        weighed 1.5 in compression flow, 0.5 in rebound."""
        if self.variant == "resonant":  # semi-implicit: y'' = w^2 (a - y) - 2 zeta w y'
            w = 2 * math.pi * RESONANCE_HZ
            self.a_rate += h * (w * w * (a - self.a) - 2 * RESONANCE_ZETA * w * self.a_rate)
            self.a += h * self.a_rate
            return self.a
        self.a += h / COLUMN_LAG_S * (a - self.a)
        if self.variant == "direction":
            return self.a * (1.5 if v > 0 else 0.5)
        return self.a
