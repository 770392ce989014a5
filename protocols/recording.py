"""MCAP recordings (docs/recording.md): every channel at its native rate in batched
messages, actuator setpoints, protocol and safety events, metadata and the rig config.

JSON messages with JSON Schemas, so any MCAP tool reads them. Chunks are small and closed
at least every FLUSH_S seconds, so a run killed mid-protocol loses at most that much:
`recover()` rebuilds an indexed file from what was written.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from rig.errors import RigError

FLUSH_S = 0.5
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
        "description": "Protocol and safety events: run_start, segment_start, segment_end, skipped, "
                       "fault, operator_stop, run_end.",
        "properties": {"seq": {"type": "integer"}, "t": {"type": "number"}, "kind": {"type": "string"},
                       "segment": {"type": "string"}, "params": {"type": "object"},
                       "message": {"type": "string"}},
        "required": ["seq", "t", "kind"]},
}
VERSION = "0.1.0"


class Recorder:
    def __init__(self, path, config, damper_json: str, protocol: str, params: dict):
        self.path = Path(path)
        try:
            self.file = open(self.path, "wb")
        except OSError as e:
            raise RigError(f"--out {path}: cannot write ({e.strerror})") from None
        self.w = Writer(self.file, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        self.w.start(profile="", library=f"dyno {VERSION}")
        self.schema = {name: self.w.register_schema(name, "jsonschema", json.dumps(s).encode())
                       for name, s in SCHEMAS.items()}
        self.units = {n: c.unit for n, c in config.channels.items()}
        self.topics, self.seq, self.n = {}, {}, {}
        for name in config.channels:
            self._topic(f"/channels/{name}", "dyno.Samples")
        self._topic("/actuator/setpoint", "dyno.Setpoints")
        self._topic("/events", "dyno.Event")
        self.w.add_metadata("software", {"name": "dyno", "version": VERSION})
        self.w.add_metadata("rig", {"name": config.name, "config_path": str(config.path)})
        self.w.add_metadata("calibration", {n: json.dumps({"device": c.device, "signal": c.signal, "gain": c.gain,
                                                           "offset": c.offset, "unit": c.unit})
                                            for n, c in config.channels.items()})
        self.w.add_metadata("damper", {"model": damper_json})
        self.w.add_metadata("protocol", {"name": protocol, "params": json.dumps(params)})
        now = time.time_ns()
        self.w.add_attachment(now, now, "rig.toml", "application/toml", config.text.encode())
        self.last_flush = time.monotonic()
        self.last_t = 0.0

    def _topic(self, topic, schema):
        self.topics[topic] = self.w.register_channel(topic, "json", self.schema[schema])
        self.seq[topic] = 0

    def _write(self, topic, t, payload):
        payload = {"seq": self.seq[topic], **payload}
        ns = int(max(t, 0.0) * 1e9)
        self.w.add_message(self.topics[topic], ns, json.dumps(payload, separators=(",", ":")).encode(), ns,
                           sequence=self.seq[topic])
        self.seq[topic] += 1
        self.last_t = max(self.last_t, t)

    # sinks -------------------------------------------------------------------------------
    def samples(self, drained):
        """A rig.drain() batch: {channel: (t array, value array)}."""
        for name, (t, v) in drained.items():
            if len(t):
                n0 = self.n.get(name, 0)
                self._write(f"/channels/{name}", float(t[0]), {"n0": n0, "unit": self.units.get(name, ""),
                                                               "t": t.tolist(), "value": v.tolist()})
                self.n[name] = n0 + len(t)
        self.maybe_flush()

    def setpoints(self, t, x):
        if len(t):
            self._write("/actuator/setpoint", float(t[0]), {"t": list(t), "x": list(x)})

    def event(self, t, kind, segment="", params=None, message=""):
        self._write("/events", t, {"t": t, "kind": kind, "segment": segment, "params": params or {},
                                   "message": message})
        self.flush()  # events are rare and matter: never leave one in an open chunk

    def maybe_flush(self):
        if time.monotonic() - self.last_flush >= FLUSH_S:
            self.flush()

    def flush(self):
        self.w.flush()
        os.fsync(self.file.fileno())
        self.last_flush = time.monotonic()

    def close(self):
        self.w.finish()
        self.file.close()


def recover(path) -> dict:
    """Rebuild an indexed MCAP from a damaged one (a run that was killed): every record of
    every complete chunk is kept. The original is kept beside it as PATH.damaged.
    Returns counts of what was restored."""
    path = Path(path)
    if not path.exists():
        raise RigError(f"{path}: no such file")
    damaged = path.with_name(path.name + ".damaged")
    try:
        with open(path, "rb") as f:
            make_reader(f).get_summary()
            list(make_reader(f).iter_messages())
        intact = True
    except Exception:
        intact = False
    if intact:
        return {"intact": True}
    schemas, channels, records = {}, {}, []
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, record_size_limit=1 << 30).records:
                if isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    channels[rec.id] = rec
                elif type(rec).__name__ in ("Message", "Metadata", "Attachment"):
                    records.append(rec)
        except Exception:
            pass  # the torn end of the file: everything before it is kept
    if not schemas:
        raise RigError(f"{path}: not an MCAP file, or nothing recoverable in it")
    os.replace(path, damaged)
    counts = {"intact": False, "messages": 0, "metadata": 0, "attachments": 0, "damaged": str(damaged)}
    with open(path, "wb") as out:
        w = Writer(out, chunk_size=1 << 20, compression=CompressionType.ZSTD)
        w.start(profile="", library=f"dyno {VERSION} recover")
        sid = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
        cid = {i: w.register_channel(c.topic, c.message_encoding, sid.get(c.schema_id, 0), c.metadata)
               for i, c in channels.items()}
        for rec in records:
            if isinstance(rec, Metadata):
                w.add_metadata(rec.name, rec.metadata)
                counts["metadata"] += 1
            elif isinstance(rec, Attachment):
                w.add_attachment(rec.create_time, rec.log_time, rec.name, rec.media_type, rec.data)
                counts["attachments"] += 1
            elif rec.channel_id in cid:
                w.add_message(cid[rec.channel_id], rec.log_time, rec.data, rec.publish_time, rec.sequence)
                counts["messages"] += 1
        w.finish()
    return counts
