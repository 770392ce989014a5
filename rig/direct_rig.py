"""A plant without wires: the `Rig` interface (rig/rig.py) read straight off an object that
steps itself (`advance(seconds)`, `readings()` in SI, `command(mode, x)`, `state`, `alarm`),
on its simulated clock. For work that needs the runner's own stepping of a plan but not the
wire protocols: `dyno prove --calibrate` and the diagnosis benchmark run the virtual plant
through protocols.runner exactly as a recorded run does, many times faster than through
the emulators; a real cell's pre-flight runs the damper model alone (protocols/cell.py).

    with protocols.cell.direct(config, damper, PlantOptions(effects=...)) as c:
        protocols.runner.run_plan(plan, c, observers)
"""
from __future__ import annotations

import time

import numpy as np

from rig.codecs.actuator import MODES, STATES, alarm_texts
from rig.rig import Reading


class DirectRig:
    def __init__(self, config, plant):
        """config: a RigConfig (its channels that the plant reads, its limits and rate)."""
        self.config = config
        self.plant = plant
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
        self.plant.command(MODES["follow"], float(x))

    def hold(self):
        self.plant.command(MODES["hold"], 0.0)

    def stop(self):
        self.plant.command(MODES["off"], 0.0)

    def actuator(self):
        return STATES.get(self.plant.state, f"state {self.plant.state}"), alarm_texts(self.plant.alarm)

    def close(self):
        pass
