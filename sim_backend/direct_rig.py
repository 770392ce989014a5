"""The plant without wires: the `Rig` interface (rig/rig.py) read straight off the plant, on
its simulated clock. For work that needs the runner's own stepping of a plan but not the
wire protocols: `dyno prove --calibrate` and the diagnosis benchmark run through
protocols.runner exactly as a recorded run does, many times faster than through the
emulators.

    with protocols.cell.direct(config, damper, effects=..., seed=...) as c:
        protocols.runner.run_plan(plan, c, observers)
"""
from __future__ import annotations

import time

import numpy as np

from rig.codecs.actuator import STATES, alarm_texts
from rig.rig import Reading
from sim_backend.plant import MODE_FOLLOW, MODE_HOLD, MODE_OFF, Plant


class DirectRig:
    def __init__(self, config, damper="koni", seed=0, T0=None, effects=None, params=None, h=5e-4):
        """config: a RigConfig (its channels that the plant reads, its limits and rate);
        h: the plant's step [s], at most the loop period."""
        self.config = config
        self.plant = Plant(damper, T0=T0, h=min(h, 1.0 / config.rate_hz), seed=seed, params=params, effects=effects)
        self.t = 0.0
        self.wall_start = time.time()
        names = set(self.plant.readings())
        self.names = [n for n in config.channels if n in names]
        self.latest = {}
        self._buf = {n: ([], []) for n in self.names}

    def clock(self):
        return self.t

    def step(self, dt):
        """Advance the plant by dt [s] (the SimulatedPacer's tick)."""
        self.plant.advance(dt)
        self.t += dt

    def open(self):
        pass

    def poll(self):
        r = self.plant.readings()
        for n in self.names:
            self.latest[n] = Reading(self.t, float(r[n]), None)
            ts, vs = self._buf[n]
            ts.append(self.t)
            vs.append(r[n])
        return self.t

    def read(self) -> dict:
        return dict(self.latest)

    def drain(self) -> dict:
        out = {n: (np.array(ts), np.array(vs)) for n, (ts, vs) in self._buf.items()}
        for ts, vs in self._buf.values():
            ts.clear()
            vs.clear()
        return out

    def follow(self, x):
        self.plant.command(MODE_FOLLOW, float(x))

    def hold(self):
        self.plant.command(MODE_HOLD, 0.0)

    def stop(self):
        self.plant.command(MODE_OFF, 0.0)

    def actuator(self):
        return STATES.get(self.plant.state, f"state {self.plant.state}"), alarm_texts(self.plant.alarm)

    def close(self):
        pass
