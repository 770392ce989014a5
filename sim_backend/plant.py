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

from . import effects as fx_mod

PARAMS = Path(__file__).parent / "plant.toml"
MODE_OFF, MODE_HOLD, MODE_FOLLOW = 0, 1, 2
# The damper's force at the end of a step answers the motion X_LAG steps earlier (it is
# driven by the step's mean velocity, and BDF2 weighs the step's end): the displacement is
# reported from then, so force and motion readings agree in time. 0.46 measured on the
# plain cell: `dyno diagnose` finds no lag between them (|tau| < 11 us) where 0.5 leaves
# 21 us and 0 leaves 240 us.
X_LAG = 0.46
MOUNT_K = 1e10  # N/m: the mount's contact stiffness once a clearance is taken up
STATE_OFF, STATE_HOLDING, STATE_FOLLOWING, STATE_ALARM = 0, 1, 2, 3
ALARM_FORCE, ALARM_VALVE = 1 << 0, 1 << 1  # see rig/dyno.dbc


def ramp_lag(y, u0, u, tau, h):
    """A first-order lag's output (time constant tau [s]) after its input ramped from u0 to
    u over h [s]: exact, so a filter far faster than the step still delays a ramp by tau."""
    r = (u - u0) / h
    return u - tau * r + (y - u0 + tau * r) * math.exp(-h / tau)


class Plant:
    def __init__(self, damper="koni", T0=None, h=5e-4, seed=0, params=None, effects=None):
        self.p = params or tomllib.loads(PARAMS.read_text())
        self.fx = dict(effects or {})  # hidden physics, sim_backend/effects.py
        damper = load_damper(damper) if isinstance(damper, str) else damper
        self.damper = fx_mod.damper_with(damper, self.fx)
        self.h = h
        self.t = 0.0
        self.rng = np.random.default_rng(seed)
        a, th = self.p["actuator"], self.p["thermal"]
        self.T = th["ambient"] if T0 is None else float(T0)
        self.T_res = self.T
        self.T_cell = self.T  # the gas charge's temperature where it does not follow the body
        self.gas_share = self.fx.get("gas_temperature", th.get("gas_follows_body", 1.0))
        self.repack_K = 0.05 if {"gas_temperature", "damping_temperature"} & set(self.fx) else th.get("repack_K", 0.5)
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
        self.stepper.set_temperature(self.T, self._T_gas())
        self.x_rod = self.x_act - self.fx.get("free_play", 0.0) / 2  # where the damper's rod is (differs from the mount's with free play)
        self.v_rod = self.F_rod = self.F_rod_d = 0.0
        self.contact = 1  # free play: +1 mount bears in compression, -1 in rebound, 0 crossing the gap
        self.x_sens = self.v_sens = None  # the LVDT/LVT conditioning's filtered outputs
        self.a_f = 0.0  # acceleration through the oil column, low-passed [m/s^2]
        self.aux_rng = np.random.default_rng(seed + 7919)
        self.i_valve = self.i_lag = 1.0  # adjuster current [A] and what the valve has followed
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
        v_prev = self.v_d
        self.v_d = (x_d - self.x_d) / h
        self.x_d = x_d
        F, F_d, P1, P2, Pg = self._damper_step(h, v_prev)
        self.F, self.F_d, self.P = F, F_d, (Pg, P1, P2)
        # thermal: damping power heats the body, convection cools it
        th = self.p["thermal"]
        power = abs(F_d * self.v_d)
        self.energy += power * h
        self.T += h * (power - th["conductance"] * (self.T - th["ambient"])) / th["heat_capacity"]
        self.T_res += h * (self.T - self.T_res) / th["reservoir_tau_s"]
        if abs(self.T - self._T_packed) > self.repack_K:  # re-pack the model as it warms
            self.stepper.set_temperature(self.T, self._T_gas())
            self._T_packed = self.T
        # the gas is polytropic about x_gas (eq 4.4) and exchanges heat towards isothermal
        # at its present position over tau (what a static dwell waits for, eq 3.7)
        self.x_gas += h / th["gas_tau_s"] * (self.x_d - self.x_gas)
        if abs(self.x_gas - self.stepper.x_e) > 1e-4:
            self.stepper.set_equilibrium(self.x_gas)
        # the adjuster current wanders (Ornstein-Uhlenbeck, 2 s, 0.3 A about 1 A); the valve
        # follows it through its solenoid's 20 ms lag
        self.i_valve += h / 2.0 * (1.0 - self.i_valve) + 0.3 * math.sqrt(2 * h / 2.0) * self.aux_rng.standard_normal()
        self.i_lag += h / 0.02 * (self.i_valve - self.i_lag)
        s = self.p["sensors"]
        alpha = 1.0 - math.exp(-h / s["force_tau_s"]) if s["force_tau_s"] > 0 else 1.0
        self.F_meas += alpha * (F - self.F_meas)
        if "sensor_delay" in self.fx and self.fx["sensor_delay"] > 0:  # the conditioning's filter
            x_mid = self.x_d - X_LAG * h * self.v_d  # see readings()
            if self.x_sens is None:
                self.x_sens, self.v_sens, self._u = x_mid, self.v_d, (x_mid, self.v_d)
            tau = self.fx["sensor_delay"]
            self.x_sens = ramp_lag(self.x_sens, self._u[0], x_mid, tau, h)
            self.v_sens = ramp_lag(self.v_sens, self._u[1], self.v_d, tau, h)
            self._u = (x_mid, self.v_d)
        self.t += h

    def _T_gas(self):
        return self.T_cell + self.gas_share * (self.T - self.T_cell)

    def _damper_step(self, h, v_prev):
        """The damper between the mount (at x_d) and the load cell, with the hidden
        effects that live in its load path: (force on the load cell, damping, P1, P2, P_gas)."""
        fx = self.fx
        c = fx.get("free_play", 0.0)
        if c > 0:
            x_rod, v_rod = self._rod_in_clearance(h, c)
        else:
            x_rod, v_rod = self.x_d, self.v_d
        F, F_d, F_g, F_f, P1, P2, Pg = self.stepper.step(x_rod, v_rod)
        if fx.get("breakaway_friction", 1.0) != 1.0:  # Stribeck: the seal grips harder near rest
            F += F_f * (fx["breakaway_friction"] - 1.0) * math.exp(-(v_rod / fx_mod.STRIBECK_V) ** 2)
        if fx.get("fluid_inertia"):
            self.a_f += h / 1e-3 * ((v_rod - v_prev) / h - self.a_f)
            F += fx["fluid_inertia"] * self.a_f
        if fx.get("aux_channel"):
            F += fx["aux_channel"] * (self.i_lag - 1.0) * F_d
        if "cavitation" in fx:  # a chamber below the floor holds the floor: the piston loses that push
            geo, floor = self.damper.geometry, fx["cavitation"]
            if P2 < floor:
                F -= (floor - P2) * (geo.A_p - geo.A_r)
                P2 = floor
            if P1 < floor:
                F += (floor - P1) * geo.A_p
                P1 = floor
        if c > 0:
            self.F_rod, self.F_rod_d = F, F_d
            if self.contact == 0:
                return 0.0, F_d, P1, P2, Pg  # crossing the clearance: the load cell feels nothing
        return F, F_d, P1, P2, Pg

    def _rod_in_clearance(self, h, c):
        """(x, v) of the damper's rod when its mount has a clearance c [m]. The mount bears
        on the rod through a stiff contact (MOUNT_K) on either side of the clearance; the
        rod (massless) moves so that the damper's force, linearised about the last step
        (slope: the damping's secant), equals the contact's. Solved per regime (bearing in
        compression, in rebound, or free), so a clearance crossed within a step costs no
        more than the time it takes."""
        S = max(abs(self.F_rod_d / self.v_rod), 2e3) if abs(self.v_rod) > 1e-4 else 2e4
        g0, F0, v0, kh = self.x_d - self.x_rod, self.F_rod, self.v_rod, MOUNT_K * h
        for side in (1, -1):
            v = (MOUNT_K * (g0 - side * c / 2) - F0 + S * v0) / (S + kh)
            if side * (g0 - v * h) > c / 2:
                self.contact = side
                break
        else:
            v = v0 - F0 / S
            self.contact = 0
        self.x_rod += v * h
        self.v_rod = v
        return self.x_rod, v

    # --- outputs ------------------------------------------------------------------------
    def readings(self):
        """Sensor values in SI, as the transducers would report them, with noise."""
        s, n = self.p["sensors"], self.rng.standard_normal(8)
        force = self.F_meas + s["force_noise"] * n[0]
        if "loadcell_stuck" in self.faults:
            if self._stuck_force is None:
                self._stuck_force = force
            force = self._stuck_force
        # the displacement the force answered (X_LAG), else the force seems to lag by 0.24 ms
        x_mid = self.x_d - X_LAG * self.h * self.v_d
        x, v = (x_mid, self.v_d) if self.x_sens is None else (self.x_sens, self.v_sens)
        return {
            "force": force,
            "x": x + s["x_noise"] * n[1],
            "v": v + s["v_noise"] * n[2],
            "aux.valve_current": self.i_valve + 0.005 * self.aux_rng.standard_normal(),
            "x_internal": self._lag[0],
            "T_body": self.T + s["temperature_noise"] * n[3],
            "T_reservoir": self.T_res + s["temperature_noise"] * n[4],
            "P_gas": self.P[0] + s["pressure_noise"] * n[5],
            "P1": self.P[1] + s["pressure_noise"] * n[6],
            "P2": self.P[2] + s["pressure_noise"] * n[7],
        }
