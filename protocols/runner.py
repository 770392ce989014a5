"""Runs a protocol's segments through the control loop, streaming to observers (the
recorder, the live view, later the identification hook: anything with `samples(drained)`,
`event(t, kind, segment, params, message)` and optionally `setpoints(t, x)`), with events
at every segment boundary and a progress line with an ETA."""
from __future__ import annotations

import sys
import time

from rig.loop import ControlLoop

from .plan import as_dict


class ProgressLine:
    def __init__(self, total_s, name, stream=None):
        self.total, self.name = total_s, name
        self.stream = stream or sys.stderr
        self.t_wall0 = time.monotonic()
        self.last = 0.0

    def show(self, t, segment, final=False):
        now = time.monotonic()
        if not final and now - self.last < 0.25:
            return
        self.last = now
        frac = min(t / self.total, 1.0) if self.total else 1.0
        wall = now - self.t_wall0
        eta = wall / frac * (1 - frac) if frac > 0 else float("nan")
        bar = "#" * int(25 * frac) + "." * (25 - int(25 * frac))
        self.stream.write(f"\r{self.name} [{bar}] {100 * frac:3.0f} %  {segment[:28]:28s} ETA {eta:5.0f} s")
        if final:
            self.stream.write("\n")
        self.stream.flush()


def run(module, params, info, rig, pacer, safety, observers=(), sinks=(), progress=True):
    """Execute the plan; returns (LoopResult, [skipped (segment, reason)]). sinks: plain
    callables that get every drained sample batch."""
    observers = [o for o in observers if o is not None]
    skipped = module.check(params, info)
    segments = list(module.plan(params, info))
    total = sum(s.duration for s in segments)
    bar = ProgressLine(total, module.NAME) if progress else None
    state = {"i": 0, "t0": None, "t_plan": 0.0, "t": 0.0}
    set_t, set_x = [], []

    def event(t, kind, seg=None, message="", name=None, params=None):
        if params is None:
            params = {**seg.params, "measured": seg.record} if seg else {}
        for o in observers:
            o.event(t, kind, name if name is not None else (seg.name if seg else ""), params, message)

    def plan(t, readings):
        state["t"] = t
        if state["t0"] is None:
            event(t, "run_start", name=module.NAME, params=as_dict(params))
            for name, why in skipped:
                event(t, "skipped", name=name, params={}, message=why)
            state["t0"] = t
            if not segments:
                return None
            event(t, "segment_start", segments[0])
        seg = segments[state["i"]]
        ts = t - state["t0"]
        if ts >= seg.duration or (seg.until is not None and seg.until(readings)):
            event(t, "segment_end", seg)
            state["t_plan"] += ts
            if bar:  # a segment that ended early (a dwell settled, a target reached) frees its time
                bar.total += ts - seg.duration
            state["i"] += 1
            if state["i"] == len(segments):
                return None
            seg = segments[state["i"]]
            state["t0"], ts = t, 0.0
            event(t, "segment_start", seg)
        x = seg.x(ts)
        set_t.append(t)
        set_x.append(x)
        if bar:
            bar.show(state["t_plan"] + ts, seg.name)
        return x

    def record_setpoints(samples):
        for o in observers:
            if hasattr(o, "setpoints"):
                o.setpoints(set_t, set_x)
        set_t.clear()
        set_x.clear()

    loop = ControlLoop(rig, pacer, safety, [*(o.samples for o in observers), record_setpoints, *sinks])
    result = loop.run(plan)
    if bar:
        bar.show(state["t_plan"], "stopped" if result.fault else "done", final=True)
    t_end = state["t"]
    if result.fault:
        kind = "operator_stop" if result.fault == "operator stop" else "fault"
        event(t_end, kind, segments[state["i"]] if state["i"] < len(segments) else None, result.fault)
    event(t_end, "run_end", name=module.NAME, params={}, message=result.fault or "completed")
    return result, skipped
