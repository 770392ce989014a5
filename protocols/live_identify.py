"""Identification while `dyno run` runs: an observer of the runner hands every completed
segment's samples to a worker process, which re-identifies on all data so far and sends
back the current estimates with their intervals; the observer prints them and passes them
to the live view. At the end of the run the worker fits the whole model (with the
compressible step) and writes it next to the recording.

The control loop never waits (protocols/segment_feed.py); the recording is another
observer and is not touched by any of this.
"""
from __future__ import annotations

import queue
import sys

import numpy as np

from protocols.segment_feed import SegmentFeed, merged

SHOWN = ("P0", "V0", "K_voil", "friction.C_ifT", "gas_spring.gamma", "friction.x_stick")


class LiveIdentify:
    def __init__(self, description: dict, model_path, live=None, stream=None, real_time=True):
        self.feed = SegmentFeed(_worker, (description, str(model_path)), self._show, real_time)
        self.live, self.stream = live, stream or sys.stderr
        self.latest = None
        self.model_path = model_path

    # runner observer -----------------------------------------------------------------
    def samples(self, drained):
        self.feed.samples(drained)

    def event(self, e):
        self.feed.event(e)

    def _show(self, msg):
        kind, body = msg
        if kind == "estimates":
            self.latest = body
            parts = [f"{e['name']} {_fmt(e)}" for e in body["estimates"] if e["name"] in SHOWN]
            if parts:  # nothing to show before the first step has its data
                self.stream.write("\nidentify: " + "; ".join(parts) + "\n")
            if self.live is not None and hasattr(self.live, "estimates"):
                self.live.estimates(body["t"], body["estimates"])
        elif kind == "prediction":
            if self.live is not None and hasattr(self.live, "prediction"):
                self.live.prediction(body["t"], body["v"], body["F"], body["F_model"])
            return
        elif kind in ("note", "error"):
            self.stream.write(f"\nidentify: {body}\n")
        self.stream.flush()

    # after the run -------------------------------------------------------------------
    def cancel(self):
        """The run recorded nothing to identify: stop the worker."""
        self.feed.cancel()

    def finish(self, timeout=600.0):
        """Hand over the rest, wait for the final model; returns its path or None."""
        feed = self.feed
        feed.ending.set()
        if feed.buf:
            feed.cut()
        # what the worker has not had yet goes as one batch: one piece at a time, it would
        # re-identify after each (the queue is short) before it got to the final fit
        if feed.backlog:
            feed.inbox.put(("data", *merged(feed.backlog)), timeout=timeout)
        feed.inbox.put(("end", None, None), timeout=timeout)
        feed.backlog = []
        result = None
        while True:
            try:
                kind, body = feed.outbox.get(timeout=timeout)
            except queue.Empty:
                self.stream.write("identify: the final fit did not finish in time\n")
                break
            if kind == "model":
                result = body
                break
            self._show((kind, body))
            if kind == "error":
                break
        feed.stop()
        return result


# SI unit -> (the unit an engineer reads it in, scale): a charge in bar, volumes in cm^3
SHOWN_UNITS = {"Pa": ("bar abs", 1e-5), "m^3": ("cm^3", 1e6), "m^3/K": ("cm^3/K", 1e6), "m": ("mm", 1e3)}


def _fmt(e):
    """An estimate in engineering units: 'P0 24.57 bar abs (24.1..25.0)'."""
    unit, k = SHOWN_UNITS.get(e.get("unit", ""), (e.get("unit", ""), 1.0))
    unit = "" if unit in ("", "-") else f" {unit}"
    if not e["identifiable"]:
        return f"{e['value'] * k:.4g}{unit} (not identifiable)"
    return f"{e['value'] * k:.4g}{unit} ({e['ci_low'] * k:.4g}..{e['ci_high'] * k:.4g})"


def predicted_force(damper, channels, events, points=2000):
    """{v, F, F_model}: the model's force along the last measured sine or low-speed
    segment's motion (at the segment's temperature) and the measured force
    there, at most `points` samples; None without such a segment or if the model fails."""
    from models.physics.simulate import simulate
    from records.data import segments
    segs = [s for s in segments(events) if s.kind in ("sine", "low-speed")]
    if not segs or not {"force", "x", "v"} <= set(channels):
        return None
    _, _, t0, t1 = segs[-1]
    t, F = channels["force"]
    k = np.flatnonzero((t >= t0) & (t <= t1))[::max(1, int(np.sum((t >= t0) & (t <= t1))) // points)]
    if len(k) < 10:
        return None
    x, v = (np.interp(t[k], *channels[n]) for n in ("x", "v"))
    T = float(np.mean(np.interp(t[k], *channels["T_body"]))) if "T_body" in channels else 293.15
    try:
        r = simulate(damper, np.linspace(t[k[0]], t[k[-1]], len(k)), np.clip(x, 0.0, damper.geometry.stroke), v,
                     T=T, x_e=damper.mid_stroke)  # compressible (eq 3.19-3.32): the loop's phase
    except Exception:  # noqa: BLE001 - a model that cannot run yet shows nothing, the fit goes on
        return None
    return {"v": v, "F": F[k], "F_model": r.force}


def _worker(inbox, outbox, ending, description, model_path):
    """Accumulate segments; after each batch re-identify (without the slow compressible
    step); at the end identify everything and save the model. Once the run is over
    (`ending`), the batches still queued are only collected: an estimate of part of the
    data would delay the final fit (by a minute on the tests' short run)."""
    from models import damper as dm
    from models.identify import identify
    from records.files import written
    from rig.errors import UsageError
    desc = dm.from_dict(description)
    channels, events = {}, []
    done = False
    while not done:
        items = [inbox.get()]
        while True:  # catch up: only the newest data matters for the next estimate
            try:
                items.append(inbox.get_nowait())
            except queue.Empty:
                break
        for kind, chunk, evs in items:
            if kind == "end":
                done = True
                continue
            for n, (t, v) in chunk.items():
                T, V = channels.get(n, (np.empty(0), np.empty(0)))
                channels[n] = (np.concatenate([T, t]), np.concatenate([V, v]))
            events += evs
        if not channels or "force" not in channels or (ending.is_set() and not done):
            continue
        try:
            res = identify(channels, events, desc, progress=lambda m: None, dynamic=done)
        except Exception as e:  # noqa: BLE001 - partial data: say so and wait for more
            if done:
                outbox.put(("error", f"final identification failed: {e}"))
                return
            outbox.put(("note", f"waiting for more data ({e})"))
            continue
        t_now = float(channels["force"][0][-1])
        outbox.put(("estimates", {"t": t_now, "estimates": [
            {"name": e.name, "value": float(e.value), "ci_low": float(e.ci_low), "ci_high": float(e.ci_high),
             "unit": e.unit, "identifiable": bool(e.identifiable)} for e in res.estimates]}))
        if not done:
            predicted = predicted_force(res.damper, channels, events)
            if predicted is not None:
                outbox.put(("prediction", {"t": t_now, **predicted}))
        if done:
            res.damper.name = f"{desc.name}-identified"
            res.damper.description = "identified live by dyno run"
            try:
                with written(model_path, "--identify") as tmp:
                    dm.save(res.damper, tmp)
            except (dm.DamperError, UsageError) as e:
                outbox.put(("error", f"identified model not written: {e}"))
                return
            outbox.put(("note", f"held-out loop NRMSE {100 * res.heldout_nrmse:.2f} %" if res.heldout
                        else "no segment held out (too few): the model is not validated"))
            outbox.put(("model", model_path))
            return
    outbox.put(("error", "no data to identify"))
