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
from rig.codecs.actuator import ALARM_BIT, MODES, STATES
from models.physics.simulate import Stepper

from sim_backend import effects as fx_mod

PARAMS = Path(__file__).parent / "plant.toml"
MODE_OFF, MODE_HOLD, MODE_FOLLOW = MODES["off"], MODES["hold"], MODES["follow"]
# The damper's force at the end of a step answers the motion X_LAG steps earlier (it is
# driven by the step's mean velocity, and BDF2 weighs the step's end): the displacement is
# reported from then, so force and motion readings agree in time. 0.46 measured on the
# plain cell: `dyno diagnose` finds no lag between them (|tau| < 11 us) where 0.5 leaves
# 21 us and 0 leaves 240 us.
X_LAG = 0.46
STATE_OFF, STATE_HOLDING, STATE_FOLLOWING, STATE_ALARM = (next(k for k, v in STATES.items() if v == name)
                                                          for name in ("off", "holding", "following", "alarm"))
# stalled against a force beyond its rating, the actuator cannot follow its setpoint
ALARM_FORCE, ALARM_VALVE = ALARM_BIT["following error"], ALARM_BIT["valve fault"]


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
        # free play: the rod sits a gap (mount less rod, [m]) from the mount, bearing on it in
        # compression (contact +1), in rebound (-1) or crossing the clearance (0)
        self.gap = self.fx.get("free_play", 0.0) / 2
        self.x_rod = self.x_act - self.gap
        self.contact = 1
        self.v_rod = self.F_rest = self.F_grip = 0.0
        self.curve = self._damping_curve() if self.gap else None
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
            if self.curve is not None:
                self.curve = self._damping_curve()
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
            x_rod, v_rod = self._rod_in_clearance(h, c, v_prev)
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
            self.F_rest, self.F_grip = F - F_d - F_f, abs(F_f)
            if self.contact == 0:
                return 0.0, F_d, P1, P2, Pg  # crossing the clearance: the load cell feels nothing
        return F, F_d, P1, P2, Pg

    def _damping_curve(self):
        """(v [m/s], F [N]): the damper's damping at steady speed, mid-stroke, at its present
        temperature (incompressible), rising with v; what a free rod floats on."""
        from models.physics.simulate import simulate
        v = np.r_[-np.geomspace(5.0, 1e-6, 120), 0.0, np.geomspace(1e-6, 5.0, 120)]
        x = np.full(len(v), self.stepper.x_e)
        F = simulate(self.damper, np.arange(len(v)) * 1e-3, x, v, T=self.T, compressible=False,
                     x_e=self.stepper.x_e).damping
        return v, np.maximum.accumulate(F)

    def _rod_in_clearance(self, h, c, v_prev):
        """(x [m], mean v over the step [m/s]) of the damper's rod when its mount has a
        clearance c [m]. In contact the rod moves with the mount, whose speed ramps from
        v_prev to v_d over the step. The contact opens where the force it carries would change
        sign; the rod (massless) then floats at the speed v_f where the damper's force on it
        is zero (its damping curve against the rest: gas, friction), and the mount moves away
        from it at v - v_f until the gap is crossed. Followed within the step, so a crossing
        shorter than a step ends when it ends: the load cell reads zero only at the
        instants inside one."""
        v_tab, F_tab = self.curve
        rest = self.F_rest + self.F_grip * math.copysign(1.0, self.v_d)  # force besides damping
        v_f = float(np.interp(-rest, F_tab, v_tab))
        side, g0 = self.contact, self.gap
        g, t_a = g0, 0.0
        if side:
            if side * (rest + float(np.interp(self.v_d, v_tab, F_tab))) >= 0:  # stays in contact
                t_a = h
            elif self.v_d != v_prev:  # opens within the step, where the mount passes v_f
                t_a = h * min(max((v_f - v_prev) / (self.v_d - v_prev), 0.0), 1.0)
        if t_a < h:
            u = np.linspace(t_a, h, 65)
            v = v_prev + (self.v_d - v_prev) * u / h  # the mount's speed
            gap = g + np.r_[0.0, np.cumsum(0.5 * (v[1:] + v[:-1] - 2 * v_f) * np.diff(u))]
            hit = np.nonzero(np.abs(gap[1:]) >= c / 2)[0] + 1
            if len(hit):  # the gap closes on one side within the step: contact from there on
                side = 1 if gap[hit[0]] > 0 else -1
                g = side * c / 2
            else:
                side, g = 0, float(gap[-1])
        self.contact, self.gap = side, g
        self.x_rod = self.x_d - g
        self.v_rod = self.v_d - (g - g0) / h  # the mount's motion less the gap's change
        return self.x_rod, self.v_rod

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
