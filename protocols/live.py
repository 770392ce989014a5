"""The live view in rerun: every channel on one timeline, the current segment's
force-velocity and force-displacement loops as 2D points, protocol progress and events as
text, in a blueprint laid out for an operator; a hardware-in-the-loop run adds the car
(target against measured motion, tracking error, body acceleration, tire load). Batches
go out with `send_columns`, so the view never slows the loop.

Entities (docs/recording.md): channels/<name> (Scalars), loops/force_velocity and
loops/force_displacement (Points2D, current segment), events (TextLog), identify/<name>
(Scalars: the live identification's estimate and its 95 % interval).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from rig.errors import RigError

from protocols.display import shown

TIMELINE = "t"
UNIT_ORDER = ("N", "mm", "mm/s", "C", "bar")  # the views, top to bottom; other units after
UNIT_NAMES = {"N": "force", "mm": "displacement", "mm/s": "velocity", "C": "temperatures", "bar": "pressures"}
LOOP_POINTS = 4000  # the most recent samples of the segment shown in the loops


VIEWER_PORT = 9876  # rerun's default


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
                raise RigError(f"--live: cannot start the rerun viewer ({e}); --rrd FILE saves the view "
                               f"to open later") from None
            if not _listening(VIEWER_PORT):  # no display, say: streaming to it would block
                raise RigError("--live: the rerun viewer did not start (no display?); --rrd FILE saves the "
                               "view to open later")
            sinks.append(rr.GrpcSink())
        if rrd:
            sinks.append(rr.FileSink(str(rrd)))
        if sinks:
            self.rec.set_sinks(*sinks)
        self.channels = dict(channels)
        self.loop = {"x": [], "v": [], "force": []}
        self.segment = ""
        self._layout()

    def _layout(self):
        """The blueprint for the channels known so far, and each channel's name with its
        unit; a closed loop's channels (hardware in the loop) get a column of their own."""
        ch = lambda *names: [f"channels/{n}" for n in names if n in self.channels]  # noqa: E731
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
                                rrb.TimeSeriesView(origin="identify", name="identified (value, 95 % interval)"),
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
        for n, unit in self.channels.items():
            self.rec.log(f"channels/{n}", rr.SeriesLines(names=f"{n} [{shown(0.0, unit)[1]}]"), static=True)

    def units(self, units):
        """Channels a closed loop adds, with their units: laid out in the view."""
        self.channels.update(units)
        self._layout()

    def samples(self, drained):
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
            # velocity in mm/s and displacement in mm keep both axes readable against N
            self.rec.log("loops/force_velocity", rr.Points2D(np.c_[1e3 * np.array(self.loop["v"]), -F], radii=0.5))
            self.rec.log("loops/force_displacement",
                         rr.Points2D(np.c_[1e3 * np.array(self.loop["x"]), -F], radii=0.5))

    def event(self, t, kind, segment, params, message):
        self.rec.set_time(TIMELINE, duration=t)
        if kind == "segment_start":
            for k in self.loop:
                self.loop[k].clear()
        level = rr.TextLogLevel.ERROR if kind in ("fault", "operator_stop") else rr.TextLogLevel.INFO
        self.rec.log("events", rr.TextLog(f"{kind}: {segment} {message}".strip(), level=level))

    def estimates(self, t, estimates):
        """The identification's current estimates (protocols/live_identify.py): each as
        identify/<name> with its 95 % interval as two more series, and a text line."""
        self.rec.set_time(TIMELINE, duration=t)
        for e in estimates:
            if e["identifiable"]:
                self.rec.log(f"identify/{e['name']}", rr.Scalars([e["value"], e["ci_low"], e["ci_high"]]))
        self.rec.log("events", rr.TextLog("identify: " + ", ".join(
            f"{e['name']} {e['value']:.4g}" for e in estimates if e["identifiable"]), level=rr.TextLogLevel.INFO))

    def close(self):
        self.rec.flush(timeout_sec=5.0)
