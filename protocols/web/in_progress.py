"""Runs being recorded now in a folder, read from their recordings as they are written (the
chunks the recorder flushes every FLUSH_S), never from the rig: what runs, how far it is,
the latest reading of each channel, and a trip's reason the moment it is recorded."""
from __future__ import annotations

import json
import re
import threading
from dataclasses import dataclass, field
from pathlib import Path

from mcap.records import Channel, Message, Metadata

from protocols.io.files import writer
from protocols.io.recording import intact_from
from protocols.reports.comparison import run_name
from protocols.units import Units, quantity_of

PLANNED = re.compile(r"^(\d+) segments")  # the run_start event's message (protocols/runner.py)


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
            elif isinstance(r, Message):
                self._message(self.topics.get(r.channel_id, ""), r.data)

    def _message(self, topic, data):
        if topic == "/events":
            self.events.append(json.loads(data))
        elif topic.startswith("/channels/"):
            d = json.loads(data)
            if d.get("t"):
                self.latest[topic.removeprefix("/channels/")] = (d["t"][-1], d["value"][-1], d.get("unit", ""))

    @property
    def elapsed_s(self):
        return max((t for t, _, _ in self.latest.values()), default=0.0)

    @property
    def segment(self):
        starts = [e["segment"] for e in self.events if e.get("kind") == "segment_start"]
        return starts[-1] if starts else "-"

    @property
    def done(self):
        return sum(e.get("kind") == "segment_end" for e in self.events)

    @property
    def planned(self):
        for e in self.events:
            m = PLANNED.match(e.get("message", "")) if e.get("kind") == "run_start" else None
            if m:
                return int(m.group(1))
        return None

    @property
    def tripped(self):
        """The reason of a fault or an operator's stop, once recorded; else None."""
        ends = [e for e in self.events if e.get("kind") in ("fault", "operator_stop")]
        return ends[0].get("message") or ends[0]["kind"] if ends else None

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

    @property
    def name(self):
        return run_name(self.meta, self.target)


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
