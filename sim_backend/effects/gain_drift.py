"""The load cell's gain drifting: its reading is the force times a gain that changes over
the run (linearly; settling after power-on; in steps)."""
from __future__ import annotations

import math

from sim_backend.effects.base import Hidden

GAIN_TAU_S = 20.0  # s: the settling form's time constant (a choice: a bridge warming up)
GAIN_STEP_S = 5.0  # s: the stepped form's update period (a choice)


class GainDrift(Hidden):
    name = "gain_drift"
    listed = 140
    unit = "1/s"
    form = "the load cell's gain drifting linearly from the plant's start: its reading times 1 + VALUE t"
    guess = 1e-05
    hi = 0.01
    forms = {"settling": "the gain settling: 1 + VALUE GAIN_TAU_S (1 - exp(-t / GAIN_TAU_S)), the default's rate "
                         "at the start (a bridge warming after power-on)",
             "stepped": "the gain moving in steps of VALUE GAIN_STEP_S every GAIN_STEP_S (an amplifier correcting "
                        "its calibration at intervals)"}

    def read(self, pl, clean):
        clean["force"] = clean["force"] * (1.0 + gain_drift(self.value, self.variant, pl.t))


def gain_drift(rate, form, t):
    """The load cell's gain change [-] at t [s] from the plant's start: rate [1/s] times t
    (the default form), settling towards rate GAIN_TAU_S, or in steps."""
    if form == "settling":
        return rate * GAIN_TAU_S * (1.0 - math.exp(-t / GAIN_TAU_S))
    if form == "stepped":
        return rate * GAIN_STEP_S * math.floor(t / GAIN_STEP_S)
    return rate * t
