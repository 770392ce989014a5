"""What Foxglove reads in a recording, checked with the mcap reader: events as
foxglove.Log on /log, every sample on /plot/<channel> at its absolute log time, and the
shipped layout (docs/foxglove-layout.json) naming only topics a recording has."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from records.reader import load_recording

DYNO = str(Path(sys.executable).parent / "dyno")
LAYOUT = Path(__file__).parent.parent / "docs" / "foxglove-layout.json"


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("fox") / "x.mcap"
    p = subprocess.run([DYNO, "run", "sine-matrix", "amplitudes_mm=6.4", "freqs_hz=4", "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    return out


def _messages(path, topic):
    with open(path, "rb") as f:
        r = make_reader(f)
        return [(s, c, m) for s, c, m in r.iter_messages(topics=[topic])]


def test_events_are_foxglove_log_lines_at_their_absolute_time(recording):
    msgs = _messages(recording, "/log")
    _, events, meta = load_recording(recording)
    assert len(msgs) == len(events) > 3
    wall = float(meta["run"]["wall_start_unix_s"])
    for (schema, channel, m), e in zip(msgs, events):
        assert schema.name == "foxglove.Log" and schema.encoding == "jsonschema" and channel.message_encoding == "json"
        d = json.loads(m.data)
        assert set(json.loads(schema.data)["required"]) <= set(d)
        ts = d["timestamp"]
        assert isinstance(ts["sec"], int) and 0 <= ts["nsec"] < 10**9
        assert ts["sec"] * 10**9 + ts["nsec"] == m.log_time
        assert abs(m.log_time / 1e9 - (wall + e.t)) < 1e-6 and d["level"] in (2, 3, 4)
        assert d["message"].startswith(e.kind)


def test_every_sample_is_a_plottable_message(recording):
    ch, _, meta = load_recording(recording)
    wall_ns = round(float(meta["run"]["wall_start_unix_s"]) * 1e9)
    for name in ("force", "x", "T_body"):
        msgs = _messages(recording, f"/plot/{name}")
        t, v = ch[name]
        assert len(msgs) == len(t) and msgs[0][1].metadata["unit"] == meta["units"][name]
        logged = np.array([m.log_time for _, _, m in msgs])
        assert np.all(np.abs(logged - (wall_ns + np.round(t * 1e9))) <= 1000)  # within a microsecond
        values = np.array([json.loads(m.data)["value"] for _, _, m in msgs])
        assert np.allclose(values, v, rtol=1e-6, atol=1e-9)


def test_the_shipped_layout_plots_topics_a_recording_has(recording):
    layout = json.loads(LAYOUT.read_text())
    with open(recording, "rb") as f:
        topics = {c.topic for c in make_reader(f).get_summary().channels.values()}
    paths = [p["value"] for c in layout["configById"].values() for p in c.get("paths", [])]
    assert paths and all(p.rsplit(".", 1)[0] in topics for p in paths), set(paths)
    logs = [c["topicToRender"] for c in layout["configById"].values() if "topicToRender" in c]
    assert logs == ["/log"]
