"""Runs a protocol's segments through the control loop, streaming samples to the sinks
(recorder, live view, the identification hook), with events at every segment boundary
and a progress line with an ETA."""
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


def run(module, params, info, rig, pacer, safety, recorder=None, sinks=(), progress=True):
    """Execute the plan; returns (LoopResult, [skipped (segment, reason)])."""
    skipped = module.check(params, info)
    segments = list(module.plan(params, info))
    total = sum(s.duration for s in segments)
    bar = ProgressLine(total, module.NAME) if progress else None
    state = {"i": 0, "t0": None, "t_plan": 0.0, "t": 0.0}
    set_t, set_x = [], []

    def event(t, kind, seg=None, message=""):
        if recorder is not None:
            recorder.event(t, kind, seg.name if seg else "", seg.params if seg else {}, message)

    def plan(t, readings):
        state["t"] = t
        if state["t0"] is None:
            if recorder is not None:
                recorder.event(t, "run_start", module.NAME, as_dict(params))
                for name, why in skipped:
                    recorder.event(t, "skipped", name, {}, why)
            state["t0"] = t
            if not segments:
                return None
            event(t, "segment_start", segments[0])
        seg = segments[state["i"]]
        ts = t - state["t0"]
        if ts >= seg.duration or (seg.until is not None and seg.until(readings)):
            event(t, "segment_end", seg)
            state["t_plan"] += seg.duration
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
        if recorder is not None:
            recorder.setpoints(set_t, set_x)
        set_t.clear()
        set_x.clear()

    loop = ControlLoop(rig, pacer, safety, [*( [recorder.samples] if recorder else []), record_setpoints, *sinks])
    result = loop.run(plan)
    if bar:
        bar.show(state["t_plan"], "stopped" if result.fault else "done", final=True)
    t_end = state["t"]
    if result.fault:
        kind = "operator_stop" if result.fault == "operator stop" else "fault"
        event(t_end, kind, segments[state["i"]] if state["i"] < len(segments) else None, result.fault)
    if recorder is not None:
        recorder.event(t_end, "run_end", module.NAME, {}, result.fault or "completed")
    return result, skipped
