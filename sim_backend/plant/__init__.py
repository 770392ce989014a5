"""The virtual test cell: servo-hydraulic actuator, load frame, the damper model from
models/ (compressible, with its chamber pressures), a lumped thermal model, and sensors
with noise and filtering, one module each; the hidden effects (sim_backend/effects/)
act through their hooks.
Parameters: sim_backend/plant.toml.

The plant runs on whatever clock advances it: `advance(seconds)` steps it by that much
simulated time (as fast as the CPU allows, or paced by a real-time thread). It knows
nothing of wires: emulators read `readings()` (SI) and feed `command()`.
"""
from __future__ import annotations

import tomllib
from collections import deque
from pathlib import Path

import numpy as np

from models.damper import load as load_damper
from models.physics.simulate import Stepper
from sim_backend import effects as hidden
from sim_backend.extra import compile_extra
from sim_backend.plant import actuator, frame, load_path, sensors, thermal
from sim_backend.plant.actuator import (MODE_FOLLOW, MODE_HOLD, MODE_OFF, STATE_ALARM,
                                        STATE_FOLLOWING, STATE_HOLDING, STATE_OFF)

PARAMS = Path(__file__).parent.parent / "plant.toml"  # the plant's parameters


def plant_params() -> dict:
    """The plant's parameters as shipped (sim_backend/plant.toml)."""
    return tomllib.loads(PARAMS.read_text())


class Plant:
    def __init__(self, damper="koni", T0=None, h=5e-4, seed=0, params=None, effects=None):
        self.p = params or plant_params()
        fx = dict(effects or {})
        extra = fx.pop("extra", None)  # a force the user writes (sim_backend/extra.py)
        self.extra = compile_extra(extra) if extra else None
        self.hidden = hidden.build(fx)  # hidden physics (sim_backend/effects/), each with its own state
        self.load_path = sorted(self.hidden, key=lambda e: e.stage)  # in the order they act on the force
        damper = load_damper(damper)
        for e in self.hidden:
            damper = e.describe(damper)
        self.damper = damper
        self.h = h
        self.t = 0.0
        self.noise = sensors.Normals(np.random.default_rng(seed), 8)  # the transducers' (sensors.readings)
        a, th = self.p["actuator"], self.p["thermal"]
        self.T = th["ambient"] if T0 is None else float(T0)
        self.T_res = self.T
        self.T_cell = self.T  # the gas charge's temperature where it does not follow the body
        self.gas_share = th.get("gas_follows_body", 1.0)
        self.repack_K = min([th.get("repack_K", 0.5)] + [e.repack_K for e in self.hidden if e.repack_K])
        self.x_act = self.damper.mid_stroke  # actuator position, in damper x [m]
        self.x_rod = self.x_act  # the damper's rod's [m] (a hidden free play moves it off the mount)
        self.v_act = 0.0
        self.setpoint = self.setpoint_from = self.x_act
        self.cmd_period = 1e-3
        self.mode = MODE_HOLD
        self.hold_at = self.x_act
        self.last_command_t = 0.0
        self.alarm = 0
        self.faults = set()  # sensor/actuator faults injected by tests or `--fault`
        self.stuck_force = None
        self.stepper = Stepper(self.damper, self.T, self.x_act, h, x_stick=self.p["frame"]["friction_x_stick"])
        self.i_valve = 1.0  # adjuster current [A] (load_path.adjuster)
        self.aux_noise = sensors.Normals(np.random.default_rng(seed + 7919))  # its wander's and reading's
        for e in self.hidden:
            e.start(self)
        self.stepper.set_temperature(self.T, thermal.gas_temperature(self))
        self.F_frame = 0.0  # force the frame deflects under (low-passed)
        self.T_packed = self.T_gas_packed = self.T
        self.x_gas = self.x_act  # where the gas last reached thermal equilibrium
        self.F = self.F_d = 0.0
        self.P = (0.0, 0.0, 0.0)
        self.x_d = self.x_act
        self.v_d = 0.0
        self.F_meas = 0.0
        n_lag = int(round(a["internal_lvdt_lag_s"] / h))  # the oldest entry is n_lag steps old
        self.lag = deque([self.x_act] * (n_lag + 1), maxlen=n_lag + 1)
        self.energy = 0.0  # J dissipated by damping

    # --- inputs -------------------------------------------------------------------------
    def command(self, mode, setpoint):
        """A setpoint frame from the controller: mode (0 off, 1 hold, 2 follow), x [m].
        Like a servo controller, it ramps from the previous setpoint to this one over one
        command period (first-order hold): a setpoint that jumps every period would make
        the piston's velocity ripple at the command rate, which no real actuator and LVT
        show (they filter it) and which would bias every velocity sample."""
        self.setpoint_from = actuator.target_now(self) if self.mode == MODE_FOLLOW else self.x_act
        self.cmd_period = min(max(self.t - self.last_command_t, self.h), 0.01)
        self.last_command_t = self.t
        if mode == MODE_HOLD and self.mode != MODE_HOLD:
            self.hold_at = self.x_act
        self.mode, self.setpoint = int(mode), float(setpoint)

    @property
    def state(self):
        if self.alarm:
            return STATE_ALARM
        return {MODE_OFF: STATE_OFF, MODE_HOLD: STATE_HOLDING, MODE_FOLLOW: STATE_FOLLOWING}[self.mode]

    # --- dynamics -----------------------------------------------------------------------
    def advance(self, seconds):
        for _ in range(max(1, int(round(seconds / self.h)))):
            self._step()

    def _step(self):
        h = self.h
        self.v_act = actuator.velocity(self)
        self.x_act += self.v_act * h
        self.lag.append(self.x_act)
        x_d = frame.mount_position(self, h)
        v_prev = self.v_d
        self.v_d = (x_d - self.x_d) / h
        self.x_d = x_d
        F, F_d, P1, P2, Pg = load_path.damper_step(self, h, v_prev)
        self.F, self.F_d, self.P = F, F_d, (Pg, P1, P2)
        thermal.advance(self, F_d, h)
        load_path.adjuster(self, h)
        sensors.condition(self, F, h)
        for e in self.hidden:
            e.advance(self, h)
        self.t += h

    # --- outputs ------------------------------------------------------------------------
    @property
    def x_mid(self):
        """The mount's position [m] the step's force answered (sensors.x_lag)."""
        return self.x_d - sensors.x_lag(self.h) * self.v_d

    def readings(self):
        """Sensor values in SI, as the transducers would report them, with noise."""
        return sensors.readings(self)
