"""The fixed-rate control loop: each tick reads the sensors, checks safety, and sends the
setpoint that the plan computes from that tick's readings (so a hardware-in-the-loop plan
can use the force measured this tick).

    loop = ControlLoop(rig, pacer, safety)
    result = loop.run(plan)            # plan(t, readings) -> x [m], or None when done

A pacer (rig/pacing.py) owns time: SimulatedPacer steps the virtual rig (as fast as the
CPU allows), RealTimePacer sleeps to wall-clock deadlines. Any trip (limit, watchdog, device fault,
transport error, operator stop) holds the actuator, moves it slowly to the safe position
when position feedback and the actuator are healthy, and latches: run() returns with
result.fault set and every sample acquired so far passed to the sinks.
"""
from __future__ import annotations

import gc
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from rig.errors import RigError
from rig.operator_stop import OPERATOR_STOP, quiet
from rig.pacing import realtime_priority, restore_priority, restore_slice, short_slice
from rig.safe_stop import SafeStop
from rig.stall_trace import StallTrace

STALLED_TICKS = 100  # failed ticks in a row, the clock standing still: the stop cannot settle


@dataclass
class LoopResult:
    ticks: int = 0
    overruns: int = 0
    duration_s: float = 0.0
    fault: str | None = None
    sched_fifo: bool = False
    missed: int = 0  # ticks skipped after stalls (real time)
    lateness_s: list = field(default_factory=list, repr=False)
    measures: list = field(default_factory=list)  # [(segment, {name: value})] the plan's closed loops measured
    stall_trace: str | None = None  # a file of every thread's stack during a stall (rig/stall_trace.py)

    def stats(self, rate_hz):
        late = np.array(self.lateness_s) if self.lateness_s else np.zeros(1)
        return {"rate_hz_target": rate_hz, "rate_hz": self.ticks / self.duration_s if self.duration_s else 0.0,
                "jitter_us": {p: float(np.percentile(late, q) * 1e6) for p, q in
                              (("p50", 50), ("p99", 99), ("p999", 99.9))},
                "overruns": self.overruns, "missed_ticks": self.missed, "ticks": self.ticks,
                "sched_fifo": self.sched_fifo}


def describe(e: BaseException) -> str:
    """One line for an error: a RigError's own words, else its type and message."""
    if isinstance(e, RigError):
        return str(e).splitlines()[0] if str(e) else "rig error"
    if isinstance(e, OSError) and e.strerror:
        return f"{e.strerror}" + (f" ({e.filename})" if e.filename else "")
    return f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else 'no message'}"


class ControlLoop:
    """sinks: callables that get every drained sample batch. A sink that raises (a full
    disk under the recorder) trips the run like any fault, and is not called again."""

    def __init__(self, rig, pacer, safety, sinks=(), drain_every=100):
        self.rig, self.pacer, self.safety = rig, pacer, safety
        self.sinks, self.drain_every = list(sinks), drain_every
        self.period = 1.0 / rig.config.rate_hz

    def run(self, plan, max_s=None):
        """plan(t, readings) -> setpoint [m] or None when done; t on the rig's clock."""
        # the cyclic garbage collector pauses for milliseconds at random ticks; the loop
        # makes no reference cycles, so it runs without it and collects when done
        gc_enabled = gc.isenabled()
        gc.disable()
        # a device thread holding the GIL would keep a wall-clock loop waiting up to the switch
        # interval (5 ms by default); on a simulated clock no deadline waits, and handing the
        # GIL to the recorder's thread every 0.1 ms only costs (the suite's shortened standard
        # run on the direct cell: 39 CPU-s so, 30 without, three runs each)
        switch = sys.getswitchinterval()
        if self.pacer.wall_clock:
            sys.setswitchinterval(1e-4)
        policy = realtime_priority(getattr(self.pacer, "fifo_priority", None))
        # not granted SCHED_FIFO: the normal policy's shortest slice, so a busy program
        # beside the loop yields its core when a tick is due
        slice_ = short_slice() if policy is None and self.pacer.wall_clock else None
        # on the wall clock, the stacks of a stall longer than the watchdog's limit are kept
        self.trace = StallTrace(self.safety.L["stale_s"], self.period) if self.pacer.wall_clock else None
        try:
            with quiet():  # a Ctrl-C is the flag, looked at every tick (rig/operator_stop.py)
                result = self._run(plan, max_s)
            result.sched_fifo = policy is not None
            result.stall_trace = self.trace and self.trace.close()
            return result
        finally:
            if self.trace is not None:
                self.trace.close()
            if policy is not None:
                restore_priority(policy)
            if slice_ is not None:
                restore_slice(slice_)
            sys.setswitchinterval(switch)
            if gc_enabled:
                gc.enable()

    def _stall_said(self):
        """Where the stall's time went, and the file of every thread's stack during it."""
        if self.trace is None:
            return ""
        caught = self.trace.caught()
        return (f" ({self.trace.where_the_time_went()}"
                + (f"; every thread's stack during it: {caught})" if caught else ")"))

    def _run(self, plan, max_s):
        r = LoopResult()
        stop = SafeStop(self.rig.config.safe_position)
        clock = self.rig.clock
        try:
            self.rig.poll()  # what arrived before the loop starts is not the first tick's work
        except Exception as e:  # noqa: BLE001 - every error trips
            stop.trip(describe(e))
        started = t = clock()
        failing = 0  # ticks in a row that failed with the clock standing still
        while not stop.done:
            try:
                late = self.pacer.wait_next()
                t = clock()
                t_work = time.perf_counter()
                r.ticks += 1
                r.lateness_s.append(late)
                if OPERATOR_STOP.is_set() and stop.running:  # Ctrl-C: the flag, never an exception, in here
                    raise KeyboardInterrupt
                if late > self.period:
                    r.overruns += 1
                    if late > self.safety.L["stale_s"] and stop.running:
                        stop.trip(f"watchdog: control loop stalled for {late * 1e3:.0f} ms" + self._stall_said())
                if self.trace is not None:
                    self.trace.tick()
                readings = self._read(stop)
                if stop.running:
                    if self._tick(plan, t, readings, stop) is None:
                        break
                if not stop.running:
                    self._safe_step(stop, t)
                if r.ticks % self.drain_every == 0:
                    self._drain(stop)
                if max_s is not None and t - started >= max_s and stop.running:
                    break
                if time.perf_counter() - t_work > self.period:
                    r.overruns += 1
            except KeyboardInterrupt:
                stop.trip("operator stop")  # the actuator holds where it is
                stop.cannot_move()
            except Exception as e:  # noqa: BLE001 - a bug in the loop itself: stop safely
                stop.trip(f"control loop: {describe(e)}")
                stop.cannot_move()
                # a clock that no longer advances (a virtual rig whose plant fails every
                # step) can never settle the stop: hold, and end the run
                failing = failing + 1 if clock() == t else 0
                if failing >= STALLED_TICKS:
                    break
            else:
                failing = 0
        r.fault = stop.reason
        r.duration_s = t - started
        r.missed = getattr(self.pacer, "missed", 0)
        self._drain(stop)
        return r

    def _read(self, stop):
        """This tick's readings (polled also while stopping: the recording goes on)."""
        try:
            self.rig.poll()
            return self.rig.read()
        except Exception as e:  # noqa: BLE001 - a transport or device failed
            reason = describe(e)
            readings = self.rig.read()
            x = readings.get("x")
            # the safe move needs position feedback from a device other than the one that failed
            if x is None or getattr(e, "device", None) in (None, self.rig.config.channels["x"].device):
                stop.trip(reason)
                stop.cannot_move()
            else:
                stop.trip(reason, self._trusted_x(readings, reason))
            return readings

    def _tick(self, plan, t, readings, stop):
        """One running tick: check, command. None once the plan is done."""
        fault = self.safety.check(readings, t, self.rig.actuator(), getattr(self.rig, "trouble", lambda d: ""))
        if fault is None:
            try:
                x = plan(t, readings)
                if x is None:
                    return None
                x = float(x)
            except RigError as e:  # the plan's own reason to stop (an observer failed)
                fault = describe(e)
            except Exception as e:  # noqa: BLE001 - a protocol's bug: still stop safely
                fault = f"protocol: {describe(e)}"
            else:
                if not self.safety.setpoint_ok(x):
                    fault = f"setpoint {x:.4f} m outside the stroke limits"
                else:
                    try:
                        self.rig.follow(x)
                        return True
                    except Exception as e:  # noqa: BLE001 - any failure to command the actuator trips the run safely
                        stop.trip(describe(e))
                        return False
        stop.trip(fault, self._trusted_x(readings, fault))
        return False

    def _trusted_x(self, readings, reason):
        """The measured position if the actuator may move to the safe position, else None
        (position feedback or the actuator cannot be trusted)."""
        x = readings.get("x")
        state, alarms = self.rig.actuator()
        if x is None or x.fault or state == "alarm" or alarms or "watchdog: x" in reason:
            return None
        return x.value

    def _safe_step(self, stop, t):
        command, x = stop.step(t)
        try:
            if command == "follow":
                self.rig.follow(x)
            elif command == "hold":
                self.rig.hold()
        except Exception:  # noqa: BLE001 - the actuator holds by itself when setpoints stop (50 ms)
            stop.cannot_move()
            try:
                self.rig.hold()
            except Exception:  # noqa: BLE001 - already stopping: its own watchdog holds it
                pass

    def _drain(self, stop):
        try:
            samples = self.rig.drain()
        except Exception as e:  # noqa: BLE001 - whatever a driver raises trips the run, never kills the loop
            stop.trip(f"rig: {describe(e)}")
            return
        for sink in list(self.sinks):
            try:
                sink(samples)
            except Exception as e:  # noqa: BLE001 - a full disk must not leave the actuator moving
                self.sinks.remove(sink)
                owner = getattr(sink, "__self__", None)
                reason = f"{type(owner).__name__.lower() if owner is not None else 'sink'}: {describe(e)}"
                stop.trip(reason, self._trusted_x(self.rig.read(), reason))
