"""Diagnosis while `dyno run` runs (issue 47): each finished sine segment is diagnosed in a
worker process against the run's damper model, refitted (the baseline `dyno diagnose`
takes for a recording that names its damper). What it found (where the mismatch lives, the
effects accepted, their rivals, what is left over) goes into the recording as a
`diagnosis` event, to the live view and to the terminal. The control loop never waits
(protocols/segment_feed.py); a segment the worker has not reached when the run ends is
diagnosed before the recording closes, within FINISH_S.
"""
from __future__ import annotations

import queue
import sys
import time
from dataclasses import replace

from records.events import Findings, SegmentEnd, SegmentStart, Skipped
from records.data import segment_kind
from protocols.segment_feed import SegmentFeed

FINISH_S = 60.0  # s the run's end waits for the last segments' findings
MARGIN_S = 0.1  # s of samples kept beyond a segment's ends
MAX_EFFECTS = 2  # effects one segment's diagnosis accepts at most: a segment is short evidence


class LiveDiagnose:
    def __init__(self, description: dict, recorder, live=None, stream=None, real_time=True):
        self.feed = SegmentFeed(_worker, (description,), self._show, real_time)
        self.recorder, self.live, self.stream = recorder, live, stream or sys.stderr
        self.t_now = 0.0
        self.sine = False  # the running segment is a sine
        self.cut_after = None  # [s] a sine segment's end: its samples go to the worker once they reach it
        self.ended = {}  # sine segments handed over and not yet answered: name -> wall clock at their end [s]

    # runner observer -----------------------------------------------------------------
    def samples(self, drained):
        self.feed.samples(drained)
        t = [float(ts[-1]) for ts, _ in drained.values() if len(ts)]
        self.t_now = max([self.t_now, *t])
        if self.cut_after is not None and self.t_now >= self.cut_after:  # a sine's last samples are in: hand over
            self.feed.cut()
            self.cut_after = None
        self.feed.pump()  # an answer is written as soon as it is back, not at the next event

    def event(self, e):
        if isinstance(e, SegmentStart):
            self.sine = segment_kind(e.params) == "sine" and e.measured
        if isinstance(e, SegmentEnd) and self.sine:
            self.ended[e.segment] = time.monotonic()
            self.cut_after = e.t
        self.feed.event(e)

    def _show(self, e):
        """A segment's Diagnosis event (t: its end) or Skipped, from the worker."""
        latency = time.monotonic() - self.ended.pop(e.segment, time.monotonic())
        if isinstance(e, Findings):
            e = replace(e, t=max(self.t_now, e.t), params={**e.params, "segment_end_s": e.t, "latency_s": latency})
            self.recorder.event(e)
            if self.live is not None:
                self.live.event(e)
            self.stream.write(f"\ndiagnose: {e.segment} ({latency:.1f} s after its end): "
                              + " ".join(e.params.get("findings", [])) + "\n")
        else:
            self.stream.write(f"\ndiagnose: {e.segment}: not diagnosed: {e.message}\n")
        self.stream.flush()

    # after the run -------------------------------------------------------------------
    def finish(self, timeout=FINISH_S):
        """Hand over what is left, wait, at most timeout [s], for the findings of the
        segments handed over (the rig is already safe), write them, and stop the worker."""
        feed = self.feed
        if feed.buf or feed.events:
            feed.cut()
        feed.backlog.append(("end", None, None))  # the worker diagnoses what still waits, then ends
        deadline = time.monotonic() + timeout
        while self.ended and time.monotonic() < deadline:
            feed.pump()
            try:
                self._show(feed.outbox.get(timeout=0.2))
            except queue.Empty:
                pass
        if self.ended:
            self.stream.write(f"diagnose: {len(self.ended)} segment(s) not diagnosed within {timeout:.0f} s of the "
                              f"run's end\n")
        feed.cancel()

    def cancel(self):
        self.feed.cancel()


def _worker(inbox, outbox, ending, description):
    """Diagnose each sine segment once the samples up to its end are in (they may come with
    the next segment: the runner hands samples over in batches), against the run's damper
    model refitted. Samples before the oldest segment still waiting are let go."""
    import numpy as np

    from models import damper as dm
    from records.data import segments
    damper = dm.from_dict(description)
    channels, events, done = {}, [], set()
    while True:
        kind, chunk, evs = inbox.get()
        final = kind == "end"
        for n, (t, v) in (chunk or {}).items():
            T, V = channels.get(n, (np.empty(0), np.empty(0)))
            T, V = np.concatenate([T, t]), np.concatenate([V, v])
            order = np.argsort(T, kind="stable")  # a device's batch may come after a later one of another
            channels[n] = (T[order], V[order])
        events += evs or []
        t_in = float(channels["force"][0][-1]) if len(channels.get("force", ((),))[0]) else -np.inf
        waiting = [(n, t0, t1) for n, _, t0, t1 in segments(events, kinds=("sine",)) if (n, t0) not in done]
        for name, t0, t1 in waiting:
            if t1 <= t_in or final:
                done.add((name, t0))
                outbox.put(diagnosed(damper, channels, events, name, t0, t1))
        if final:
            return
        running = [e.t for e in events if isinstance(e, SegmentStart)][-1:]  # it may be a sine still to come
        keep_from = min([t0 for n, t0, _ in waiting if (n, t0) not in done] + running, default=t_in) - MARGIN_S
        channels = {n: (t[t >= keep_from], v[t >= keep_from]) for n, (t, v) in channels.items()}


def diagnosed(damper, channels, events, name, t0, t1):
    """A Diagnosis event: what one sine segment shows against the damper model (t: the
    segment's end); or Skipped, why not."""
    from models.damper import DamperError
    from models.diagnose import diagnose
    from models.diagnose.data import DiagnoseError
    from models.diagnose.words import findings, said
    # a margin beyond the segment's ends: the diagnosis cuts it by its events, and needs a
    # sample at or before its start to interpolate from
    k = {n: (t >= t0 - MARGIN_S) & (t <= t1 + MARGIN_S) for n, (t, _) in channels.items()}
    ch = {n: (t[k[n]], v[k[n]]) for n, (t, v) in channels.items()}
    evs = [e for e in events if e.segment == name and t0 <= e.t <= t1]
    start = time.perf_counter()
    try:
        res = diagnose({n: c for n, c in ch.items() if len(c[0])}, evs, baseline=(damper.name, damper),
                       max_effects=MAX_EFFECTS)
    except (DiagnoseError, DamperError) as e:
        return Skipped(t1, name, message=str(e))
    except Exception as e:  # noqa: BLE001 - a live analysis says what failed and goes on to the next segment
        return Skipped(t1, name, message=f"{type(e).__name__}: {e}")
    steps = [{"effect": s.effect, "said": said(s.effect), "size_rms_n": float(s.size_rms_n),
              "rivals": [r[0] for r in s.rivals], "stand_in": bool(s.stand_in), "small": bool(s.small)}
             for s in res.steps]
    named = [said(e) for e in res.named()]
    return Findings(float(t1), name, {"baseline": res.baseline.name, "named": named, "effects": steps,
                                       "findings": findings(res), "within_noise": bool(res.left_over.within_noise),
                                       "diagnosis_s": time.perf_counter() - start},
                     f"{name}: " + ("; ".join(named) or "nothing named"), source="live")
