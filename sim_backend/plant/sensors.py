"""The transducers: the load cell's filter, the LVDT/LVT conditioning (with a hidden
sensor delay), noise, and the faults a sensor can have."""
from __future__ import annotations

import math

# The damper's force at the end of a step answers the motion at the step's middle: it is
# driven by the step's mean velocity (the frame's integrator), so the displacement is
# reported from half a step earlier and force and motion readings agree in time to
# first order. This is the plant's physics, not a calibration against the diagnosis: what
# is left (tens of microseconds, as between a real cell's amplifiers) the diagnosis must
# say as a timing offset of the cell, never as physics of the damper (issue 29).
X_LAG, X_LAG_S = 0.5, 0.0


def x_lag(h):
    """How long before the end of a plant step of h [s] the force's motion was [s]."""
    return X_LAG * h + X_LAG_S


def ramp_lag(y, u0, u, tau, h):
    """A first-order lag's output (time constant tau [s]) after its input ramped from u0 to
    u over h [s]: exact, so a filter far faster than the step still delays a ramp by tau."""
    r = (u - u0) / h
    return u - tau * r + (y - u0 + tau * r) * math.exp(-h / tau)


def condition(pl, F, h):
    """One step of the load cell's filter on the force F [N] and of the conditioning's
    filter on the motion, when a sensor delay is hidden."""
    s = pl.p["sensors"]
    alpha = 1.0 - math.exp(-h / s["force_tau_s"]) if s["force_tau_s"] > 0 else 1.0
    pl.F_meas += alpha * (F - pl.F_meas)
    if "sensor_delay" in pl.fx and pl.fx["sensor_delay"] > 0:  # the conditioning's filter
        x_mid = pl.x_d - x_lag(h) * pl.v_d  # see readings()
        tau, form = pl.fx["sensor_delay"], pl.forms.get("sensor_delay")
        if form == "transport":
            pl.x_sens, pl.v_sens = transport(pl.sens_past, (x_mid, pl.v_d), tau, h)
            return
        if pl.x_sens is None:
            pl.x_sens, pl.v_sens, pl.u_sens = x_mid, pl.v_d, (x_mid, pl.v_d)
            pl.sens_mid = (x_mid, pl.v_d, x_mid, pl.v_d)  # first stage's output and its last input
        if form == "second_order":  # two stages of tau / 2; the second sees the first's output ramp
            ym, vm, u0x, u0v = pl.sens_mid
            ym2, vm2 = ramp_lag(ym, u0x, x_mid, tau / 2, h), ramp_lag(vm, u0v, pl.v_d, tau / 2, h)
            pl.x_sens = ramp_lag(pl.x_sens, ym, ym2, tau / 2, h)
            pl.v_sens = ramp_lag(pl.v_sens, vm, vm2, tau / 2, h)
            pl.sens_mid = (ym2, vm2, x_mid, pl.v_d)
            return
        pl.x_sens = ramp_lag(pl.x_sens, pl.u_sens[0], x_mid, tau, h)
        pl.v_sens = ramp_lag(pl.v_sens, pl.u_sens[1], pl.v_d, tau, h)
        pl.u_sens = (x_mid, pl.v_d)


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


class Normals:
    """A generator's standard normal draws (width at a time, or one), taken a block at a
    time: the same numbers in the same order as one call per draw, without a call's cost
    at every step (the plant draws at each of its steps and each reading)."""
    BLOCK = 4096

    def __init__(self, rng, width=None):
        self.rng, self.shape = rng, self.BLOCK if width is None else (self.BLOCK, width)
        self.block, self.i = [], 0

    def __call__(self):
        if self.i == len(self.block):
            self.block, self.i = self.rng.standard_normal(self.shape).tolist(), 0
        self.i += 1
        return self.block[self.i - 1]


GAIN_TAU_S = 20.0  # s: the settling gain drift's time constant (a choice: a bridge warming up)
GAIN_STEP_S = 5.0  # s: the stepped gain drift's update period (a choice)


def gain_drift(rate, form, t):
    """The load cell's gain change [-] at t [s] from the plant's start: rate [1/s] times t
    (hidden.toml's default), settling towards rate GAIN_TAU_S, or in steps."""
    if form == "settling":
        return rate * GAIN_TAU_S * (1.0 - math.exp(-t / GAIN_TAU_S))
    if form == "stepped":
        return rate * GAIN_STEP_S * math.floor(t / GAIN_STEP_S)
    return rate * t


def readings(pl):
    """Sensor values in SI, as the transducers would report them, with noise."""
    s, n = pl.p["sensors"], pl.noise()
    gain = 1.0 + gain_drift(pl.fx["gain_drift"], pl.forms.get("gain_drift"), pl.t) if "gain_drift" in pl.fx else 1.0
    force = pl.F_meas * gain + s["force_noise"] * n[0]
    if "loadcell_stuck" in pl.faults:
        if pl.stuck_force is None:
            pl.stuck_force = force
        force = pl.stuck_force
    # the displacement the force answered (x_lag), else the force seems to lag by 0.24 ms
    x_mid = pl.x_d - x_lag(pl.h) * pl.v_d
    x, v = (x_mid, pl.v_d) if pl.x_sens is None else (pl.x_sens, pl.v_sens)
    return {
        "force": force,
        "x": x + s["x_noise"] * n[1],
        "v": v + s["v_noise"] * n[2],
        "aux.valve_current": pl.i_valve + 0.005 * pl.aux_noise(),
        "x_internal": pl.lag[0],
        "T_body": pl.T + s["temperature_noise"] * n[3],
        "T_reservoir": pl.T_res + s["temperature_noise"] * n[4],
        "P_gas": pl.P[0] + s["pressure_noise"] * n[5],
        "P1": pl.P[1] + s["pressure_noise"] * n[6],
        "P2": pl.P[2] + s["pressure_noise"] * n[7],
    }
