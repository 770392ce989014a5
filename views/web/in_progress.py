"""Runs being recorded now in a folder, read from their recordings as they are written (the
chunks the recorder flushes every FLUSH_S), never from the rig: what runs, how far it is,
the latest reading of each channel, a trip's reason the moment it is recorded, and the
recent force, displacement and velocity the live page plots (plots())."""
from __future__ import annotations

import json
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mcap.records import Attachment, Channel, Message, Metadata

from records.events import STOPS, Findings, RunStart, SegmentEnd, SegmentStart, DiscoveryVerdict
from rig.errors import UsageError
from records.files import writer
from records.reader import read_event
from records.recorder import intact_from
from views.reports.comparison import run_name
from protocols.units import Units, quantity_of

PLOTTED = ("force", "x", "v")  # the channels the live page plots, kept for KEEP_S
KEEP_S = 20.0  # s of them kept: the force trace's TRACE_S and the running segment's loops
TRACE_S = 10.0  # s of force against time shown
POINTS = 1500  # at most this many points a series sent to the page


@dataclass
class Live:
    """One recording being written, as read so far."""
    target: Path
    pid: int
    offset: int = 0  # bytes read (whole records only)
    inode: int = 0
    topics: dict = field(default_factory=dict)  # channel id -> topic
    meta: dict = field(default_factory=dict)  # metadata name -> {key: value}
    events: list = field(default_factory=list)
    latest: dict = field(default_factory=dict)  # channel -> (t [s], value, unit)
    recent: dict = field(default_factory=dict)  # PLOTTED channel -> [t array, value array], the last KEEP_S
    rig_toml: str = ""  # the rig's configuration, as attached: its limits

    def read_on(self, file: Path):
        """Take in what was written since the last read."""
        st = file.stat()
        if st.st_ino != self.inode or st.st_size < self.offset:
            self.__init__(self.target, self.pid, inode=st.st_ino)
        with open(file, "rb") as f:
            f.seek(self.offset)
            records, end = intact_from(f.read())  # end: into what was read
        self.offset += end
        for r in records:
            if isinstance(r, Channel):
                self.topics[r.id] = r.topic
            elif isinstance(r, Metadata):
                self.meta[r.name] = r.metadata
            elif isinstance(r, Attachment) and r.name == "rig.toml":
                self.rig_toml = r.data.decode(errors="replace")
            elif isinstance(r, Message):
                self._message(self.topics.get(r.channel_id, ""), r.data)

    def _message(self, topic, data):
        if topic == "/events":
            try:
                self.events.append(read_event(json.loads(data)))
            except UsageError:  # a foreign writer's event: the live page shows ours
                pass
        elif topic.startswith("/channels/"):
            d = json.loads(data)
            name = topic.removeprefix("/channels/")
            if d.get("t"):
                values = np.asarray(d["value"], float)  # a sample that is no number is written null
                self.latest[name] = (d["t"][-1], float(values[-1]), d.get("unit", ""))
                if name in PLOTTED:
                    t, v = self.recent.get(name, (np.zeros(0), np.zeros(0)))
                    t, v = np.append(t, d["t"]), np.append(v, values)
                    keep = t >= t[-1] - KEEP_S
                    self.recent[name] = [t[keep], v[keep]]

    @property
    def elapsed_s(self):
        return max((t for t, _, _ in self.latest.values()), default=0.0)

    @property
    def segment(self):
        starts = [e.segment for e in self.events if isinstance(e, SegmentStart)]
        return starts[-1] if starts else "-"

    @property
    def done(self):
        return sum(isinstance(e, SegmentEnd) for e in self.events)

    @property
    def planned(self):
        return next((e.segment_count for e in self.events if isinstance(e, RunStart) and e.segment_count), None)

    @property
    def tripped(self):
        """The reason of a fault or an operator's stop, once recorded; else None."""
        ends = [e for e in self.events if isinstance(e, STOPS)]
        return ends[0].message or ends[0].kind if ends else None

    @property
    def findings(self):
        """[(label, [sentences])], the latest first: the live diagnosis's per segment
        (protocols/live_diagnose.py), and dyno run discover's rounds and verdict."""
        out = []
        for e in self.events:
            p = e.params
            if isinstance(e, Findings) and e.live:
                out.append((e.segment, p.get("findings", [])))
            elif isinstance(e, Findings):
                out.append((f"round {p.get('round', '?')}", [e.message, *(f"Unsure: {u}" for u in p.get("unsure", []))]))
            elif isinstance(e, DiscoveryVerdict):
                out.append(("verdict", [e.message]))
        return out[::-1]

    @property
    def progress(self):
        """'12.3 s · segment 2 of 6: sine 12.7 mm 1 Hz'."""
        return (f"{self.elapsed_s:.1f} s · segment {self.done + 1}" + (f" of {self.planned}" if self.planned else "")
                + f": {self.segment}")

    def as_json(self, units: Units) -> dict:
        """What the live page redraws on each refresh."""
        return {"key": self.target.name, "progress": self.progress, "tripped": self.tripped, "findings": self.findings,
                "readings": self.readings(units), "plots": self.plots(units)}

    def readings(self, units: Units):
        """[(channel, value, unit)] of the latest readings in the unit system."""
        out = []
        for name, (_, v, unit) in sorted(self.latest.items()):
            quantity = quantity_of(unit)
            if quantity is None:
                out.append((name, f"{v:.4g}", unit))
            else:
                out.append((name, f"{units.show(quantity, v):.4g}", units.unit(quantity)))
        return out

    def plots(self, units: Units) -> dict:
        """What the live page draws, in the unit system: force against time over the last
        TRACE_S; the running segment's force against velocity and displacement (what was
        kept of it), with the force the recording's damper model gives along the same
        motion; and the rig's limits. Series thinned to at most POINTS."""
        if "force" not in self.recent:
            return {}
        tF, F = self.recent["force"]
        trace = tF >= tF[-1] - TRACE_S
        out = {"units": {q: units.unit(q) for q in ("force", "length", "velocity")},
               "trace": {"t": _thin(tF[trace]), "force": _thin(units.show("force", F[trace]))}}
        starts = [e.t for e in self.events if isinstance(e, SegmentStart)]
        seg = tF >= (starts[-1] if starts else tF[0])
        if {"x", "v"} <= set(self.recent) and seg.sum() > 2:
            t = tF[seg]
            x, v = (np.interp(t, *self.recent[n]) for n in ("x", "v"))
            out["loop"] = {"x": _thin(units.show("length", x)), "v": _thin(units.show("velocity", v)),
                           "force": _thin(units.show("force", F[seg]))}
            model = self._model_force(t, x, v)
            if model is not None:
                out["loop"]["model"] = _thin(units.show("force", model))
        limits = self._limits()
        if limits:
            out["limits"] = {"force": units.show("force", limits["force_max"]),
                             "x": [units.show("length", limits["x_min"]), units.show("length", limits["x_max"])],
                             "v": units.show("velocity", limits["velocity_max"])}
        return out

    def _model_force(self, t, x, v):
        """The recording's damper model's force [N] along the motion (incompressible: no
        state to settle, quick enough for every refresh), or None without a full model."""
        from models.physics.simulate import simulate
        from views.reports.peaks import recorded_damper
        damper = recorded_damper(self.meta)
        if damper is None:
            return None
        T = self.latest.get("T_body", (0, 293.15, ""))[1]
        k = _thinned(len(t))
        try:
            r = simulate(damper, t[k], np.clip(x[k], 0.0, damper.geometry.stroke), v[k], T=T, compressible=False,
                         x_e=damper.mid_stroke)
        except (ValueError, FloatingPointError):
            return None
        return np.interp(t, t[k], r.force)

    def _limits(self):
        from rig import config as rig_config
        from rig.errors import RigError
        try:
            return rig_config.parse(self.rig_toml).limits if self.rig_toml else None
        except RigError:
            return None

    @property
    def name(self):
        return run_name(self.meta, self.target)


def _thinned(n):
    """Indices of every k-th of n samples, at most POINTS of them, the last always kept."""
    return np.unique(np.r_[np.arange(0, n, max(1, -(-n // POINTS))), n - 1]) if n else np.zeros(0, int)


def _thin(a):
    """A series as the page gets it: at most POINTS values, rounded to 5 significant figures
    (null where no number: JSON has no NaN)."""
    a = np.asarray(a, float)
    return [float(f"{y:.5g}") if np.isfinite(y) else None for y in a[_thinned(len(a))]]


_SEEN: dict[Path, Live] = {}
_READING = threading.Lock()  # the server's threads share what was read so far


def in_progress(folder) -> list[Live]:
    """The runs being recorded under folder now: a recording whose lock a live process holds."""
    with _READING:
        return _in_progress(folder)


def being_written(folder) -> list[tuple[Path, int]]:
    """(recording, writing process) of each recording under folder a live process holds,
    without reading it (what every page's count needs)."""
    out = []
    for lock in sorted(Path(folder).rglob("*.mcap.lock")):
        target = lock.with_name(lock.name.removesuffix(".lock"))
        pid = writer(target)
        if pid is not None:
            out.append((target, pid))
    return out


def _in_progress(folder):
    out = []
    writing = being_written(folder)
    for gone in set(_SEEN) - {target for target, _ in writing}:
        del _SEEN[gone]
    for target, pid in writing:
        partial = target.with_name(f".{target.name}.partial")
        file = partial if partial.exists() else target
        if not file.exists():
            continue
        live = _SEEN.get(target)
        if live is None or live.pid != pid:
            live = _SEEN[target] = Live(target, pid)
        try:
            live.read_on(file)
        except OSError:  # renamed or finished between the look and the read: next time
            continue
        out.append(live)
    return out
