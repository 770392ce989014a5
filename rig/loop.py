"""The fixed-rate control loop: each tick reads the sensors, checks safety, and sends the
setpoint that the plan computes from that tick's readings (so a hardware-in-the-loop plan
can use the force measured this tick).

    loop = ControlLoop(rig, pacer, safety)
    result = loop.run(plan)            # plan(t, readings) -> x [m], or None when done

A pacer owns time: SimulatedPacer steps the virtual rig (as fast as the CPU allows),
RealTimePacer sleeps to wall-clock deadlines. Any trip (limit, watchdog, device fault,
transport error, operator stop) holds the actuator, moves it slowly to the safe position
when position feedback and the actuator are healthy, and latches: run() returns with
result.fault set and every sample acquired so far passed to the sinks.
"""
from __future__ import annotations

import gc
import os
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from .errors import RigError

SAFE_SPEED = 0.01  # m/s: the controlled move to the safe position
SETTLE_S = 0.2  # hold at the safe position before returning


def _realtime_priority(priority):
    """Switch this thread to SCHED_FIFO; returns the policy to restore, or None if not
    asked for or not allowed."""
    if not priority or not hasattr(os, "SCHED_FIFO"):
        return None
    old = (os.sched_getscheduler(0), os.sched_getparam(0))
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(int(priority)))
    except OSError:
        return None
    return old


class SimulatedPacer:
    """Simulated clock: each tick advances the virtual rig by one period."""

    def __init__(self, virtual_rig, rate_hz):
        self.vr, self.dt = virtual_rig, 1.0 / rate_hz

    def now(self):
        return self.vr.t

    def wait_next(self):
        self.vr.step(self.dt)
        return self.vr.t, 0.0


class RealTimePacer:
    """Wall clock: sleeps to each deadline (the last 0.1 ms spun for precision); returns
    the tick's lateness. With a virtual rig, steps it by the elapsed time."""

    def __init__(self, rate_hz, virtual_rig=None, spin_s=1e-4, fifo_priority=None):
        """fifo_priority: run the loop thread under SCHED_FIFO at this priority (1-99)
        while it runs, if the OS allows (Linux, privileged); as a dedicated cell would."""
        self.dt, self.vr, self.spin = 1.0 / rate_hz, virtual_rig, spin_s
        self.fifo_priority = fifo_priority
        self.t0 = None
        self.k = 0
        self.missed = 0  # ticks skipped after stalls

    def now(self):
        return time.perf_counter() - (self.t0 or time.perf_counter())

    def wait_next(self):
        if self.t0 is None:
            self.t0 = time.perf_counter()
        self.k += 1
        due = deadline = self.t0 + self.k * self.dt
        behind = time.perf_counter() - deadline
        skip = 0
        if behind > self.dt:  # a stall: skip the ticks it swallowed rather than burst them
            skip = int(behind / self.dt)
            self.k += skip
            self.missed += skip
            deadline += skip * self.dt
        while True:
            left = deadline - time.perf_counter()
            if left <= 0:
                break
            if left > self.spin:
                time.sleep(left - self.spin)
        now = time.perf_counter()
        if self.vr is not None:
            self.vr.step(self.dt * (1 + skip))
        return now - self.t0, now - due  # lateness counts the stall


@dataclass
class LoopResult:
    ticks: int = 0
    overruns: int = 0
    duration_s: float = 0.0
    fault: str | None = None
    sched_fifo: bool = False
    missed: int = 0  # ticks skipped after stalls (real time)
    lateness_s: list = field(default_factory=list, repr=False)

    def stats(self, rate_hz):
        late = np.array(self.lateness_s) if self.lateness_s else np.zeros(1)
        return {"rate_hz_target": rate_hz, "rate_hz": self.ticks / self.duration_s if self.duration_s else 0.0,
                "jitter_us": {p: float(np.percentile(late, q) * 1e6) for p, q in
                              (("p50", 50), ("p99", 99), ("p999", 99.9))},
                "overruns": self.overruns, "missed_ticks": self.missed, "ticks": self.ticks,
                "sched_fifo": self.sched_fifo}


class ControlLoop:
    def __init__(self, rig, pacer, safety, sinks=(), drain_every=100):
        self.rig, self.pacer, self.safety = rig, pacer, safety
        self.sinks, self.drain_every = list(sinks), drain_every
        self.period = 1.0 / rig.config.rate_hz

    def _drain(self):
        samples = self.rig.drain()
        for s in self.sinks:
            s(samples)

    def run(self, plan, max_s=None):
        # the cyclic garbage collector pauses for milliseconds at random ticks; the loop
        # makes no reference cycles, so it runs without it and collects when done
        gc_enabled = gc.isenabled()
        gc.disable()
        # a device thread holding the GIL would keep the loop waiting up to the switch
        # interval (5 ms by default)
        switch = sys.getswitchinterval()
        sys.setswitchinterval(1e-4)
        policy = _realtime_priority(getattr(self.pacer, "fifo_priority", None))
        try:
            result = self._run(plan, max_s)
            result.sched_fifo = policy is not None
            return result
        finally:
            if policy is not None:
                os.sched_setscheduler(0, *policy)
            sys.setswitchinterval(switch)
            if gc_enabled:
                gc.enable()

    def _run(self, plan, max_s):
        r = LoopResult()
        self.rig.poll()  # what arrived before the loop starts is not the first tick's work
        started = self.pacer.now()
        t_end_safe = None
        ramp = None
        try:
            while True:
                t, late = self.pacer.wait_next()
                t0 = time.perf_counter()
                r.ticks += 1
                r.lateness_s.append(late)
                if late > self.period:
                    r.overruns += 1
                    if late > self.safety.L["stale_s"] and r.fault is None:
                        r.fault = f"watchdog: control loop stalled for {late * 1e3:.0f} ms"
                        ramp = None
                try:
                    self.rig.poll()
                    readings = self.rig.read()
                    if r.fault is None:
                        r.fault = self.safety.check(readings, t, started, self.rig.actuator())
                        if r.fault is None:
                            x = plan(t - started, readings)
                            if x is None:
                                break
                            if not self.safety.setpoint_ok(x):
                                r.fault = f"setpoint {x:.4f} m outside the stroke limits"
                            else:
                                self.rig.follow(x)
                        if r.fault is not None:
                            ramp = self._safe_ramp(readings, r.fault)
                    if r.fault is not None:
                        done = self._safe_step(ramp, t)
                        if done and t_end_safe is None:
                            t_end_safe = t + SETTLE_S
                        if t_end_safe is not None and t >= t_end_safe:
                            break
                except RigError as e:
                    if r.fault is None:
                        r.fault = str(e)
                        ramp = None
                    self._try_hold()
                    if t_end_safe is None:
                        t_end_safe = t + SETTLE_S
                    if t >= t_end_safe:
                        break
                if r.ticks % self.drain_every == 0:
                    self._drain()
                if max_s is not None and t - started >= max_s and r.fault is None:
                    break
                if time.perf_counter() - t0 > self.period:
                    r.overruns += 1
        except KeyboardInterrupt:
            r.fault = r.fault or "operator stop"
            self._try_hold()
        finally:
            r.duration_s = self.pacer.now() - started
            r.missed = getattr(self.pacer, "missed", 0)
            self._drain()
        return r

    def _safe_ramp(self, readings, reason):
        """(start x, start t) of the slow move to the safe position, or None to just hold
        (position feedback or the actuator cannot be trusted)."""
        self._try_hold()
        x = readings.get("x")
        state, alarms = self.rig.actuator()
        if x is None or x.fault or state == "alarm" or alarms or "watchdog: x" in reason:
            return None
        return [x.value, None]

    def _safe_step(self, ramp, t):
        """One tick of the safe state; True once it is reached."""
        if ramp is None:
            self._try_hold()
            return True
        if ramp[1] is None:
            ramp[1] = t
        target = self.rig.config.safe_position
        x0 = ramp[0]
        step = SAFE_SPEED * (t - ramp[1])
        x = target if abs(target - x0) <= step else x0 + np.sign(target - x0) * step
        try:
            self.rig.follow(float(x))
        except RigError:
            return True
        return x == target

    def _try_hold(self):
        try:
            self.rig.hold()
        except RigError:
            pass  # the actuator holds by itself when its setpoints stop (50 ms)
