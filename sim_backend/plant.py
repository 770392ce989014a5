"""The virtual test cell: servo-hydraulic actuator, load frame, the damper model from
models/ (compressible, with its chamber pressures), a lumped thermal model, and sensors
with noise and filtering. Parameters: sim_backend/plant.toml.

The plant runs on whatever clock advances it: `advance(seconds)` steps it by that much
simulated time (as fast as the CPU allows, or paced by a real-time thread). It knows
nothing of wires: emulators read `readings()` (SI) and feed `command()`.
"""
from __future__ import annotations

import math
import tomllib
from collections import deque
from pathlib import Path

import numpy as np

from models.damper import load as load_damper
from models.simulate import Stepper

PARAMS = Path(__file__).parent / "plant.toml"
MODE_OFF, MODE_HOLD, MODE_FOLLOW = 0, 1, 2
STATE_OFF, STATE_HOLDING, STATE_FOLLOWING, STATE_ALARM = 0, 1, 2, 3
ALARM_FORCE, ALARM_VALVE = 1 << 0, 1 << 1  # see rig/dyno.dbc


class Plant:
    def __init__(self, damper="koni", T0=None, h=5e-4, seed=0, params=None):
        self.p = params or tomllib.loads(PARAMS.read_text())
        self.damper = load_damper(damper) if isinstance(damper, str) else damper
        self.h = h
        self.t = 0.0
        self.rng = np.random.default_rng(seed)
        a, th = self.p["actuator"], self.p["thermal"]
        self.T = th["ambient"] if T0 is None else float(T0)
        self.T_res = self.T
        self.x_act = self.damper.mid_stroke  # actuator position, in damper x [m]
        self.v_act = 0.0
        self.setpoint = self.setpoint_from = self.x_act
        self.cmd_period = 1e-3
        self.mode = MODE_HOLD
        self.hold_at = self.x_act
        self.last_command_t = 0.0
        self.alarm = 0
        self.faults = set()  # sensor/actuator faults injected by tests or `--fault`
        self._stuck_force = None
        self.stepper = Stepper(self.damper, self.T, self.x_act, h, x_stick=self.p["frame"]["friction_x_stick"])
        self.F_frame = 0.0  # force the frame deflects under (low-passed)
        self._T_packed = self.T
        self.x_gas = self.x_act  # where the gas last reached thermal equilibrium
        self.F = self.F_d = 0.0
        self.P = (0.0, 0.0, 0.0)
        self.x_d = self.x_act
        self.v_d = 0.0
        self.F_meas = 0.0
        n_lag = int(round(a["internal_lvdt_lag_s"] / h))  # the oldest entry is n_lag steps old
        self._lag = deque([self.x_act] * (n_lag + 1), maxlen=n_lag + 1)
        self.energy = 0.0  # J dissipated by damping

    # --- inputs -------------------------------------------------------------------------
    def command(self, mode, setpoint):
        """A setpoint frame from the controller: mode (0 off, 1 hold, 2 follow), x [m].
        Like a servo controller, it ramps from the previous setpoint to this one over one
        command period (first-order hold): a setpoint that jumps every period would make
        the piston's velocity ripple at the command rate, which no real actuator and LVT
        show (they filter it) and which would bias every velocity sample."""
        self.setpoint_from = self._target_now() if self.mode == MODE_FOLLOW else self.x_act
        self.cmd_period = min(max(self.t - self.last_command_t, self.h), 0.01)
        self.last_command_t = self.t
        if mode == MODE_HOLD and self.mode != MODE_HOLD:
            self.hold_at = self.x_act
        self.mode, self.setpoint = int(mode), float(setpoint)

    def _target_now(self):
        frac = min((self.t - self.last_command_t) / self.cmd_period, 1.0)
        return self.setpoint_from + (self.setpoint - self.setpoint_from) * frac

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
        a, h = self.p["actuator"], self.h
        if self.t - self.last_command_t > a["command_timeout_s"] and self.mode == MODE_FOLLOW:
            self.mode, self.hold_at = MODE_HOLD, self.x_act  # lost controller: hold
        if "actuator_alarm" in self.faults:
            self.alarm |= ALARM_VALVE
        if self.alarm or self.mode == MODE_OFF:
            target = None
        else:
            target = self._target_now() if self.mode == MODE_FOLLOW else self.hold_at
        if target is None:
            v = 0.0  # valve closed: the oil column locks the piston
        else:
            v = 2 * math.pi * a["bandwidth_hz"] * (target - self.x_act)
            v = min(max(v, -a["velocity_max"]), a["velocity_max"])
        if abs(self.F) > a["force_max"] and v * self.F > 0:
            v = 0.0  # stalled against the damper
            self.alarm |= ALARM_FORCE
        self.v_act = v
        self.x_act += v * h
        self._lag.append(self.x_act)
        # the damper sees the actuator less the frame's give under the force, low-passed
        # over the frame's time constant: explicit, and stable with Dahl friction
        fr = self.p["frame"]
        self.F_frame += h / fr["tau_s"] * (self.F - self.F_frame)
        x_d = self.x_act - self.F_frame / fr["stiffness"]
        self.v_d = (x_d - self.x_d) / h
        self.x_d = x_d
        F, F_d, F_g, F_f, P1, P2, Pg = self.stepper.step(self.x_d, self.v_d)
        self.F, self.F_d, self.P = F, F_d, (Pg, P1, P2)
        # thermal: damping power heats the body, convection cools it
        th = self.p["thermal"]
        power = abs(F_d * self.v_d)
        self.energy += power * h
        self.T += h * (power - th["conductance"] * (self.T - th["ambient"])) / th["heat_capacity"]
        self.T_res += h * (self.T - self.T_res) / th["reservoir_tau_s"]
        if abs(self.T - self._T_packed) > 0.5:  # re-pack the model every half kelvin
            self.stepper.set_temperature(self.T)
            self._T_packed = self.T
        # the gas is polytropic about x_gas (eq 4.4) and exchanges heat towards isothermal
        # at its present position over tau (what a static dwell waits for, eq 3.7)
        self.x_gas += h / th["gas_tau_s"] * (self.x_d - self.x_gas)
        if abs(self.x_gas - self.stepper.x_e) > 1e-4:
            self.stepper.set_equilibrium(self.x_gas)
        s = self.p["sensors"]
        alpha = 1.0 - math.exp(-h / s["force_tau_s"])
        self.F_meas += alpha * (F - self.F_meas)
        self.t += h

    # --- outputs ------------------------------------------------------------------------
    def readings(self):
        """Sensor values in SI, as the transducers would report them, with noise."""
        s, n = self.p["sensors"], self.rng.standard_normal(8)
        force = self.F_meas + s["force_noise"] * n[0]
        if "loadcell_stuck" in self.faults:
            if self._stuck_force is None:
                self._stuck_force = force
            force = self._stuck_force
        return {
            "force": force,
            "x": self.x_d + s["x_noise"] * n[1],
            "v": self.v_d + s["v_noise"] * n[2],
            "x_internal": self._lag[0],
            "T_body": self.T + s["temperature_noise"] * n[3],
            "T_reservoir": self.T_res + s["temperature_noise"] * n[4],
            "P_gas": self.P[0] + s["pressure_noise"] * n[5],
            "P1": self.P[1] + s["pressure_noise"] * n[6],
            "P2": self.P[2] + s["pressure_noise"] * n[7],
        }
