"""Damping that changes with the oil's temperature (eq 4.17's K_effoil), in both
directions or in one."""
from __future__ import annotations

import dataclasses

from models.damper import TempCoeff, TemperatureSensitivity
from sim_backend.effects.base import Hidden


class DampingTemperature(Hidden):
    name = "damping_temperature"
    listed = 80
    unit = "1/K"
    form = "K_effoil of eq 4.17 in both directions (oil density with temperature)"
    guess = 1e-4
    hi = 0.05
    forms = {"compression": "K_effoil of twice VALUE in compression only",
             "rebound": "K_effoil of twice VALUE in rebound only"}
    repack_K = 0.05  # the damping follows the temperature closely

    def describe(self, d):
        k, form = self.value, self.variant
        kc = TempCoeff(K_effoil=2 * k if form == "compression" else 0.0 if form == "rebound" else k, C_fd=0.0)
        kr = TempCoeff(K_effoil=2 * k if form == "rebound" else 0.0 if form == "compression" else k, C_fd=0.0)
        return dataclasses.replace(d, temperature=TemperatureSensitivity(d.temperature.T_ref, kc, kr))
