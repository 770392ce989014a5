"""Reading a recording (docs/recording.md) into plain data: what reports, identification,
diagnosis and any user's own analysis start from.

    from protocols.io.reader import load_recording
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
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from rig.errors import RigError


def load_recording(path):
    """(channels {name: (t, values)}, events [dict], metadata {name: dict}); metadata
    "units" is {channel: unit} as recorded."""
    path = Path(path)
    if not path.exists():
        raise RigError(f"{path}: no such file")
    if not path.is_file():
        raise RigError(f"{path}: not a readable recording (a folder, not a file)")
    chans, events, units = {}, [], {}
    try:
        with open(path, "rb") as f:
            r = make_reader(f)
            meta = {m.name: dict(m.metadata) for m in r.iter_metadata()}
            summary = r.get_summary()  # None in a file cut short: then every topic is read
            topics = None if summary is None else [c.topic for c in summary.channels.values()
                                                   if c.topic.startswith("/channels/") or c.topic == "/events"]
            for _, ch, m in r.iter_messages(topics=topics):
                d = json.loads(m.data)
                if ch.topic.startswith("/channels/"):
                    ts, vs = chans.setdefault(ch.topic[len("/channels/"):], ([], []))
                    ts.extend(d["t"])
                    vs.extend(d["value"])
                    units.setdefault(ch.topic[len("/channels/"):], d.get("unit", ""))
                elif ch.topic == "/events":
                    events.append(d)
    except Exception as e:
        raise RigError(f"{path}: not a readable recording ({e}); try `dyno recover {path}`") from None
    meta["units"] = units
    return {k: (np.array(t), np.array(v)) for k, (t, v) in chans.items()}, events, meta
