"""Hardware-in-the-loop: a virtual quarter car (thesis chapter 5) around the damper on the
rig. Each control tick the load cell's force advances the car one step (eqs 5.3-5.14),
the car says where the damper must be next, and a compensator (rig/compensation.py)
turns that into the actuator's command ahead of the servo's lag.

Segments: two holds at the installed position (mid-stroke), approached from compression
and from extension, whose mean force is the gas force the car's spring preload is set
against (eqs 3.7, 5.1); a probe (a small multi-sine) that estimates the actuator's delay;
the road. The road segment's prediction (what the
pre-flight checks) is the car with the damper model on the same road.

The load cell's force is used as measured: on the virtual rig, as on a cell with the load
cell on the fixed end, nothing moves between the cell and the damper, so no fixture mass
is subtracted. The stability guard stops the run (safely, like any trip) when the
measured motion leaves the target by more than guard_mm or the compensator's correction
exceeds correction_mm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.damper import DamperError
from models.quarter_car import hil as measures
from models.quarter_car import load as load_car
from models.quarter_car.sim import CarStepper
from models.quarter_car.sim import run as run_car
from rig.compensation import COMPENSATORS, fit, make
from rig.errors import RigError

from protocols.library import roads
from protocols.plan import ParamError, RigInfo, Segment, drain, said_stalled, stalled

NAME = "hil"
REHEARSE = True  # pre-flight: the whole run against the virtual plant first (protocols/rehearsal.py)
PROBE_HZ = (3.0, 7.0, 13.0, 19.0)  # the probe's sines, each PROBE_MM peak
PROBE_MM = 0.4
APPROACH_MM = 1.0  # each hold is approached from this far out
# the tracking guard trips on an error over guard_mm held this long, or on twice guard_mm at
# once: an unstable loop's error grows without bound within a few of its periods, while a
# stall of the host (a late tick on a machine without a real-time kernel) leaves an error
# the servo takes back within its own lag (4 ms). For GUARD_HOLD_S after a stall the guard
# allows, on top, the way the car moved while the actuator held its last command (one
# 17 ms stall over the wires left 4.2 mm at 250 mm/s and tripped a loop that tracked)
GUARD_HOLD_S = 0.02
UNITS = {"hil.x_target": "m", "hil.x_command": "m", "hil.error": "m", "hil.road": "m", "hil.body_acc": "m/s^2",
         "hil.tire_load": "N", "hil.sprung": "m", "hil.unsprung": "m", "hil.delay": "s",
         "hil.ref.body_acc": "m/s^2", "hil.ref.travel": "m", "hil.ref.tire_load": "N"}


@dataclass
class Params:
    car: str = "simulator"  # quarter-car preset or FILE.json
    road: str = "iso8608:C:50"  # see protocols/library/roads.py
    compensator: str = "adaptive"  # none, polynomial, adaptive
    delay_ms: float = 0.0  # the actuator's delay; 0: estimated by the probe
    guard_mm: float = 2.0  # the most the damper may be from where the car wants it (for GUARD_HOLD_S)
    correction_mm: float = 10.0  # the most the compensator may move the command from the target
    hold_s: float = 1.0
    probe_s: float = 2.0


def check(p: Params, rig: RigInfo):
    _car(p)
    if p.compensator not in COMPENSATORS:
        raise ParamError(f"compensator: unknown {p.compensator!r} (known: {', '.join(COMPENSATORS)})")
    if not 0 <= p.delay_ms <= 50:
        raise ParamError(f"delay_ms: 0 (estimate) to 50, got {p.delay_ms:g}")
    for name in ("guard_mm", "correction_mm", "hold_s", "probe_s"):
        if not getattr(p, name) > 0:
            raise ParamError(f"{name}: must be positive, got {getattr(p, name):g}")
    if rig.damper is None:
        raise ParamError("hil: needs a damper model (--damper) for the pre-flight and the reference")
    roads.parse(p.road, rig.rate_hz)
    return []


def _car(p):
    try:
        return load_car(p.car)
    except DamperError as e:
        raise ParamError(f"car: {e}") from None


def plan(p: Params, rig: RigInfo):
    road, qc, h = roads.parse(p.road, rig.rate_hz), _car(p), 1.0 / rig.rate_hz
    loop = CarLoop(p, rig, qc, road)
    for side, watch in ((1, loop.hold_c), (-1, loop.hold_e)):
        x = _approach(rig.x_mid, side * APPROACH_MM / 1e3, p.hold_s)
        yield Segment(f"hold at the installed position from {'compression' if side > 0 else 'extension'}",
                      {"x_mm": rig.x_mid * 1e3}, p.hold_s, x, record=False, control=watch.using(x))
    probe = _probe(rig.x_mid, p.probe_s)
    yield Segment("probe the actuator", {"probe_hz": list(PROBE_HZ), "probe_mm": PROBE_MM}, p.probe_s, probe,
                  record=False, control=loop.probe(probe))
    ref = run_car(qc, rig.damper, road.t, road.y, road.v, T=rig.T_ambient)
    yield Segment(f"hil {p.road}", {"car": qc.name, "road": p.road, "compensator": p.compensator},
                  len(road.t) * h, lambda t: float(np.interp(t, ref.t, ref.damper_x)), kind="road", control=loop)


def summary(m):
    """One line of a road segment's measures."""
    return (f"J2 {100 * m['j2']:.2f} %, delay {m['delay_ms']:.2f} ms (probe {m['probe_delay_ms']:.2f}, residual "
            f"{m['residual_delay_ms']:+.2f}); against the reference (damper model at {m['T_c']:.0f} C): body "
            f"acceleration {100 * m['body_acc_nrmse']:.1f} %, travel {100 * m['travel_nrmse']:.1f} %, tire load "
            f"{100 * m['tire_load_nrmse']:.1f} % NRMS" + said_stalled(m))


def _approach(x_mid, offset, duration):
    """Out by offset and back to x_mid over the first third (half-cosines), then held: the
    seal's friction then points one way (thesis 2.3.1.2's static test, eq 3.7)."""
    T = duration / 3
    return lambda t: x_mid + offset * (0.5 - 0.5 * math.cos(2 * math.pi * min(t / T, 1.0)))


def _probe(x_mid, duration):
    """A small multi-sine about mid-stroke, faded in and out: the actuator's response over
    the band the car moves in, for its delay."""
    def x(t):
        w = min(t / 0.3, (duration - t) / 0.3, 1.0)
        w = 0.5 - 0.5 * math.cos(math.pi * max(w, 0.0))
        return x_mid + w * PROBE_MM / 1e3 * sum(math.sin(2 * math.pi * f * t + i) for i, f in enumerate(PROBE_HZ))
    return x


class _Watch:
    """A segment's setpoint as planned, with every tick's command, position and force kept."""

    def __init__(self, x=None):
        self.x, self.c, self.m, self.f = x, [], [], []

    def using(self, x):
        self.x = x
        return self

    def setpoint(self, t, ts, readings):
        c = self.x(ts)
        if "x" in readings and "force" in readings:  # (the first ticks may have no reading yet)
            self.c.append(c)
            self.m.append(readings["x"].value)
            self.f.append(readings["force"].value)
        return c


class CarLoop:
    """The road segment's control: the car stepped on the measured force, the compensator,
    the guard, the car's channels, and the measures against the reference once done."""

    units = UNITS

    def __init__(self, p: Params, rig: RigInfo, qc, road):
        self.p, self.rig, self.qc, self.road = p, rig, qc, road
        self.h = 1.0 / rig.rate_hz
        self.hold_c, self.hold_e, self._probe = _Watch(), _Watch(), None
        self.car = self.comp = None
        self.delay_probe = float("nan")
        self.log = {n: ([], []) for n in UNITS if not n.startswith("hil.ref")}
        self.x_meas, self.x_tgt, self.times, self.temps = [], [], [], []
        self.ticks = []  # each road tick's time [s]
        self.next = None  # (x, v, a) the car asked for at the last tick
        self.over_since = None  # time the tracking error went over guard_mm
        self.owed, self.owed_until = 0.0, -np.inf  # [m], [s]: the error a stall left, allowed until then

    def probe(self, x):
        self._probe = _Watch(x)
        return self._probe

    def _start(self):
        """At the road's first tick: the static force (the gas force: the mean of the two
        holds' last halves, eq 3.7), the delay from the probe, the car at rest on it."""
        held = [w.f[len(w.f) // 2:] for w in (self.hold_c, self.hold_e) if w.f]
        F_static = float(np.mean([np.mean(f) for f in held])) if held else 0.0
        r = fit(self._probe.c, self._probe.m, self._probe.f, self.h, with_force=False) if self._probe else None
        self.delay_probe = float(r[0][1] / r[0][0]) if r is not None and r[0][0] > 0 else float("nan")
        delay = self.p.delay_ms / 1e3 if self.p.delay_ms > 0 else self.delay_probe
        if -self.h / 2 < delay < 0.0:  # within half a tick of none (a perfect actuator): none
            delay = 0.0
        if not 0.0 <= delay <= 0.05:
            raise RigError(f"hil: the probe's delay estimate {delay * 1e3:.1f} ms is not an actuator's: give delay_ms")
        d = self.rig.damper
        self.car = CarStepper(self.qc, self.road.t, self.road.y, self.road.v, F_static, self.rig.x_mid,
                           d.geometry.stroke)
        self.comp = make(self.p.compensator, delay, self.h, start=r if self.p.delay_ms == 0 else None)
        self.next = self.car.motion()
        self.last = self.next[0]

    def setpoint(self, t, ts, readings):
        if self.car is None:
            self._start()
            self.t0 = ts
        try:
            F, x_m = readings["force"].value, readings["x"].value
        except KeyError as e:
            raise RigError(f"hil: no {e.args[0]} reading: the car cannot be stepped") from None
        self.ticks.append(ts)
        if "T_body" in readings:
            self.temps.append(readings["T_body"].value)
        # the car keeps the rig's time: after ticks the loop skipped (a stall in real time)
        # it takes the steps it missed, on this tick's force. Those steps neither judge nor
        # teach: no command went out at their times and this tick's position is not theirs
        due = max(1, int(round((ts - self.t0) / self.h)) + 1 - self.car.k)
        held = self.last
        for i in range(due):
            if self.car.done:  # the segment's last tick: stay
                break
            now = i == due - 1
            if now and due > 1:  # the target moved on while the actuator held its command
                self.owed = (self.owed if t < self.owed_until else 0.0) + abs(self.next[0] - held)
                self.owed_until = t + GUARD_HOLD_S
            self._step(F, x_m, t - (due - 1 - i) * self.h, now)
        return self.last

    def _step(self, F, x_m, t, measured=True):
        """One car step on the force F [N] with the damper measured at x_m [m] (measured:
        at this step's time, not a step a stall skipped): the guard, the command for the
        next tick, the car's channels."""
        x_t = self.next[0]
        error = x_m - x_t
        if measured:
            self._guard(error, t)
        self.x_meas.append(x_m)
        self.x_tgt.append(x_t)
        self.times.append(t)
        k = self.car.k
        self.next = self.car.step(F)
        c = self.comp.command(*self.next, F)
        if abs(c - self.next[0]) > self.p.correction_mm / 1e3:
            raise RigError(f"hil guard: the compensator's correction {abs(c - self.next[0]) * 1e3:.2f} mm exceeds "
                           f"{self.p.correction_mm:g} mm (compensator {self.comp.name})")
        if measured:
            self.comp.observe(c, x_m, F)
        self.last = c
        s = self.car.s
        for name, value in (("hil.x_target", x_t), ("hil.x_command", c), ("hil.error", error),
                            ("hil.road", self.road.y[k]), ("hil.body_acc", self.car.a1),
                            ("hil.tire_load", self.car.rec[k, 4]), ("hil.sprung", s[0]), ("hil.unsprung", s[1]),
                            ("hil.delay", self.comp.delay_s)):
            ts_, vs_ = self.log[name]
            ts_.append(t)
            vs_.append(value)

    def _guard(self, error, t):
        """Stop the run when the damper is not where the car wants it (error [m] at t [s]),
        less what a stall just left."""
        judged = max(0.0, abs(error) - (self.owed if t < self.owed_until else 0.0))
        over = judged > self.p.guard_mm / 1e3
        self.over_since = (self.over_since if self.over_since is not None else t) if over else None
        if over and (judged > 2 * self.p.guard_mm / 1e3 or t - self.over_since >= GUARD_HOLD_S):
            raise RigError(f"hil guard: the damper is {error * 1e3:+.2f} mm from where the car wants it (guard "
                           f"{self.p.guard_mm:g} mm; compensator {self.comp.name}): the loop is not following")

    def channels(self):
        return drain(self.log)

    def after(self):
        """(reference channels, measures) of the steps the car took."""
        if self.car is None or self.car.k < 10:
            return {}, {}
        hil = self.car.result()
        T = float(np.mean(self.temps)) if self.temps else self.rig.T_ambient
        # the reference: the same car, road and damper model, compressible, on the run's step
        ref = run_car(self.qc, self.rig.damper, hil.t, hil.y_in, hil.v_in, T=T)
        n = len(self.x_meas)
        out = {"j2": measures.j2(self.x_meas, self.x_tgt[:n]),
               "delay_ms": 1e3 * self.comp.delay_s, "probe_delay_ms": 1e3 * self.delay_probe,
               "residual_delay_ms": 1e3 * measures.delay(self.x_tgt[:n], self.x_meas, self.h),
               **measures.compare(hil, ref), "T_c": T - 273.15, "steps": int(self.car.k),
               "compensator": self.comp.name, "stalled": stalled(self.ticks, self.h)}
        times = np.asarray(self.times, float)
        return {f"hil.ref.{k}": (times, v) for k, v in measures.responses(ref).items()}, out
