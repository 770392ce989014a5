"""Reading a recording (docs/recording.md) into plain data: what reports, identification,
diagnosis and any user's own analysis start from.

    from records.reader import load_recording
    channels, events, metadata = load_recording("run.mcap")
    t, force = channels["force"]          # seconds on the run clock, newtons
    metadata["units"]["force"]            # "N": each channel's unit as recorded
    metadata["run"], metadata["protocol"] # the run and its protocol's parameters (docs/recording.md)

A DataFrame with pandas: `dyno export run.mcap --csv run.csv`, or
    pandas.DataFrame({n: v for n, (t, v) in channels.items() if len(t) == len(channels["force"][0])})
for channels that share the force clock.
"""
from __future__ import annotations

import json
import math
from dataclasses import fields
from pathlib import Path

import numpy as np
import orjson
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Chunk, MessageIndex
from mcap.stream_reader import get_chunk_data_stream

from records import source_filter
from records.data import Channels
from records.events import Event, from_wire
from records.files import input_file, not_being_written
from rig.errors import UsageError

MAX_TIME_S = 1e8  # s from a run's start: three years, beyond any durability run's clock
MAX_VALUE = 1e15  # SI: above any force, pressure or length a dyno measures; the arithmetic stays finite
ESSENTIAL = ("force", "x")  # every analysis reads these: a channel of them with no number is refused
POSITIVE = ("freq_hz", "cycles")  # segment parameters that are above 0 or meaningless
JSON_METADATA = {"damper": ("model",), "protocol": ("params",), "calibration": None}  # None: every key


def load_recording(path: str | Path, channels: list[str] | None = None) -> tuple[Channels, list[Event], dict]:
    """(channels {name: (t, values)}, events [Event] (records/events.py), metadata {name: dict}); metadata
    "units" is {channel: unit} as recorded. Only the named channels when given (those the
    recording has): the others' batches are most of a 1 kHz recording's reading time.
    Whatever the file holds is checked here: RigError naming the topic or metadata record
    that is not as docs/recording.md says."""
    path = not_being_written(input_file(path))
    chans, events, units = {}, [], {}
    try:
        with open(path, "rb") as f:
            r = make_reader(f)
            meta = {m.name: dict(m.metadata) for m in r.iter_metadata()}
            summary = r.get_summary()  # None in a file cut short: then every topic is read
            wanted = None if channels is None else {f"/channels/{n}" for n in channels}
            topics = None if summary is None else [
                c.topic for c in summary.channels.values()
                if (c.topic.startswith("/channels/") and (wanted is None or c.topic in wanted)) or c.topic == "/events"]
            for topic, data in _messages(f, r, summary, topics):
                if topic.startswith("/channels/") and (wanted is None or topic in wanted):
                    name = topic[len("/channels/"):]
                    t, v, unit = _batch(_batch_json(data), topic)
                    ts, vs = chans.setdefault(name, ([], []))
                    ts.extend(t)
                    vs.extend(v)
                    units.setdefault(name, unit)
                elif topic == "/events":
                    events.append(read_event(json.loads(data)))
        _check_metadata(meta)
    except UsageError as e:
        raise UsageError(f"{path}: {e}") from None
    except Exception as e:  # noqa: BLE001 - whatever the MCAP reader or JSON refuses
        raise UsageError(f"{path}: not a readable recording ({e}); try `dyno recover {path}`") from None
    if not chans:
        raise UsageError(f"{path}: no dyno channels (/channels/NAME): not a recording dyno run or import wrote")
    meta["units"] = units
    out = {}
    for name, (t, v) in chans.items():
        try:
            out[name] = (np.array(t, dtype=float), np.array(v, dtype=float))
        except (TypeError, ValueError):
            raise UsageError(f"{path}: /channels/{name}: values are not numbers") from None
        t, v = out[name]
        if not np.all(np.isfinite(t)):
            raise UsageError(f"{path}: /channels/{name}: a time that is not a finite number")
        if len(t) and np.max(np.abs(t)) > MAX_TIME_S:
            raise UsageError(f"{path}: /channels/{name}: times reach {np.max(np.abs(t)):.3g} s from the run's start, "
                             f"beyond any run's clock ({MAX_TIME_S:g} s, three years)")
        back = np.nonzero(np.diff(t) < 0)[0]
        if len(back):
            raise UsageError(f"{path}: /channels/{name}: time runs backwards ({t[back[0]]:.6g} s, then "
                           f"{t[back[0] + 1]:.6g} s)")
        if np.any(np.abs(v) > MAX_VALUE):
            raise UsageError(f"{path}: /channels/{name}: values beyond +-{MAX_VALUE:g} (SI): no sensor reads that")
        if name in ESSENTIAL and len(v) and not np.any(np.isfinite(v)):
            raise UsageError(f"{path}: /channels/{name}: not one value is a number")
    return out, events, meta


def merged(paths: list[str | Path]) -> tuple[Channels, list[Event], dict]:
    """(channels, events, metadata of the first) from several recordings, each later one
    shifted in time to start 10 s after the one before ends."""
    channels, events, meta, offset = {}, [], None, 0.0
    for p in paths:
        ch, ev, m = load_recording(p)
        meta = meta if meta is not None else m
        if source_filter.of(m) != source_filter.of(meta):  # one filter is put on every recording's model
            raise UsageError(f"{p}: its source smoothed it as {_said(m)}, the first as {_said(meta)}: "
                             f"give recordings smoothed alike")
        end = offset
        for name, (t, v) in ch.items():
            T, V = channels.get(name, (np.empty(0), np.empty(0)))
            channels[name] = (np.concatenate([T, t + offset]), np.concatenate([V, v]))
            end = max(end, float(t[-1]) + offset) if len(t) else end
        events += [e.shifted(offset) for e in ev]
        offset = end + 10.0
    return channels, events, meta or {}


def _said(meta):
    s = source_filter.of(meta)
    return "not at all" if s is None else f"a moving average of {s.text()}"


def _messages(f, reader, summary, topics):
    """(topic, data) of the messages on `topics` (None: all) in log-time order. Where every
    chunk has its message indexes, only the wanted messages are read out of each chunk: a
    recording's per-sample /plot topics hold a hundred times the records of its /channels
    batches, and the MCAP reader parses every record of a chunk it opens (7 s of a 345 s
    run's 1 kHz recording, 0.3 s this way)."""
    if summary is None or topics is None or not all(c.message_index_offsets for c in summary.chunk_indexes):
        for _, ch, m in reader.iter_messages(topics=topics):
            yield ch.topic, m.data
        return
    ids = {cid: c.topic for cid, c in summary.channels.items() if c.topic in topics}
    found = []
    for ci in summary.chunk_indexes:
        offsets = [o for cid, o in ci.message_index_offsets.items() if cid in ids]
        if not offsets:
            continue
        f.seek(ci.chunk_start_offset + 9)  # past the record's opcode and length
        stream, size = get_chunk_data_stream(Chunk.read(ReadDataStream(f)))
        records = stream.read(size)
        for o in offsets:
            f.seek(o + 9)
            index = MessageIndex.read(ReadDataStream(f))
            for log_time, at in index.records:
                # a message record: opcode (1), length (8), channel, sequence, two times (22), data
                end = at + 9 + int.from_bytes(records[at + 1:at + 9], "little")
                found.append((log_time, ci.chunk_start_offset, at, ids[index.channel_id], records[at + 31:end]))
    found.sort(key=lambda m: m[:3])
    for *_, topic, data in found:
        yield topic, data


def _batch_json(data):
    """A /channels batch's JSON: orjson, a third of json's time; json for an older
    recording's NaN, which orjson (keeping to JSON) refuses."""
    try:
        return orjson.loads(data)
    except orjson.JSONDecodeError:
        return json.loads(data)


def _batch(d, topic):
    """(t, value, unit) of one batch of samples, as docs/recording.md gives it."""
    if not isinstance(d, dict) or not isinstance(d.get("t"), list) or not isinstance(d.get("value"), list):
        raise UsageError(f"{topic}: a message without the lists t and value")
    if len(d["t"]) != len(d["value"]):
        raise UsageError(f"{topic}: a message with {len(d['t'])} times and {len(d['value'])} values")
    unit = d.get("unit", "")
    return d["t"], d["value"], unit if isinstance(unit, str) else str(unit)


def read_event(d: dict) -> Event:
    """The event a message holds: t [s] a finite number, kind and segment texts, params an
    object, and a kind's own fields of their types."""
    ok = isinstance(d, dict) and isinstance(d.get("kind"), str) and isinstance(d.get("t"), (int, float)) \
        and not isinstance(d.get("t"), bool) and np.isfinite(d["t"]) and abs(d["t"]) <= MAX_TIME_S \
        and isinstance(d.setdefault("segment", ""), str) and isinstance(d.setdefault("params", {}), dict) \
        and isinstance(d.setdefault("message", ""), str)
    if not ok or (d["kind"].startswith("segment_") and not d["segment"]):
        raise UsageError(f"/events: an event without its fields (t, kind, segment, params): {str(d)[:80]}")
    for k, v in d["params"].items():
        if isinstance(v, (int, float)) and not isinstance(v, bool) and not (
                math.isfinite(v) and abs(v) <= MAX_VALUE and (v > 0 or k not in POSITIVE)):
            raise UsageError(f"/events: segment {d['segment']!r}: {k} = {v!r} (a finite number"
                           f"{' above 0' if k in POSITIVE else ''})")
    e = from_wire(d)
    for f in fields(e):
        if f.type in _TYPES and not isinstance(getattr(e, f.name), _TYPES[f.type]):
            raise UsageError(f"/events: a {e.kind} event whose {f.name} is {getattr(e, f.name)!r}, not of type {f.type}")
    return e


_TYPES = {"float": (int, float), "int": int, "str": str}  # the event fields' declared types


def _check_metadata(meta):
    try:
        source_filter.of(meta)
    except ValueError as e:
        raise UsageError(f"metadata run.{source_filter.RUN_KEY}: {e}") from None
    for name, keys in JSON_METADATA.items():
        record = meta.get(name, {})
        for key in (record if keys is None else keys):
            text = record.get(key)
            if text:
                try:
                    json.loads(text)
                except ValueError:
                    raise UsageError(f"metadata {name}.{key}: not JSON") from None
