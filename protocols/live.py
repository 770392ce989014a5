"""The live view in rerun: every channel on one timeline, one view per unit in the
operator's units, the current segment's force-velocity and force-displacement loops as 2D
points scaled to fill their view (a labelled frame gives the full scale), protocol
progress and events as text, and the live identification: each parameter relative to its
first estimate, and the model's force against the last segment's measurement; a
hardware-in-the-loop run adds the car (target against measured motion, tracking error,
body acceleration, tire load). Batches go out with `send_columns`, so the view never
slows the loop.

Entities (docs/recording.md): channels/<name> (Scalars), loops/force_velocity and
loops/force_displacement (Points2D, current segment, with a frame .../scale), events
(TextLog), identify/params/<name> (Scalars: estimate and 95 % interval over the first
estimate), identify/fit/measured and identify/fit/model (Points2D: force against
velocity of the last segment identified).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from records.events import STOPS, Findings, SegmentStart
from rig.errors import UsageError

from protocols.display import shown

TIMELINE = "t"
UNIT_ORDER = ("N", "mm", "mm/s", "C", "bar")  # the views, top to bottom; other units after
UNIT_NAMES = {"N": "force", "mm": "displacement", "mm/s": "velocity", "C": "temperatures", "bar": "pressures"}
LOOP_POINTS = 4000  # the most recent samples of the segment shown in the loops


VIEWER_PORT = 9876  # rerun's default


def _full_scale(a):
    return max(float(np.max(np.abs(a))), 1e-12) if len(a) else 1.0


def _listening(port, wait_s=5.0):
    import socket
    import time
    t_end = time.monotonic() + wait_s
    while time.monotonic() < t_end:
        with socket.socket() as s:
            s.settimeout(0.2)
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.2)
    return False


class LiveView:
    def __init__(self, channels, spawn=False, rrd=None, recording=None):
        """channels: {name: unit}. spawn: open a viewer; rrd: also save to this file;
        recording: an existing RecordingStream (tests pass a memory one)."""
        self.rec = recording or rr.RecordingStream("dyno")
        sinks = []
        if spawn:
            viewer = Path(sys.executable).parent / "rerun"  # installed with rerun-sdk in our venv
            try:
                rr.spawn(connect=False, executable_path=str(viewer) if viewer.exists() else None,
                         recording=self.rec)
            except RuntimeError as e:
                raise UsageError(f"--live: cannot start the rerun viewer ({e}); --rrd FILE saves the view "
                               f"to open later") from None
            if not _listening(VIEWER_PORT):  # no display, say: streaming to it would block
                raise UsageError("--live: the rerun viewer did not start (no display?); --rrd FILE saves the "
                               "view to open later")
            sinks.append(rr.GrpcSink())
        if rrd:
            sinks.append(rr.FileSink(str(rrd)))
        if sinks:
            self.rec.set_sinks(*sinks)
        self.channels = dict(channels)
        self.loop = {"x": [], "v": [], "force": []}
        self.segment = ""
        self.first, self.named = {}, set()  # each parameter's first estimate; its series named
        self.laid_out = None  # the channels the blueprint sent shows; None: none sent yet
        self._name_series(self.channels)

    def _name_series(self, channels):
        for n, unit in channels.items():
            self.rec.log(f"channels/{n}", rr.SeriesLines(names=f"{n} [{shown(0.0, unit)[1]}]"), static=True)

    def _layout(self):
        """The blueprint, sent once before the first data: a second send_blueprint to a file
        sink can lose the first one's rows in the .rrd (rerun issue #12769), so a closed loop's
        channels, which arrive before the first sample, are laid out with the rest. A
        closed loop's channels (hardware in the loop) get a column of their own."""
        if self.laid_out == set(self.channels):
            return
        self.laid_out = set(self.channels)
        ch = lambda *names: [f"channels/{n}" for n in names if n in self.channels]
        # one view per unit, in the operator's units (force, displacement, velocity,
        # temperatures in C, pressures in bar, then any other)
        by_unit = {}
        for n, unit in self.channels.items():
            if not n.startswith("hil."):
                by_unit.setdefault(shown(0.0, unit)[1], []).append(f"channels/{n}")
        order = sorted(by_unit, key=lambda u: (UNIT_ORDER.index(u) if u in UNIT_ORDER else len(UNIT_ORDER), u))
        columns = [rrb.Vertical(*[rrb.TimeSeriesView(origin="/", contents=by_unit[u], name=f"{UNIT_NAMES.get(u, u)} [{u}]")
                                  for u in order]),                   rrb.Vertical(rrb.Spatial2DView(origin="loops/force_velocity", name="force vs velocity"),
                                rrb.Spatial2DView(origin="loops/force_displacement", name="force vs displacement"),
                                rrb.TimeSeriesView(origin="identify/params",
                                                   name="identified / first estimate (value, 95 % interval)"),
                                rrb.Spatial2DView(origin="identify/fit", name="model (colour) vs measured (grey)"),
                                rrb.TextLogView(origin="events", name="protocol"))]
        if "hil.x_target" in self.channels:
            columns.append(rrb.Vertical(
                rrb.TimeSeriesView(origin="/", contents=ch("hil.x_target", "x", "hil.x_command"),
                                   name="damper: target, measured, command [mm]"),
                rrb.TimeSeriesView(origin="/", contents=ch("hil.error"), name="tracking error [mm]"),
                rrb.TimeSeriesView(origin="/", contents=ch("hil.body_acc", "hil.ref.body_acc"),
                                   name="car: body acceleration [m/s^2]"),
                rrb.TimeSeriesView(origin="/", contents=ch("hil.tire_load", "hil.ref.tire_load"),
                                   name="car: tire load [N]"),
                rrb.TimeSeriesView(origin="/", contents=ch("hil.sprung", "hil.unsprung", "hil.road"),
                                   name="car: body, wheel, road [mm]")))
        self.rec.send_blueprint(rrb.Blueprint(rrb.Horizontal(*columns, column_shares=[3, 2, 3][:len(columns)])))

    def units(self, units):
        """Channels a closed loop adds, with their units: laid out in the view with the rest."""
        self.channels.update(units)
        self._name_series(units)

    def samples(self, drained):
        self._layout()
        for name, (t, v) in drained.items():
            if len(t):  # in the operator's units: C, bar, mm, mm/s
                self.rec.send_columns(f"channels/{name}", indexes=[rr.TimeColumn(TIMELINE, duration=t)],
                                      columns=rr.Scalars.columns(scalars=shown(np.asarray(v, float),
                                                                               self.channels.get(name, ""))[0]))
        if all(len(drained.get(k, ((), ()))[0]) for k in self.loop):
            n = min(len(drained[k][1]) for k in self.loop)
            for k in self.loop:
                self.loop[k].extend(drained[k][1][:n].tolist())
                del self.loop[k][:-LOOP_POINTS]
            t_last = float(drained["force"][0][-1])
            self.rec.set_time(TIMELINE, duration=t_last)
            F = np.array(self.loop["force"])
            x = np.array(self.loop["x"])
            self._loop("loops/force_velocity", np.array(self.loop["v"]), F, "velocity", 1e3, "mm/s")
            self._loop("loops/force_displacement", x - np.mean(x), F, "displacement about the mean", 1e3, "mm")

    def _loop(self, entity, u, F, what, to_unit, unit):
        """Points (u, F) scaled to +-100 in both directions, so a loop fills its square view
        whatever its units, in a frame labelled with the full scale."""
        su, sF = _full_scale(u), _full_scale(F)
        self._points(entity, u / su, F / sF)
        self._frame(entity, f"{what} +-{to_unit * su:.3g} {unit} (across), force +-{sF:.0f} N (up)")

    def _points(self, entity, u, F, color=None):
        """Points scaled to +-1; 2D draws y down, so the force is negated to point up."""
        self.rec.log(entity, rr.Points2D(np.c_[100 * u, -100 * F], radii=0.6, colors=color))

    def _frame(self, entity, label):
        self.rec.log(f"{entity}/scale", rr.Boxes2D(mins=[-100, -100], sizes=[200, 200], labels=[label]))

    def event(self, e):
        self._layout()
        self.rec.set_time(TIMELINE, duration=e.t)
        if isinstance(e, SegmentStart):
            for k in self.loop:
                self.loop[k].clear()
        level = rr.TextLogLevel.ERROR if isinstance(e, STOPS) else rr.TextLogLevel.INFO
        self.rec.log("events", rr.TextLog(f"{e.kind}: {e.segment} {e.message}".strip(), level=level))
        # dyno run discover's rounds; the live diagnosis's findings (protocols/live_diagnose.py)
        for key in ("unsure", "settled", "findings") if isinstance(e, Findings) else ():
            for said in e.params.get(key, []):
                self.rec.log("events", rr.TextLog(f"  {key}: {said}", level=rr.TextLogLevel.INFO))

    def estimates(self, t, estimates):
        """The identification's current estimates (protocols/live_identify.py), named as in
        the model JSON: each as identify/params/<name>, over its first estimate (one axis
        for gamma and a bulk modulus alike), with its 95 % interval; and a text line."""
        self.rec.set_time(TIMELINE, duration=t)
        shown_ = [e for e in estimates if e["identifiable"] and np.isfinite(e["value"])]
        for e in shown_:
            ref = self.first.setdefault(e["name"], abs(e["value"]) or 1.0)
            if e["name"] not in self.named:
                self.named.add(e["name"])
                self.rec.log(f"identify/params/{e['name']}", rr.SeriesLines(
                    names=[f"{e['name']} / {ref:.4g}", "95 % low", "95 % high"]), static=True)
            self.rec.log(f"identify/params/{e['name']}",
                         rr.Scalars([e["value"] / ref, e["ci_low"] / ref, e["ci_high"] / ref]))
        if shown_:
            self.rec.log("events", rr.TextLog("identify: " + ", ".join(f"{e['name']} {e['value']:.4g}" for e in shown_),
                                              level=rr.TextLogLevel.INFO))

    def prediction(self, t, v, F, F_model):
        """The identified model's force (orange) along the last identified segment's motion
        against the measured force (grey), on one scale."""
        self.rec.set_time(TIMELINE, duration=t)
        sv, sF = _full_scale(v), max(_full_scale(F), _full_scale(F_model))
        self._points("identify/fit/measured", v / sv, F / sF, [150, 150, 150])
        self._points("identify/fit/model", v / sv, F_model / sF, [230, 120, 20])
        self._frame("identify/fit", f"velocity +-{1e3 * sv:.3g} mm/s (across), force +-{sF:.0f} N (up)")

    def close(self):
        self._layout()
        self.rec.flush(timeout_sec=5.0)
