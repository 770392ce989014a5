"""Runs a protocol's segments through the control loop, streaming to observers (the
recorder, the live view, later the identification hook: anything with `samples(drained)`,
`event(e)` with an Event of records/events.py and optionally `setpoints(t, x)`), with events
at every segment boundary and a progress line with an ETA.

An observer that raises (a full disk under the recorder) is not called again, and the run
trips with its error on that tick: the actuator stops safely and the other observers go on.
"""
from __future__ import annotations

import math
import queue
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from records.events import (Event, Fault, OperatorStop, ClosedLoopResult, RunEnd, RunStart, SegmentEnd, SegmentStart,
                            Skipped)
from rig.errors import RigError
from rig.loop import ControlLoop, LoopResult, describe

from protocols.display import shown
from protocols.plan import Plan, as_dict
from protocols.units import Units


class ProgressLine:
    """One terminal line: bar, segment, ETA. A segment that waits for a reading to reach a
    target (Segment.target: warming, cooling) has no known length: its remaining time is
    the distance to the target over the rate of approach so far, and each wait still to
    come is named as such rather than counted at its timeout (30 min of a cooling that
    takes 3 would make the ETA meaningless). Into a log (a stream that is not a terminal)
    the line is written whole, once per segment and every LOG_EVERY_S, not redrawn."""

    LOG_EVERY_S = 10.0

    def __init__(self, segments, name, stream=None, units=Units()):
        self.segments, self.name, self.units = segments, name, units
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t_wall0 = time.monotonic()
        self.last = 0.0
        self.logged = (None, -1e9)  # (segment, wall time) of the last line written to a log
        self.start = None  # (ts, value) of the current wait, a few seconds in
        self.shown = 0.0  # the fraction shown last

    def show(self, i, ts, done_s, readings=None, final=None):
        """i: current segment, ts: seconds into it, done_s: seconds run so far; final: the
        last line's label ("done", "stopped")."""
        now = time.monotonic()
        if not final and now - self.last < 0.25:
            return
        if not (self.tty or final or i != self.logged[0] or now - self.logged[1] >= self.LOG_EVERY_S):
            return
        self.last = now
        self.logged = (i, now)
        seg = self.segments[min(i, len(self.segments) - 1)]
        label, eta, waits = final or seg.name, 0.0, 0
        if final != "done":
            left = self.segments[i + 1:]
            eta = sum(s.duration for s in left if s.target is None)
            waits = sum(1 for s in left if s.target is not None)
            if seg.target is None:
                eta += max(seg.duration - ts, 0.0)
            else:
                label, rest = self._wait(seg, ts, readings or {})
                if rest is None:
                    waits += 1
                else:
                    eta += rest
        label = final or label
        # the bar counts time; a wait's share is its time so far, and it is not full while
        # a wait of unknown length is left
        frac = 1.0 if final == "done" else done_s / max(done_s + eta, 1e-9)
        frac = min(frac, 0.99) if waits else frac
        # never backwards: a wait's estimate that grows (or becomes unknown) holds the bar
        frac = self.shown = max(frac, self.shown)
        pace = (now - self.t_wall0) / done_s if done_s > 10 else 1.0  # wall seconds per rig second
        bar = "#" * int(25 * frac) + "." * (25 - int(25 * frac))
        tail = "" if final else f"ETA {eta * pace:5.0f} s" + (f" + {waits} wait{'s' * (waits > 1)}" if waits else "")
        line = f"{self.name} [{bar}] {100 * frac:3.0f} %  {label[:38]:38s} {tail:20s}"
        self.stream.write(f"\r{line}" if self.tty else f"{line.rstrip()}\n")
        if final and self.tty:
            self.stream.write("\n")
        self.stream.flush()

    def _wait(self, seg, ts, readings):
        """(label with the reading against its target, seconds left or None)."""
        name, target = seg.target
        r = readings.get(name)
        if r is None:
            return seg.name, None
        value = r.value
        shown = f"{_shown(name, value, self.units)} of {_shown(name, target, self.units)}"
        if ts < 5.0 or self.start is None or self.start[0] > ts:
            self.start = (ts, value) if ts >= 5.0 else None  # the first seconds: the ramp in
            return f"{seg.name} {shown}", None
        rate = (value - self.start[1]) / max(ts - self.start[0], 1e-9)
        if rate * (target - value) <= 0:  # not approaching (yet)
            return f"{seg.name} {shown}", None
        return f"{seg.name} {shown}", min((target - value) / rate, seg.duration - ts)


class Observer(Protocol):
    """What the runner calls on an observer (the recorder, the live view, the live
    identification); an observer implements those it needs."""

    def samples(self, drained: dict) -> None: ...  # {channel: (t [s], values [SI])} since the last call
    def event(self, e: Event) -> None: ...  # records/events.py
    def setpoints(self, t: list, x: list) -> None: ...  # every setpoint sent [s], [m]
    def units(self, units: dict) -> None: ...  # {channel: unit} of channels a closed loop adds


class Observers:
    """The observers' calls, made in order on a thread of their own: the control loop never
    waits for a disk, a viewer or the identification (a recorder's write and fsync took
    0.6-4 ms in the loop's thread: late ticks, and a force notch at every segment start on
    a wired cell). An observer that raises is not called again; `failed` names it, and the
    runner trips the run on its next tick."""

    def __init__(self, observers):
        self.observers = observers
        self.failed = {}  # observer -> what it raised
        self.queue = queue.SimpleQueue()
        self.thread = threading.Thread(target=self._run, name="observers", daemon=True)
        self.thread.start()

    def call(self, method, *args):
        self.queue.put((method, args))

    def _run(self):
        while (item := self.queue.get()) is not None:
            method, args = item
            for o in self.observers:
                if o in self.failed or not hasattr(o, method):
                    continue
                try:
                    getattr(o, method)(*args)
                except Exception as e:  # noqa: BLE001 - one observer's failure stops the run, not the others
                    self.failed[o] = f"{type(o).__name__.lower()}: {describe(e)}"

    def close(self):
        """Wait until every call so far has been made."""
        self.queue.put(None)
        self.thread.join()


class Kept:
    """An observer that keeps what a run sends, in memory (for work on a run's data
    without a recording: calibration, commissioning)."""

    def __init__(self):
        self.channels, self.events = {}, []

    def samples(self, drained):
        for n, (t, v) in drained.items():
            ts, vs = self.channels.setdefault(n, ([], []))
            ts.append(t)
            vs.append(v)

    def event(self, e):
        self.events.append(e)

    def arrays(self):
        """{name: (t, values)} of everything kept."""
        return {n: (np.concatenate(ts), np.concatenate(vs)) for n, (ts, vs) in self.channels.items()}


def _shown(name, value, units):
    """A reading in the unit system: temperatures in C or F (the channels waited on)."""
    if not name.startswith("T_"):
        return f"{value:.4g}"
    v, unit = shown(value, "K", units)
    return f"{v:.1f} {unit}"


def _params(seg):
    """A segment's parameters as its events carry them."""
    return {**seg.params, "kind": seg.kind, "measured": seg.record}


def _started(t, seg):
    return SegmentStart(t, seg.name, _params(seg))


class Sequence:
    """The plan's segments stepped on the run clock: called by the control loop each tick
    with (t, readings), returns the setpoint [m] or None when the plan is done, and emits
    run_start, skipped, segment_start and segment_end events through `event`."""

    def __init__(self, module, params, segments, skipped, event, failed, bar=None, units=Units()):
        self.module, self.params, self.segments, self.skipped = module, params, segments, skipped
        self.event, self.failed, self.bar, self.units = event, failed, bar, units
        self.i, self.t0, self.t_plan, self.t, self.until = 0, None, 0.0, 0.0, math.inf
        self.set_t, self.set_x = [], []
        # the segments' closed-loop controls, each once
        self.controls = list({id(s.control): s.control for s in segments if s.control is not None}.values())

    @property
    def current(self):
        return self.segments[self.i] if self.i < len(self.segments) else None

    def __call__(self, t, readings):
        self.t = t
        if self.t0 is None:
            longest = sum(s.duration for s in self.segments)
            # the plan's size as fields beside the protocol's parameters: a reader takes them, not the sentence
            self.event(RunStart(t, self.module.NAME, as_dict(self.params), f"{len(self.segments)} segments, "
                                f"{longest:.0f} s at most", segment_count=len(self.segments), duration_max_s=longest))
            for name, why in self.skipped:
                self.event(Skipped(t, name, message=why))
            self.t0 = t
            if not self.segments:
                return None
            self.event(_started(t, self.segments[0]))
        ts = self._advance(t, readings)
        if ts is None:
            return None
        if self.failed:
            raise RigError(next(iter(self.failed.values())))
        seg = self.current
        x = seg.x(ts) if seg.control is None else seg.control.setpoint(t, ts, readings)
        self.set_t.append(t)
        self.set_x.append(x)
        if self.bar:
            self.bar.show(self.i, ts, self.t_plan + ts, readings)
        return x

    def _advance(self, t, readings):
        """Seconds into the segment that runs at t (moving on past those that ended), or
        None when the plan is done."""
        seg = self.current
        ts = t - self.t0
        while True:
            end = min(self.until, seg.duration)
            reached = self.until < math.inf or (seg.until is not None and seg.until(readings))
            if ts < end and not reached:
                return ts
            if seg.target is not None and not reached:  # a wait that ran out: its data would be mislabelled
                name, value = seg.target
                r = readings.get(name)
                raise RigError(f"{seg.name}: {name} did not reach its target in {seg.duration:.0f} s "
                               f"({'no reading' if r is None else _shown(name, r.value, self.units)} of "
                               f"{_shown(name, value, self.units)})")
            if ts < end and seg.cycle:  # ended on its reading: run on to the whole cycle
                end = self.until = min(math.ceil(ts / seg.cycle) * seg.cycle, seg.duration)
                if ts < end:
                    return ts
            # a segment that ran its time ended at its boundary, between ticks: the next
            # one starts there, so the motion runs on without a repeated setpoint
            t_end = self.t0 + end if ts >= end else t
            self.until = math.inf
            self.event(SegmentEnd(t_end, seg.name))
            self.t_plan += t_end - self.t0
            self.i += 1
            seg = self.current
            if seg is None:
                return None
            self.t0 = t_end
            ts = t - t_end
            self.event(_started(t_end, seg))

    def drain_setpoints(self):
        out = (list(self.set_t), list(self.set_x))
        self.set_t.clear()
        self.set_x.clear()
        return out

    def drain_channels(self):
        """{name: (t, values)} the closed-loop controls logged since the last call."""
        parts = {}
        for c in self.controls:
            if hasattr(c, "channels"):
                for n, tv in c.channels().items():
                    parts.setdefault(n, []).append(tv)
        # controls may log the same channel (one per replay iteration): joined, none overwrites another's
        return {n: tuple(np.concatenate(a) for a in zip(*tvs)) for n, tvs in parts.items()}

    def after(self):
        """(segment, channels, measures) of each started segment whose control measures
        itself once the rig is safe."""
        for seg in self.segments[:self.i + 1]:
            if seg.control is not None and hasattr(seg.control, "after"):
                yield seg, *seg.control.after()


def _measure(sequence, observed, event):
    """The closed-loop segments' measures, made once the loop has ended (the rig is safe):
    their channels to the observers, a `result` event per segment; [(segment name,
    measures)]."""
    out = []
    try:
        for seg, channels, found in sequence.after():
            if channels:
                observed.call("samples", channels)
            if found:
                event(ClosedLoopResult(sequence.t, seg.name, {**seg.params, "kind": seg.kind, **found},
                             protocol=sequence.module.NAME))
                out.append((seg.name, found))
    except Exception as e:  # noqa: BLE001 - the recording is kept whatever the measures do
        print(f"dyno: measures not made: {describe(e)}", file=sys.stderr)
    return out


@dataclass
class RunResult(LoopResult):
    skipped: list = field(default_factory=list)  # [(segment, why)] the plan's check left out


def run_plan(plan: Plan, cell, observers=(), sinks=(), progress=False, units=Units()) -> RunResult:
    """Execute the plan on the cell (protocols/cell.py); observers get the samples and
    events on a thread of their own, sinks (plain callables) every drained sample batch in
    the loop's; readings in messages and the progress line in `units`. The cell stays open."""
    module, params, info = plan.module, plan.params, cell.info
    observers = [o for o in observers if o is not None]
    skipped = module.check(params, info)
    segments = list(module.plan(params, info))
    bar = ProgressLine(segments, module.NAME, units=units) if progress else None
    observed = Observers(observers)

    def event(e):
        observed.call("event", e)

    sequence = Sequence(module, params, segments, skipped, event, observed.failed, bar, units)

    units = {}
    for c in sequence.controls:
        units.update(getattr(c, "units", {}))
    if units:
        observed.call("units", units)

    def record(samples):
        observed.call("samples", {**samples, **sequence.drain_channels()})
        observed.call("setpoints", *sequence.drain_setpoints())

    loop = ControlLoop(cell.rig, cell.pacer(), cell.safety(), [record, *sinks])
    try:
        result = RunResult(**vars(loop.run(sequence)), skipped=skipped)
    except BaseException:
        observed.close()
        raise
    if bar:
        bar.show(sequence.i, 0.0, sequence.t_plan, final="stopped" if result.fault else "done")
    if result.fault:
        stop = OperatorStop if result.fault == "operator stop" else Fault
        seg = sequence.current
        event(stop(sequence.t, seg.name, _params(seg), result.fault) if seg else stop(sequence.t, message=result.fault))
    result.measures = _measure(sequence, observed, event)
    event(RunEnd(sequence.t, module.NAME, message=result.fault or "completed"))
    observed.close()
    return result
