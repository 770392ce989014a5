"""Events written to a recording are read back as the same classes (records/events.py);
a recording written before a kind had its own fields, or by a newer writer, still reads."""
import json

import numpy as np
import pytest

from records import events as ev
from rig.errors import UsageError
from records.reader import load_recording, read_event
from records.recorder import Recorder
from rig import config
from tests import mcap_files

EVERY_KIND = [
    ev.RunStart(0.0, "sine-matrix", {"freqs_hz": [1.0]}, "2 segments, 9 s at most", segment_count=2, duration_max_s=9.0),
    ev.Skipped(0.0, "sine 12.7 mm 20 Hz", message="beyond the rig's speed"),
    ev.SegmentStart(0.0, "sine 12.7 mm 1 Hz", {"kind": "sine", "freq_hz": 1.0, "measured": True}),
    ev.SegmentEnd(3.0, "sine 12.7 mm 1 Hz"),
    ev.Findings(3.5, "sine 12.7 mm 1 Hz", {"findings": ["nothing left out"]}, "nothing named", source="live"),
    ev.ClosedLoopResult(4.0, "road", {"kind": "road", "j2": 0.01}, protocol="hil"),
    ev.NextTest(4.0, "sine 5 mm 4 Hz", {"round": 1, "rig_s": 2.0}, "separates friction from a lag"),
    ev.DiscoveryVerdict(5.0, "discover", {"found": []}, "Found: nothing."),
    ev.Fault(6.0, "sine 12.7 mm 1 Hz", message="force beyond the load cell"),
    ev.OperatorStop(6.0, message="operator stop"),
    ev.RunEnd(6.0, "sine-matrix", message="completed"),
]


def test_every_kind_is_read_back_as_itself(tmp_path):
    rec = Recorder(tmp_path / "r.mcap", config.load("virtual"), "{}", "sine-matrix", {})
    rec.samples({"force": (np.array([0.0, 1.0]), np.array([400.0, 410.0])), "x": (np.array([0.0, 1.0]), np.array([0.04, 0.041]))})
    for e in EVERY_KIND:
        rec.event(e)
    rec.close()
    _, events, _ = load_recording(tmp_path / "r.mcap")
    assert events == EVERY_KIND
    assert {type(e) for e in events} == set(ev.KINDS.values())


def test_a_recording_from_before_the_fields_still_reads():
    """run_start without its count, a result without its protocol: read, the gaps told apart."""
    start = read_event({"t": 0.0, "kind": "run_start", "segment": "sine-matrix", "params": {}, "message": "3 segments"})
    assert isinstance(start, ev.RunStart) and start.segment_count == 0
    result = read_event({"t": 1.0, "kind": "result", "segment": "iteration 2", "params": {"nrmse": 0.02, "iteration": 2}})
    assert isinstance(result, ev.ClosedLoopResult) and result.of == "replay"
    live = read_event({"t": 1.0, "kind": "diagnosis", "segment": "s", "params": {"source": "live", "named": []}})
    assert live.live and live.params == {"named": []}


def test_a_newer_writers_kind_is_kept_as_it_was(tmp_path):
    wire = {"t": 2.0, "kind": "calibrated", "segment": "", "params": {"gain": 1.01}, "message": "load cell"}
    e = read_event(dict(wire))
    assert isinstance(e, ev.Other) and e.kind == "calibrated" and e.wire() == wire
    mcap_files.write(tmp_path / "new.mcap", mcap_files.good_channels(), [wire], {"protocol": {"name": "x"}})
    assert load_recording(tmp_path / "new.mcap")[1] == [e]


@pytest.mark.parametrize("params, message", [
    ({"segment_count": "three"}, "segment_count is 'three', not of type int"),
    ({"source": 7}, "source is 7, not of type str"),
])
def test_a_kinds_field_of_the_wrong_type_is_refused_in_one_line(params, message):
    kind = "diagnosis" if "source" in params else "run_start"
    with pytest.raises(UsageError, match=message):
        read_event(json.loads(json.dumps({"t": 0.0, "kind": kind, "segment": "x", "params": params})))
