"""The transducers: the load cell's filter, noise, and the faults a sensor can have (a
hidden effect may lag the LVDT/LVT conditioning or drift the load cell's gain)."""
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


def condition(pl, F, h):
    """One step of h [s] of the load cell's filter on the force F [N]."""
    s = pl.p["sensors"]
    alpha = 1.0 - math.exp(-h / s["force_tau_s"]) if s["force_tau_s"] > 0 else 1.0
    pl.F_meas += alpha * (F - pl.F_meas)


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


def readings(pl):
    """Sensor values in SI, as the transducers would report them, with noise."""
    s, n = pl.p["sensors"], pl.noise()
    # the displacement the force answered (x_lag), else the force seems to lag by 0.24 ms
    force, x, v = pl.F_meas, pl.x_mid, pl.v_d
    if pl.hidden:  # a lag in the conditioning, a drifting gain
        clean = {"force": force, "x": x, "v": v}
        for e in pl.hidden:
            e.read(pl, clean)
        force, x, v = clean["force"], clean["x"], clean["v"]
    force += s["force_noise"] * n[0]
    if "loadcell_stuck" in pl.faults:
        if pl.stuck_force is None:
            pl.stuck_force = force
        force = pl.stuck_force
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
