"""Small MCAP files for the reader tests, written with the mcap library alone (not our
Recorder): what another tool, a bug or a hostile user could hand `dyno`."""
import json

from mcap.writer import Writer


def write(path, channels=None, events=(), metadata=None, topics=None):
    """channels {name: [message dict, ...]} on /channels/NAME, events on /events, metadata
    {name: {key: text}}; topics {topic: [raw bytes, ...]} for anything else."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="tests")
        sid = w.register_schema("any", "jsonschema", b"{}")
        seq = 0

        def put(topic, payloads):
            nonlocal seq
            cid = w.register_channel(topic, "json", sid)
            for p in payloads:
                seq += 1
                w.add_message(cid, seq, p if isinstance(p, bytes) else json.dumps(p).encode(), seq, seq)
        for name, msgs in (channels or {}).items():
            put(f"/channels/{name}", msgs)
        if events:
            put("/events", events)
        for topic, msgs in (topics or {}).items():
            put(topic, msgs)
        for name, md in (metadata or {}).items():
            w.add_metadata(name, md)
        w.finish()
    return path


def good_channels(n=200):
    import math
    t = [i * 1e-3 for i in range(n)]
    return {"force": [{"t": t, "value": [100 * math.sin(i / 20) for i in range(n)], "unit": "N"}],
            "x": [{"t": t, "value": [0.03 + 0.005 * math.cos(i / 20) for i in range(n)], "unit": "m"}]}
