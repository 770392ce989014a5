"""A Stribeck seal: it grips harder near rest than sliding (Gaussian, exponential,
Lorentzian or a power law in the Stribeck velocity)."""
from __future__ import annotations

import math

from sim_backend.effects.base import Hidden

# Stribeck curve per form: (shape, Stribeck velocity [m/s]); seals run 1-20 mm/s (a choice)
STRIBECK = {None: ("gaussian", 0.005), "exponential": ("exponential", 0.002), "lorentzian": ("lorentzian", 0.01),
            "power": ("power", 0.02), "slow": ("gaussian", 0.001)}


class BreakawayFriction(Hidden):
    name = "breakaway_friction"
    listed = 50
    unit = "-"
    form = "Stribeck seal (Gaussian, 5 mm/s): friction at rest over sliding friction"
    guess = 1.1
    hi = 10.0
    grows = "in its excess over 1"
    forms = {"exponential": "Stribeck seal, exp(-|v| / 2 mm/s)",
             "lorentzian": "Stribeck seal, 1 / (1 + (v / 10 mm/s)^2)",
             "power": "Stribeck seal, a power law (1 + |v| / 20 mm/s)^-2",
             "slow": "Stribeck seal, Gaussian at 1 mm/s"}
    stage = 10

    def load(self, pl, s):
        if self.value != 1.0:
            shape, v_s = STRIBECK[self.variant]
            s.F += s.F_f * (self.value - 1.0) * stribeck(s.v / v_s, shape)


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
