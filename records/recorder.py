"""MCAP recordings (docs/recording.md): every channel at its native rate in batched
messages, actuator setpoints, protocol and safety events, metadata and the rig config.

JSON messages with JSON Schemas, so any MCAP tool reads them. Chunks are small and closed
at least every FLUSH_S seconds, so a run killed mid-protocol loses at most that much:
`recover()` rebuilds an indexed file from what was written.
"""
from __future__ import annotations

import json
import os
import functools
import re
import subprocess
import time
import zlib
from importlib import metadata
from io import BytesIO
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import orjson
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Chunk, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk
from mcap.writer import MCAP0_MAGIC, CompressionType, Writer

from records.events import KINDS, Event, Fault, OperatorStop, SegmentStart, Skipped
from rig.errors import RigError, UsageError

from records.files import Claim, input_file, not_being_written, output_file, written
from records.mcap_batch import add_messages

FLUSH_S = 0.5


def SAMPLES(payload: dict) -> bytes:
    """A /channels batch as JSON, its arrays written by orjson (a tenth of json's time on a
    million-row import); a sample that is no number is written null, as JSON has no NaN."""
    return orjson.dumps(payload, option=orjson.OPT_SERIALIZE_NUMPY)

SCHEMAS = {
    "dyno.Samples": {
        "type": "object", "title": "dyno.Samples",
        "description": "Consecutive samples of one channel at its native rate, SI units.",
        "properties": {"seq": {"type": "integer", "description": "message counter of this topic, from 0"},
                       "n0": {"type": "integer", "description": "index of the first sample in the channel, "
                                                                "from 0: consecutive messages continue it"},
                       "unit": {"type": "string"},
                       "t": {"type": "array", "items": {"type": "number"}, "description": "rig clock [s]"},
                       "value": {"type": "array", "items": {"type": "number"}}},
        "required": ["seq", "n0", "unit", "t", "value"]},
    "dyno.Setpoints": {
        "type": "object", "title": "dyno.Setpoints",
        "description": "Actuator position setpoints sent, one per control tick [m from full extension].",
        "properties": {"seq": {"type": "integer"}, "t": {"type": "array", "items": {"type": "number"}},
                       "x": {"type": "array", "items": {"type": "number"}}},
        "required": ["seq", "t", "x"]},
    "dyno.Event": {
        "type": "object", "title": "dyno.Event",
        "description": "Protocol, safety and analysis events (records/events.py); a kind's own fields ride "
                       "in params (run_start: segment_count, duration_max_s; diagnosis: source).",
        "properties": {"seq": {"type": "integer"}, "t": {"type": "number"},
                       "kind": {"type": "string", "examples": list(KINDS)},
                       "segment": {"type": "string"}, "params": {"type": "object"},
                       "message": {"type": "string"}},
        "required": ["seq", "t", "kind"]},
    "dyno.Sample": {
        "type": "object", "title": "dyno.Sample",
        "description": "One sample of a channel, at its log time, SI unit (the channel's metadata 'unit'): for "
                       "plotting tools that plot a field over time (Foxglove's Plot panel: /plot/force.value).",
        "properties": {"value": {"type": "number"}}, "required": ["value"]},
    # Foxglove's Log panel reads this schema by name (docs.foxglove.dev, message schemas: Log)
    "foxglove.Log": {
        "type": "object", "title": "foxglove.Log", "description": "The run's events as log lines",
        "properties": {"timestamp": {"type": "object", "title": "time",
                                     "properties": {"sec": {"type": "integer", "minimum": 0},
                                                    "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}},
                       "level": {"type": "integer", "description": "2 info, 3 warning, 4 error"},
                       "message": {"type": "string"}, "name": {"type": "string"}, "file": {"type": "string"},
                       "line": {"type": "integer", "minimum": 0}},
        "required": ["timestamp", "level", "message", "name", "file", "line"]},
}
LOG_LEVEL = {Fault: 4, OperatorStop: 3, Skipped: 3}  # foxglove.Log levels; other events: 2 (info)
VERSION = metadata.version("dyno")  # pyproject.toml's, as installed


@functools.cache
def software() -> dict:
    """{"name", "version", "commit"}: this dyno, with the git commit of its source when it runs
    from a checkout (a "+" when the checkout has changes not committed); no commit otherwise.
    Recorded in every file and printed on the test sheet: which code made a result."""
    here = Path(__file__).resolve().parent.parent
    out = {"name": "dyno", "version": VERSION}
    try:
        head = subprocess.run(["git", "-C", str(here), "rev-parse", "--show-toplevel", "--short=12", "HEAD"],
                              capture_output=True, text=True, timeout=10)
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return out
    top, _, commit = head.stdout.strip().partition("\n")
    if head.returncode == 0 and commit and Path(top).resolve() == here:  # not a checkout the package sits inside
        out["commit"] = commit + ("+" if dirty.stdout.strip() else "")
    return out


UNDATED = "unknown"  # the run metadata's wall_start of a recording whose date nobody knows (an import)


class Recorder:
    """Writes a run to `path` through a Claim (records/files.py): to a partial file
    beside it, renamed onto `path` at the first segment_start event (the run has started
    cleanly); a run that never starts leaves no file and an existing one untouched.

    Log times are absolute (ns since the Unix epoch: wall_start + the run clock), so any
    MCAP tool shows the date; the messages carry the run clock in seconds."""

    def __init__(self, path, config, damper_json: str, protocol: str, params: dict, wall_start=None,
                 overwrite=False, run_info=None, plot_every=1):
        """path: the target, or a Claim on it taken earlier (to refuse before the rig opens);
        plot_every: every how many samples go on /plot (an import's long file: the batches
        keep them all)."""
        self.plot_every = max(1, int(plot_every))
        self.claim = path if isinstance(path, Claim) else Claim(path, overwrite)
        self.path = self.claim.target
        self.file = self.claim.open()
        self.wall_start = time.time() if wall_start is None else float(wall_start)
        self.t0_ns = int(round(self.wall_start * 1e9))
        self.w = Writer(self.file, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        self.w.start(profile="", library=f"dyno {VERSION}")
        self.schema = {name: self.w.register_schema(name, "jsonschema", json.dumps(s).encode())
                       for name, s in SCHEMAS.items()}
        self.unit_of = {n: c.unit for n, c in config.channels.items()}
        self.topics, self.seq, self.n = {}, {}, {}
        for name in config.channels:
            self._channel(name)
        self._topic("/actuator/setpoint", "dyno.Setpoints")
        self._topic("/events", "dyno.Event")
        self._topic("/log", "foxglove.Log")
        self.w.add_metadata("software", software())
        started = datetime.fromtimestamp(self.wall_start, timezone.utc)
        self.w.add_metadata("run", {"wall_start": started.isoformat(timespec="microseconds"),
                                    "wall_start_unix_s": repr(self.wall_start),
                                    "clock": "t [s] of every message: the run clock, 0 at the rig's open; "
                                             "log time = wall_start + t",
                                    **{k: str(v) for k, v in (run_info or {}).items()}})
        self.w.add_metadata("rig", {"name": config.name, "config_path": str(config.path)})
        self.w.add_metadata("calibration", {n: json.dumps({"device": c.device, "signal": c.signal, "gain": c.gain,
                                                           "offset": c.offset, "unit": c.unit,
                                                           **{k: getattr(c, k) for k in ("drives", "sensor", "calibrated")
                                                              if getattr(c, k, "")}})
                                            for n, c in config.channels.items()})
        self.w.add_metadata("damper", {"model": damper_json})
        self.w.add_metadata("protocol", {"name": protocol, "params": json.dumps(params)})
        self.w.add_attachment(self.t0_ns, self.t0_ns, "rig.toml", "application/toml", config.text.encode())
        self.last_flush = time.monotonic()
        self.last_t = 0.0

    def _topic(self, topic, schema, metadata=None):
        self.topics[topic] = self.w.register_channel(topic, "json", self.schema[schema], metadata or {})
        self.seq[topic] = 0

    def _channel(self, name):
        """A channel's batched topic and its per-sample one for plotting tools."""
        self._topic(f"/channels/{name}", "dyno.Samples")
        self._topic(f"/plot/{name}", "dyno.Sample", {"unit": self.unit_of.get(name, "")})

    def _plot(self, name, t, v):
        """One message per sample on /plot/NAME at its own log time."""
        topic = f"/plot/{name}"
        t, v = t[::self.plot_every], v[::self.plot_every]
        ns = (self.t0_ns + (np.maximum(t, 0.0) * 1e9 + 0.5).astype(np.int64)).tolist()
        # 7 digits plot (the batches keep all); JSON has no nan or inf
        data = [b'{"value":%.7g}' % vi if -1e308 < vi < 1e308 else b'{"value":null}' for vi in v.tolist()]
        add_messages(self.w, self.topics[topic], ns, data, self.seq[topic])
        self.seq[topic] += len(ns)

    def _write(self, topic, t, payload, encode=None):
        payload = {"seq": self.seq[topic], **payload}
        ns = self.t0_ns + int(round(max(t, 0.0) * 1e9))
        data = encode(payload) if encode else json.dumps(payload, separators=(",", ":")).encode()
        self.w.add_message(self.topics[topic], ns, data, ns, sequence=self.seq[topic])
        self.seq[topic] += 1
        self.last_t = max(self.last_t, t)

    # sinks -------------------------------------------------------------------------------
    def units(self, units):
        """Channels the plan adds to the rig's (a closed loop's own), with their units."""
        self.unit_of.update(units)
        for name in units:
            if f"/channels/{name}" not in self.topics:
                self._channel(name)

    def samples(self, drained):
        """A rig.drain() batch: {channel: (t array, value array)}."""
        for name, (t, v) in drained.items():
            if len(t):
                n0 = self.n.get(name, 0)
                self._write(f"/channels/{name}", float(t[0]), {"n0": n0, "unit": self.unit_of.get(name, ""),
                                                               "t": np.ascontiguousarray(t, float),
                                                               "value": np.ascontiguousarray(v, float)}, SAMPLES)
                self._plot(name, t, v)
                self.n[name] = n0 + len(t)
        self.maybe_flush()

    def setpoints(self, t, x):
        if len(t):
            self._write("/actuator/setpoint", float(t[0]), {"t": list(t), "x": list(x)})

    def event(self, e: Event):
        self._write("/events", e.t, e.wire())
        ns = self.t0_ns + int(round(max(e.t, 0.0) * 1e9))
        self._write("/log", e.t, {"timestamp": {"sec": ns // 10**9, "nsec": ns % 10**9},
                                  "level": LOG_LEVEL.get(type(e), 2), "name": "dyno", "file": "", "line": 0,
                                  "message": " ".join(p for p in (e.kind, e.segment, e.message) if p)})
        self.flush()  # events are rare and matter: never leave one in an open chunk
        if isinstance(e, SegmentStart):
            self.commit()

    def commit(self):
        """The recording is worth keeping: it takes the target's name now."""
        self.claim.commit()
        self.path = self.claim.target

    def maybe_flush(self):
        if time.monotonic() - self.last_flush >= FLUSH_S:
            self.flush()

    def flush(self):
        self.w.flush()
        os.fsync(self.file.fileno())
        self.last_flush = time.monotonic()

    @property
    def kept(self):
        return self.claim.committed

    def close(self):
        """Finish the file (index and summary). A run that never started leaves nothing.
        RigError if the file cannot be finished (a full disk): what was flushed before is
        on disk and `dyno recover` rebuilds it."""
        error = None
        try:
            self.w.finish()
            self.file.flush()
            os.fsync(self.file.fileno())
        except Exception as e:  # noqa: BLE001 - reported once, after the run's own error
            error = e
        finally:
            try:
                self.file.close()
            except OSError as e:
                error = error or e
            if not self.claim.committed:
                self.claim.abandon()
            self.claim.release()
        if error is not None and self.claim.committed:
            why = getattr(error, "strerror", None) or str(error)
            raise RigError(f"{self.path}: recording not finished ({why}); what was written up to the last "
                           f"flush is kept: run `dyno recover {self.path}`")


# records worth keeping, and how a resync finds a candidate: opcode, then a little-endian
# u64 length below 2^32 (the high four bytes zero)
_KEEP = {Opcode.SCHEMA: Schema, Opcode.CHANNEL: Channel, Opcode.CHUNK: Chunk, Opcode.METADATA: Metadata,
         Opcode.ATTACHMENT: Attachment}
_CANDIDATE = re.compile(b"[" + b"".join(re.escape(bytes([int(o)])) for o in _KEEP) + b"].{4}\x00{4}", re.DOTALL)


def _record_at(data, pos):
    """(records, end) of the intact record at pos, or (None, None). A chunk counts only
    if it decompresses to its CRC; other records only if they parse to their exact length."""
    opcode, length = data[pos], int.from_bytes(data[pos + 1:pos + 9], "little")
    end = pos + 9 + length
    kind = _KEEP.get(opcode)
    if kind is None or end > len(data):
        return None, None
    stream = ReadDataStream(BytesIO(data[pos + 9:end]))
    try:
        rec = kind.read(stream)
        if stream.count != length:
            return None, None
        if isinstance(rec, Chunk):
            if rec.compression not in ("", "zstd", "lz4") or rec.uncompressed_crc == 0:
                return None, None
            return breakup_chunk(rec, validate_crc=True), end
        crc = int.from_bytes(data[end - 4:end], "little")
        if isinstance(rec, Attachment) and crc and crc != zlib.crc32(data[pos + 9:end - 4]):
            return None, None
    except Exception:  # noqa: BLE001 - any parse failure: not a record here
        return None, None
    return [rec], end


def _passed(data, pos):
    """The end of a whole record at pos that need not be kept (header, indexes, summary), or None."""
    if data[pos] in (Opcode.HEADER, Opcode.DATA_END, Opcode.FOOTER, Opcode.STATISTICS, Opcode.CHUNK_INDEX,
                     Opcode.MESSAGE_INDEX, Opcode.METADATA_INDEX, Opcode.ATTACHMENT_INDEX, Opcode.SUMMARY_OFFSET):
        length = int.from_bytes(data[pos + 1:pos + 9], "little")
        if pos + 9 + length <= len(data) and length < 1 << 32:
            return pos + 9 + length
    return None


def intact_from(data: bytes, pos: int = 0) -> tuple[list, int]:
    """(records, end) of the whole records from pos up to the first one not yet whole: what
    a recording being written holds so far (its flushed chunks); read on from end later."""
    out = []
    if pos == 0 and data[:8] == MCAP0_MAGIC:
        pos = 8
    while pos + 9 <= len(data):
        recs, end = _record_at(data, pos)
        if recs is None:
            end = _passed(data, pos)
            if end is None:
                break
        else:
            out.extend(recs)
        pos = end
    return out, pos


def scan(data: bytes) -> tuple[list, int]:
    """(records, bytes skipped): every intact schema, channel, metadata, attachment and
    every message of every intact chunk, in file order, resynchronising after damage (a
    torn end, a damaged chunk or a damaged magic)."""
    out, skipped = [], 0
    pos = 8 if data[:8] == MCAP0_MAGIC else 0
    while pos + 9 <= len(data):
        recs, end = _record_at(data, pos)
        if recs is not None:
            out.extend(recs)
            pos = end
            continue
        end = _passed(data, pos)
        if end is not None:
            pos = end
            continue
        m = _CANDIDATE.search(data, pos + 1)
        nxt = m.start() if m else len(data)
        skipped += nxt - pos
        pos = nxt
    return out, skipped


def _scanned(path):
    """(records, bytes skipped, {id: Schema}, {id: Channel}) of a recording read whole."""
    try:
        data = path.read_bytes()
    except OSError as e:
        raise UsageError(f"{path}: cannot read ({e.strerror})") from None
    records, skipped = scan(data)
    return (records, skipped, {r.id: r for r in records if isinstance(r, Schema)},
            {r.id: r for r in records if isinstance(r, Channel)})


def recover(path: str | Path) -> dict:
    """Rebuild an indexed MCAP from a damaged one (a run that was killed, a torn or
    corrupted file): every intact record is kept, also those after a damaged part. The
    original is kept beside it as PATH.damaged (PATH.damaged-2 ... if that exists).
    Returns counts of what was restored."""
    path = not_being_written(input_file(path), "recover")
    try:
        with open(path, "rb") as f:
            make_reader(f).get_summary()
            list(make_reader(f).iter_messages())
        return {"intact": True}
    except Exception:  # noqa: BLE001 - anything the indexed reader refuses is recovered below
        pass
    records, skipped, schemas, channels = _scanned(path)
    messages = [r for r in records if isinstance(r, Message) and r.channel_id in channels]
    if not channels:
        raise UsageError(f"{path}: not an MCAP recording, or nothing recoverable in it")
    damaged, k = path.with_name(path.name + ".damaged"), 2
    while damaged.exists():
        damaged, k = path.with_name(f"{path.name}.damaged-{k}"), k + 1
    output_file(damaged, [path], what="recover:")  # a writable folder, checked before any work
    counts = {"intact": False, "messages": len(messages), "metadata": 0, "attachments": 0,
              "bytes_skipped": skipped, "damaged": str(damaged)}
    with written(path, "recover:") as tmp:
        with open(tmp, "wb") as out:
            _rewrite(out, records, schemas, channels, counts)
        os.link(path, damaged)  # the original kept under its new name before the rebuilt one replaces it
    return counts


def edit_run_info(path: str | Path, changes: dict) -> dict:
    """Rewrite a recording with its "run" metadata changed ({damper_serial, operator, note,
    setup.KEY: text}; "" removes one); every other record is kept as it was: the messages
    with their times, the attachments, the other metadata. Returns the new run metadata."""
    path = not_being_written(input_file(path), "runs edit")
    records, skipped, schemas, channels = _scanned(path)
    if skipped or not channels:
        raise UsageError(f"{path}: damaged ({skipped} bytes unreadable): run `dyno recover {path}` first")
    runs = [i for i, r in enumerate(records) if isinstance(r, Metadata) and r.name == "run"]
    old = dict(records[runs[-1]].metadata) if runs else {}
    new = {k: v for k, v in {**old, **changes}.items() if v != ""}
    for i in runs:
        records[i] = Metadata(name="run", metadata=new)
    if not runs:
        records.append(Metadata(name="run", metadata=new))
    counts = {"metadata": 0, "attachments": 0}
    with written(path, "runs edit:") as tmp:
        with open(tmp, "wb") as out:
            _rewrite(out, records, schemas, channels, counts, "edit")
    return new


def _rewrite(out, records, schemas, channels, counts, why="recover"):
    """The intact records, written as a new indexed MCAP; counts what was kept."""
    w = Writer(out, chunk_size=1 << 20, compression=CompressionType.ZSTD)
    w.start(profile="", library=f"dyno {VERSION} {why}")
    sid = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
    cid = {i: w.register_channel(c.topic, c.message_encoding, sid.get(c.schema_id, 0), c.metadata)
           for i, c in channels.items()}
    seen = set()
    for rec in records:
        if isinstance(rec, Metadata):
            w.add_metadata(rec.name, rec.metadata)
            counts["metadata"] += 1
        elif isinstance(rec, Attachment):
            w.add_attachment(rec.create_time, rec.log_time, rec.name, rec.media_type, rec.data)
            counts["attachments"] += 1
        elif isinstance(rec, Message) and rec.channel_id in cid:
            key = (rec.channel_id, rec.sequence, rec.log_time)
            if key not in seen:  # a chunk can only be counted once
                seen.add(key)
                w.add_message(cid[rec.channel_id], rec.log_time, rec.data, rec.publish_time, rec.sequence)
    counts["messages"] = len(seen)
    w.finish()
