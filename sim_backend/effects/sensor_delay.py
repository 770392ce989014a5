"""A lag in the LVDT/LVT conditioning: the motion readings lag the motion the force
answers (a first-order filter; a pure transport delay; two stages in series)."""
from __future__ import annotations

import math
from collections import deque

import numpy as np

from sim_backend.effects.base import Hidden


class SensorDelay(Hidden):
    name = "sensor_delay"
    listed = 20
    unit = "s"
    form = "time constant of a first-order filter in the LVDT/LVT conditioning"
    guess = 1e-4
    hi = 0.05
    forms = {"transport": "a pure transport delay of VALUE in the LVDT/LVT signal",
             "second_order": "two first-order filters of VALUE / 2 in series (critically damped)"}

    @classmethod
    def without_run(cls, value, t, F0):
        """Every form delays the motion by about its value: the force against itself
        shifted by it."""
        return F0 - np.interp(t - value, t, F0)

    def start(self, pl):
        self.x = self.v = None  # the conditioning's filtered outputs (none before the first step)
        self.mid = None  # its first stage (second-order form)
        self.past = deque(maxlen=int(self.value / pl.h) + 3)  # (x, v) (transport form)

    def advance(self, pl, h):
        if self.value <= 0:
            return
        x_mid, tau = pl.x_mid, self.value
        if self.variant == "transport":
            self.x, self.v = transport(self.past, (x_mid, pl.v_d), tau, h)
            return
        if self.x is None:
            self.x, self.v, self.u = x_mid, pl.v_d, (x_mid, pl.v_d)
            self.mid = (x_mid, pl.v_d, x_mid, pl.v_d)  # first stage's output and its last input
        if self.variant == "second_order":  # two stages of tau / 2; the second sees the first's output ramp
            ym, vm, u0x, u0v = self.mid
            ym2, vm2 = ramp_lag(ym, u0x, x_mid, tau / 2, h), ramp_lag(vm, u0v, pl.v_d, tau / 2, h)
            self.x = ramp_lag(self.x, ym, ym2, tau / 2, h)
            self.v = ramp_lag(self.v, vm, vm2, tau / 2, h)
            self.mid = (ym2, vm2, x_mid, pl.v_d)
            return
        self.x = ramp_lag(self.x, self.u[0], x_mid, tau, h)
        self.v = ramp_lag(self.v, self.u[1], pl.v_d, tau, h)
        self.u = (x_mid, pl.v_d)

    def read(self, pl, clean):
        if self.x is not None:
            clean["x"], clean["v"] = self.x, self.v


def ramp_lag(y, u0, u, tau, h):
    """A first-order lag's output (time constant tau [s]) after its input ramped from u0 to
    u over h [s]: exact, so a filter far faster than the step still delays a ramp by tau."""
    r = (u - u0) / h
    return u - tau * r + (y - u0 + tau * r) * math.exp(-h / tau)


def transport(past, now, tau, h):
    """The signal tau [s] ago (linear between steps), with `now` appended to `past` (a
    deque of the last steps' values, newest last)."""
    past.append(now)
    back = tau / h
    k = int(back)
    if k + 1 >= len(past):  # not yet that long: the oldest
        return past[0]
    a, b = past[-1 - k], past[-2 - k]
    f = back - k
    return tuple((1 - f) * u + f * w for u, w in zip(a, b))
