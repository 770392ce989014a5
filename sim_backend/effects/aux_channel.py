"""Damping that follows the adjuster's current (a semi-active valve): the plant records
the current as aux.valve_current and the valve follows it through its solenoid's lag."""
from __future__ import annotations

from sim_backend.effects.base import Hidden

SOLENOID_S = {None: 0.02, "fast": 0.002}  # s: the solenoid's lag per form


class AuxChannel(Hidden):
    name = "aux_channel"
    listed = 130
    unit = "1/A"
    form = "damping change per ampere of the adjuster current aux.valve_current (20 ms solenoid lag)"
    guess = 0.01
    hi = 10.0
    forms = {"fast": "the solenoid follows the current within 2 ms",
             "quadratic": "damping change VALUE (i^2 - 1) / 2: the solenoid's force goes with the current squared "
                          "(VALUE per ampere at 1 A)"}
    stage = 50
    drives = {"aux.valve_current": "valve current"}

    def start(self, pl):
        self.i = pl.i_valve  # A: the current the valve has followed

    def load(self, pl, s):
        if self.value:
            i = self.i
            s.F += self.value * ((i * i - 1.0) / 2 if self.variant == "quadratic" else i - 1.0) * s.F_d

    def advance(self, pl, h):
        self.i += h / SOLENOID_S.get(self.variant, SOLENOID_S[None]) * (pl.i_valve - self.i)
