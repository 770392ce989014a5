"""`dyno run` on the embedded virtual rig: the recording as the standard mcap reader sees
it, refusal of bad parameters before motion, SIGKILL and `dyno recover`, and recordings
that end with the event that ended them."""
import json
import signal
import subprocess
import sys
import time
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from records.events import Findings, SegmentStart
from protocols import cell, runner
from protocols.library import sine_matrix
from protocols.plan import Plan, parse, rig_info
from records.recorder import Recorder
from rig import config
from rig.pacing import SimulatedPacer
from rig.rig import Rig
from rig.safety import Safety
from sim_backend.virtual_rig import VirtualRig
from tests.conftest import dyno

DYNO = str(Path(sys.executable).parent / "dyno")
CHANNELS = ("force", "x", "v", "x_internal", "T_body", "T_reservoir", "P_gas", "P1", "P2", "aux.valve_current")


def read(path):
    with open(path, "rb") as f:
        r = make_reader(f)
        summary = r.get_summary()
        meta = {m.name: m.metadata for m in r.iter_metadata()}
        attachments = [a.name for a in r.iter_attachments()]
        messages = [(ch.topic, sch.name, sch.encoding, json.loads(m.data)) for sch, ch, m in r.iter_messages()]
    return summary, meta, attachments, messages


def test_sine_matrix_recording_reads_with_the_standard_reader(tmp_path):
    out = tmp_path / "x.mcap"
    p = dyno("run", "sine-matrix", "--out", out, "amplitudes_mm=6.4,40", "freqs_hz=2,8", "record_cycles=3")
    assert p.returncode == 2 and "amplitudes_mm: 40 mm leaves the stroke limits" in p.stderr  # refused
    assert not out.exists()
    p = subprocess.run([DYNO, "run", "sine-matrix", "--out", str(out), "amplitudes_mm=6.4,12.7",
                        "freqs_hz=2,8,20", "record_cycles=3", "--operator", "A. Tester", "--serial", "K-0042",
                        "--setup", "clicks_reb=12", "--setup", "shims=A-3"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "skipping sine 12.7 mm 20 Hz: peak velocity 1.60 m/s" in p.stderr
    summary, meta, attachments, messages = read(out)
    topics = {c.topic for c in summary.channels.values()}
    assert topics == ({f"/channels/{c}" for c in CHANNELS} | {f"/plot/{c}" for c in CHANNELS}
                      | {"/actuator/setpoint", "/events", "/log"})
    assert {s.name for s in summary.schemas.values()} == {"dyno.Samples", "dyno.Setpoints", "dyno.Event",
                                                          "dyno.Sample", "foxglove.Log"}
    assert all(s.encoding == "jsonschema" for s in summary.schemas.values())
    assert {"software", "rig", "calibration", "damper", "protocol"} <= set(meta)
    assert json.loads(meta["protocol"]["params"])["freqs_hz"] == [2.0, 8.0, 20.0]
    assert (meta["run"]["operator"], meta["run"]["damper_serial"]) == ("A. Tester", "K-0042")
    assert (meta["run"]["setup.clicks_reb"], meta["run"]["setup.shims"]) == ("12", "A-3")
    assert "note" not in meta["run"]
    assert attachments == ["rig.toml"]
    # no gaps: per topic the message counter and the sample index both run on
    seq, n = {}, {}
    for topic, schema, _, d in messages:
        if schema == "dyno.Sample":  # one sample per message: counted by MCAP's sequence field
            continue
        assert d["seq"] == seq.get(topic, 0)
        seq[topic] = d["seq"] + 1
        if schema == "dyno.Samples":
            assert d["n0"] == n.get(topic, 0) and len(d["t"]) == len(d["value"])
            n[topic] = d["n0"] + len(d["t"])
    events = [d for t, _, _, d in messages if t == "/events"]
    assert events[0]["kind"] == "run_start" and events[-1] == {**events[-1], "kind": "run_end", "message": "completed"}
    measured = [e["segment"] for e in events if e["kind"] == "segment_start" and e["segment"].startswith("sine")]
    assert measured == ["sine 6.4 mm 2 Hz", "sine 6.4 mm 8 Hz", "sine 6.4 mm 20 Hz", "sine 12.7 mm 2 Hz",
                        "sine 12.7 mm 8 Hz"]
    assert any(e["kind"] == "skipped" and e["segment"] == "sine 12.7 mm 20 Hz" for e in events)
    # the plan's size travels as fields (the live page reads them), the sentence is for people
    assert events[0]["params"]["segment_count"] == sum(e["kind"] == "segment_start" for e in events)
    # 1 kHz for the whole run; the load cell's last frame may still be on the line at the stop
    assert n["/channels/x"] > 10000 and abs(n["/channels/force"] - n["/channels/x"]) <= 1
    # the same recording as one wide table on the force clock, for pandas or a spreadsheet
    table = tmp_path / "x.csv"
    p = dyno("export", str(out), "--csv", str(table), "--channels", "force,x,T_body")
    assert p.returncode == 0, p.stderr
    import csv
    rows = list(csv.reader(table.open()))
    assert rows[0] == ["t [s]", "t_utc", "segment", "kind", "force [N]", "x [mm]", "T_body [C]"]
    # every force sample the slower thermocouple channel covers, no empty cell at either end
    assert n["/channels/force"] - 1000 <= len(rows) - 1 <= n["/channels/force"]
    assert all(all(r[k] for k in (0, 1, 4, 5, 6)) for r in rows[1:])
    assert abs(datetime.fromisoformat(rows[1][1].rstrip("Z")) - datetime.now(timezone.utc).replace(tzinfo=None)) \
        < timedelta(hours=1)
    assert "3 channels (force [N], x [mm], T_body [C])" in p.stdout
    side = json.loads((tmp_path / "x.csv.meta.json").read_text())
    assert side["columns"] == rows[0] and side["protocol"]["name"] == "sine-matrix" and side["run"]["wall_start"]
    assert side["run"]["setup.shims"] == "A-3"  # the setup goes with the exported table
    assert {(r[2], r[3]) for r in rows[1:] if r[3] == "sine"} >= {("sine 6.4 mm 2 Hz", "sine"), ("sine 12.7 mm 8 Hz", "sine")}
    # pandas reads both back alike: the Parquet typed (time stamps, numbers), with the run in its schema
    import pandas as pd
    import pyarrow.parquet as pq
    parquet = tmp_path / "x.parquet"
    p = dyno("export", str(out), "--parquet", str(parquet), "--channels", "force,x,T_body")
    assert p.returncode == 0, p.stderr
    df, csv_df = pd.read_parquet(parquet), pd.read_csv(table)
    assert list(df.columns) == list(csv_df.columns) == rows[0] and len(df) == len(csv_df)
    assert str(df["t_utc"].dtype).startswith("datetime64") and df["force [N]"].dtype == float
    assert np.allclose(df["force [N]"], csv_df["force [N]"], rtol=1e-6, atol=0.01)
    assert json.loads(pq.read_schema(parquet).metadata[b"dyno"])["run"]["setup.shims"] == "A-3"
    # a replay target from one segment: what `dyno run replay --target` reads, about mid-stroke
    target = tmp_path / "target.csv"
    p = dyno("export", str(out), "--target", str(target), "--segment", "sine 6.4 mm 2 Hz")
    assert p.returncode == 0 and "dyno run replay --target" in p.stdout, p.stderr
    from protocols.library import replay
    from protocols.plan import ParamError
    tgt = pd.read_csv(target)
    assert list(tgt.columns) == ["t_s", "displacement_mm"] and tgt["t_s"].iloc[-1] == pytest.approx(1.5, abs=0.01)
    assert 6.0 < tgt["displacement_mm"].max() < 6.6 and abs(tgt["displacement_mm"].mean()) < 0.3
    assert replay.check(replay.Params(target=str(target)), rig_info(config.load("virtual"), None)) == []
    with pytest.raises(ParamError):  # and the reader refuses what is not one
        replay.check(replay.Params(target=str(table)), rig_info(config.load("virtual"), None))


@pytest.mark.parametrize("args, message", [
    (["sine-matrix", "amplitudes_mm=-3"], "amplitudes_mm: must be positive, got -3"),
    (["sine-matrix", "freqs_hz=2,80"], "freqs_hz: 80 Hz is above the rig's 50 Hz"),
    (["sine-matrix", "amplitude=3"], "amplitude: unknown parameter"),
    (["sine-matrix", "freqs_hz=two"], "freqs_hz: 'two' is not a number"),
    (["step", "steps_mm=0"], "steps_mm: needs non-zero steps"),
    (["temperature-sweep", "targets_c=200,60"], "targets_c: 200 C is above what the rig may reach"),
    (["temperature-sweep", "targets_c=60,15"], "targets_c: 15 C cannot be reached by cooling"),
    (["static", "points=1"], "points: 2 to 200"),
    (["low-speed", "freqs_hz=2"], "freqs_hz: 2 Hz is not low speed"),
    (["squat"], "unknown protocol 'squat'"),
])
def test_bad_parameters_are_refused_before_motion(tmp_path, args, message):
    out = tmp_path / "x.mcap"
    p = dyno("run", *args, "--out", out)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and message in p.stderr, p.stderr
    assert not out.exists()


@pytest.mark.realtime
def test_sigkill_then_recover_keeps_all_but_the_last_second(tmp_path):
    out = tmp_path / "killed.mcap"
    p = subprocess.Popen([DYNO, "run", "sine-matrix", "--realtime", "--out", str(out), "amplitudes_mm=6.4",
                          "freqs_hz=2", "record_cycles=40"], stderr=subprocess.PIPE, text=True)
    lines = [p.stderr.readline() for _ in range(2)]
    assert lines[0].startswith("pre-flight:") and "recording to" in lines[1], lines
    t_start = time.monotonic()
    time.sleep(4.0)
    # a run that ended by itself (a trip) leaves a whole file: say why, the premise is gone
    assert p.poll() is None, f"the run ended before the kill: {p.stderr.read()[-800:]}"
    p.send_signal(signal.SIGKILL)
    p.wait(10)
    elapsed = time.monotonic() - t_start
    with pytest.raises(Exception):  # noqa: B017 - the indexed reader refuses the torn file, by its own error
        with open(out, "rb") as f:
            list(make_reader(f).iter_messages())
    r = dyno("recover", str(out))
    assert r.returncode == 0 and "recovered" in r.stdout, r.stderr
    assert out.with_name("killed.mcap.damaged").exists()
    summary, meta, attachments, messages = read(out)
    assert {"rig", "damper", "protocol"} <= set(meta) and attachments == ["rig.toml"]
    t_last = max(d["t"][-1] for topic, _, _, d in messages if topic == "/channels/force")
    assert t_last > elapsed - 1.0 - 0.5  # at most the last second lost (0.5 s: start-up slack)


def run_in_process(tmp_path, inject=None, interrupt_at=None):
    c = cell.embedded("koni")
    vr = c.plant
    params = parse(sine_matrix.Params, ["amplitudes_mm=6.4", "freqs_hz=2", "record_cycles=10"])
    rec = Recorder(tmp_path / "r.mcap", c.config, "{}", sine_matrix.NAME, {}, wall_start=c.rig.wall_start,
                   overwrite=True)
    stopped = []

    def hook(samples):
        if inject and vr.t > 1.0:
            vr.inject(inject)
        if interrupt_at and vr.t > interrupt_at and not stopped:
            stopped.append(vr.t)
            raise KeyboardInterrupt  # the operator's Ctrl-C
    try:
        result = runner.run_plan(Plan(sine_matrix, params), c, [rec], sinks=[hook])
    finally:
        rec.close()
        c.close()
    events = [d for t, _, _, d in read(tmp_path / "r.mcap")[3] if t == "/events"]
    return result, events


def test_a_safety_trip_and_an_operator_stop_end_the_recording(tmp_path):
    result, events = run_in_process(tmp_path, inject="open_thermocouple")
    assert [e["kind"] for e in events[-2:]] == ["fault", "run_end"]
    assert events[-2]["message"] == "T_body (tc): open thermocouple" == result.fault
    # the report of the tripped run shows its trace up to the trip, not "No measured segments"
    from views.reports.recording import report
    index, pngs = report(tmp_path / "r.mcap", tmp_path / "rep")
    assert "trace.png" in [p.name for p in pngs] and "to where it was stopped" in index.read_text()
    assert "No measured segments" not in index.read_text()
    result, events = run_in_process(tmp_path, interrupt_at=1.5)
    assert [e["kind"] for e in events[-2:]] == ["operator_stop", "run_end"]
    assert events[-1]["message"] == "operator stop"


def test_live_view_logs_the_documented_entities():
    import rerun as rr

    from protocols.live import LiveView
    c = cell.embedded("koni")
    vr = c.plant
    rec = rr.RecordingStream("dyno-test")
    memory = rec.memory_recording()
    live = LiveView({n: ch.unit for n, ch in c.config.channels.items()}, recording=rec)
    # the text lines as logged: the stream's bytes are compressed, and whether a line reads
    # literally there depends on which rows the batcher put in one chunk with it
    lines, send = [], live.rec.log
    live.rec.log = lambda path, arch, *a, **k: (
        lines.extend(arch.text.as_arrow_array().to_pylist() if isinstance(arch, rr.TextLog) else []),
        send(path, arch, *a, **k))
    params = parse(sine_matrix.Params, ["amplitudes_mm=6.4", "freqs_hz=4", "record_cycles=4"])
    kept = runner.Kept()
    try:
        result = runner.run_plan(Plan(sine_matrix, params), c, [live, kept])
        # the live identification's estimates (gamma beside a bulk modulus) and its model's
        # force along the last segment: the plant's own damper predicts it
        live.estimates(1.0, [{"name": "gas_spring.gamma", "value": 1.3, "ci_low": 1.2, "ci_high": 1.4,
                              "identifiable": True},
                             {"name": "compressibility.beta_inv", "value": 1e8, "ci_low": 0.9e8, "ci_high": 1.1e8,
                              "identifiable": True}])
        logged, log = [], live.rec.log
        live.rec.log = lambda path, *a, **k: (logged.append(path), log(path, *a, **k))
        live.estimates(2.0, [{"name": "friction.C_ifT", "value": 2.0, "ci_low": 0.0, "ci_high": 9.0,
                              "identifiable": False}])
        assert logged == []  # nothing identifiable: no plot, no empty "identify:" line
        live.rec.log = log
        from protocols.live_identify import predicted_force
        p = predicted_force(vr.plant.damper, kept.arrays(), kept.events)
        live.prediction(3.0, p["v"], p["F"], p["F_model"])
        live.event(Findings(4.0, "", {"unsure": ["qz7 over kx9"], "settled": []},
                             "round 1: named sensor_delay"))  # dyno run discover's round
    finally:
        live.close()
        c.close()
    assert result.fault is None
    assert np.sqrt(np.mean((p["F_model"] - p["F"]) ** 2)) < 0.05 * np.ptp(p["F"])
    data = memory.drain_as_bytes()
    for entity in [f"channels/{c}" for c in CHANNELS] + [
            "loops/force_velocity", "loops/force_displacement", "loops/force_velocity/scale", "events",
            "identify/params/gas_spring.gamma", "identify/params/compressibility.beta_inv", "identify/fit/model",
            "identify/fit/measured"]:
        assert entity.encode() in data, entity
    assert b"identify/params/friction.C_ifT" not in data, "an unidentifiable estimate is not plotted"
    assert b"channels/not_a_channel" not in data
    assert any("gas_spring.gamma 1.3" in ln for ln in lines)  # the identification's text line
    assert any("sine 6.4 mm 4 Hz" in ln for ln in lines)  # the events' text
    assert "  unsure: qz7 over kx9" in lines  # a round's unsure rivals, each a line


def test_report_of_a_standard_run(koni_run, tmp_path):
    out, _ = koni_run  # static holds, low-speed, sine matrix, temperature sweep (conftest.py)
    r = dyno("report", str(out), "--out", str(tmp_path / "rep"))
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "Protocol standard," in page
    for png in ("static.png", "loops.png", "composite.png"):
        assert png in page and (tmp_path / "rep" / png).stat().st_size > 20_000
    # the friction the seal held shows: half the difference of the two approaches
    from records.reader import load_recording as load
    from records.data import segments
    ch, events, _ = load(out)
    holds = [s for s in segments(events) if "x_mm" in s[1]]
    assert len(holds) == 10 and {s[1]["approach"] for s in holds} == {"compression stroke", "extension stroke"}
    # the gas force at rest (mean of the two approaches) gives back the charge by eq 3.7
    import numpy as np

    from models.damper import load as load_damper
    from models.identify.static import identify_static, static_holds
    koni = load_damper("koni")
    x, up, down = static_holds(ch, events)
    est = identify_static(x, up, down, koni.geometry.A_r)
    P0, V0 = est["P0"], est["V0"]
    assert P0.value == pytest.approx(koni.gas_spring.P0, rel=0.05) and V0.value == pytest.approx(koni.gas_spring.V0, rel=0.08)
    assert P0.ci_low <= P0.value <= P0.ci_high and V0.ci_low <= V0.value <= V0.ci_high
    _, friction = est["friction"]
    assert np.all(friction > 50) and np.all(friction < 200)  # the Koni's seal, 55-95 N static x 1.7 moving
    # the recording's own damper overlaid: the model's peaks are the plant's; damping force
    # (measured less gas and friction) is negative in rebound at every speed
    r = dyno("report", str(out), "--model", "koni", "--out", str(tmp_path / "model"))
    assert r.returncode == 0, r.stderr
    assert "Model overlaid: koni." in (tmp_path / "model" / "index.html").read_text()
    assert (tmp_path / "model" / "report.pdf").read_bytes().startswith(b"%PDF")
    import csv
    rows = list(csv.DictReader(open(tmp_path / "model" / "peaks.csv")))
    assert len(rows) == 13  # 4 amplitudes x 3 frequencies and the sweep's sine
    for row in rows:
        for side in ("comp", "reb"):
            F, Fm = float(row[f"F_{side}_N"]), float(row[f"model_{side}_N"])
            assert abs(Fm - F) < 0.03 * abs(F) + 20.0, (row["segment"], side, F, Fm)
        assert float(row["Fd_reb_N"]) < 0 < float(row["Fd_comp_N"]), row
        assert 0.85 < float(row["reached_mm"]) / float(row["amplitude_mm"]) < 1.03, row
    # the dyno sheet's velocity table: the model's curve, read at standard speeds
    table = list(csv.DictReader(open(tmp_path / "model" / "velocity.csv")))
    assert [float(r["v_mm_s"]) for r in table][:2] == [25, 50]
    done = [r for r in table if r["F_comp_N"]]
    assert len(done) >= 5 and all(float(r["Fd_reb_N"]) < 0 < float(r["Fd_comp_N"]) for r in done)
    assert all(float(a["F_comp_N"]) < float(b["F_comp_N"]) for a, b in zip(done, done[1:]))
    # the same report in US units: the table's round in/s and the forces in lbf
    r = dyno("report", str(out), "--model", "koni", "--units", "us", "--out", str(tmp_path / "us"))
    assert r.returncode == 0, r.stderr
    us = list(csv.DictReader(open(tmp_path / "us" / "velocity.csv")))
    assert [float(r["v_in_s"]) for r in us][:3] == [1, 2, 3]
    peak_us = list(csv.DictReader(open(tmp_path / "us" / "peaks.csv")))
    assert float(peak_us[0]["F_comp_lbf"]) == pytest.approx(float(rows[0]["F_comp_N"]) / 4.4482216, rel=1e-4)
    assert "F comp [lbf]" in (tmp_path / "us" / "index.html").read_text()
    r = dyno("report", str(out), str(out), str(out), "--out", str(tmp_path / "cmp"))
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "cmp" / "index.html").read_text()
    # three runs, each named by its damper and serial; B and C against A, segment by segment
    assert page.count("<td>+0.0</td>") == 2 * 2 * 13 and "compare_composite.png" in page
    assert "A koni" in page and "C koni" in page
    diffs = list(csv.DictReader(open(tmp_path / "cmp" / "differences.csv")))
    assert len(diffs) == 2 * 13 and {d["run"] for d in diffs} == {"B", "C"}
    assert all(float(d["diff_comp_pct"]) == 0 for d in diffs)
    bad = dyno("report", str(out), "--model", str(tmp_path / "none.json"), "--out", str(tmp_path / "r"))
    assert bad.returncode == 2 and "none.json: no such file" in bad.stderr
    bad = dyno("report", str(out), "--speeds", "0.1,fast", "--out", str(tmp_path / "r"))
    assert bad.returncode == 2 and bad.stderr.strip().endswith("is not a comma-separated list of speeds in mm/s")
    bad = dyno("report", str(tmp_path / "nope.mcap"), "--out", str(tmp_path / "r"))
    assert bad.returncode == 2 and "no such file" in bad.stderr


def test_progress_counts_waits_by_their_approach_not_their_timeout():
    import io
    from types import SimpleNamespace

    from protocols.plan import Segment
    hold = lambda t: 0.1
    segs = [Segment("sine", {}, 10.0, hold), Segment("warm up", {}, 1800.0, hold, False, None, ("T_body", 320.0)),
            Segment("sine hot", {}, 5.0, hold), Segment("cool to 30 C", {}, 1800.0, hold, False, None,
                                                         ("T_body", 303.15))]
    class Terminal(io.StringIO):
        def isatty(self):
            return True
    out = Terminal()
    line = runner.ProgressLine(segs, "t", out)

    def shown(i, ts, T):
        line.last = 0.0  # the line is throttled in wall time
        line.t_wall0 = time.monotonic() - (10.0 + ts)  # a rig in real time
        line.show(i, ts, 10.0 + ts, {"T_body": SimpleNamespace(value=T)})
        return out.getvalue().rsplit("\r", 1)[-1]

    assert "ETA     5 s + 2 waits" in shown(1, 1.0, 300.0)  # how long the warming takes is not known yet
    shown(1, 5.0, 300.0)
    text = shown(1, 15.0, 310.0)  # 1 K/s, 10 K to go
    assert "warm up 36.9 C of 46.9 C" in text and "ETA    15 s + 1 wait" in text
    percent = (lambda text: int(text.split("]")[1].split("%")[0]))
    before = percent(text)
    assert percent(shown(1, 60.0, 301.0)) >= before > 0  # the warming stalls: a longer wait, the bar holds
    assert "ETA     5 s + 2 waits" in shown(1, 20.0, 299.0)  # cooling while it should warm: not known
    text = shown(3, 1.0, 310.0)  # the last wait: the bar is not full before it is done
    assert "ETA     0 s + 1 wait" in text and " 99 %" in text


def test_progress_into_a_log_is_a_line_per_segment_or_ten_seconds_never_a_redraw():
    import io

    from protocols.plan import Segment
    hold = lambda t: 0.1
    segs = [Segment("sine 1", {}, 10.0, hold), Segment("sine 2", {}, 10.0, hold)]
    out = io.StringIO()  # not a terminal: a file, a pipe
    line = runner.ProgressLine(segs, "t", out)
    for k in range(200):  # 200 calls in the first segment, 0.3 s of wall time apart
        line.last -= 0.3
        line.show(0, 0.05 * k, 0.05 * k)
    line.logged = (0, line.logged[1] - 10.0)  # ten seconds later
    line.show(0, 9.9, 9.9)
    line.last -= 0.3
    line.show(1, 0.1, 10.1)
    line.show(1, 10.0, 20.0, final="done")
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue() and len(lines) == 4
    assert "sine 1" in lines[0] and "sine 1" in lines[1] and "sine 2" in lines[2] and "100 %  done" in lines[3]


def test_the_proofs_progress_into_a_log_is_a_line_per_task():
    import io

    from workers.pool import Progress
    out = io.StringIO()
    bar = Progress(3, "prove", out)
    bar.note("null seed 0: accepted []")
    for _ in range(3):
        bar.advance()
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue() and len(lines) == 4 and lines[-1].startswith("prove [") and "3/3" in lines[-1]


def test_recover_keeps_every_intact_chunk_after_damage_and_a_damaged_magic(tmp_path):
    from mcap.writer import CompressionType, Writer

    from records.recorder import recover
    path = tmp_path / "many.mcap"
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=2048, compression=CompressionType.ZSTD)
        w.start()
        ch = w.register_channel("/x", "json", w.register_schema("s", "jsonschema", b"{}"))
        w.add_metadata("rig", {"name": "test"})
        for i in range(2000):
            w.add_message(ch, i * 1000, json.dumps({"i": i, "pad": "%08d" % (i * 7919 % 10**8)}).encode(), i * 1000, i)
        w.finish()
    data = bytearray(path.read_bytes())
    with open(path, "rb") as f:
        chunks = list(make_reader(f).get_summary().chunk_indexes)
    assert len(chunks) > 10
    hit = chunks[len(chunks) // 2]
    start = hit.chunk_start_offset + hit.chunk_length // 2
    data[start:start + 40] = b"\xff" * 40  # one chunk's compressed body damaged
    data[:8] = b"\0" * 8  # and the magic
    cut = len(data) - 300  # and the summary torn off
    path.write_bytes(bytes(data[:cut]))
    r = recover(path)
    assert r["intact"] is False and r["metadata"] == 1
    with open(path, "rb") as f:
        got = [json.loads(m.data)["i"] for _, _, m in make_reader(f).iter_messages()]
    lost = set(range(2000)) - set(got)
    assert lost and max(got) == 1999  # what follows the damage is kept to the end
    first_lost, last_lost = min(lost), max(lost)
    assert lost == set(range(first_lost, last_lost + 1))  # only the damaged chunk's messages
    assert len(lost) < 2000 / len(chunks) * 1.5


def test_a_disk_error_in_a_sink_stops_the_actuator_safely():
    """A sink writing to a full device (/dev/full: the kernel's ENOSPC) trips the run: the
    actuator holds and parks at the safe position, the other sinks get every sample."""
    from rig.loop import ControlLoop

    class DiskWriter:
        def __init__(self):
            self.f = open("/dev/full", "wb", buffering=0)
            self.calls = 0

        def samples(self, drained):
            self.calls += 1
            if self.calls > 3:
                self.f.write(json.dumps({k: len(t) for k, (t, v) in drained.items()}).encode())

    vr = VirtualRig(config.load("virtual"), damper="koni")
    cfg = vr.start()
    rig = Rig(cfg, clock=vr.clock)
    rig.open()
    disk, kept = DiskWriter(), []
    try:
        loop = ControlLoop(rig, SimulatedPacer(vr, cfg.rate_hz), Safety(cfg),
                           [disk.samples, lambda s: kept.extend(s["x"][0])])
        res = loop.run(lambda t, r: 0.030 + 0.005 * np.sin(2 * np.pi * 2 * t) if t < 5 else None)
    finally:
        rig.close()
        vr.close()
    assert res.fault == "diskwriter: No space left on device"
    assert abs(vr.plant.x_act - cfg.safe_position) < 2e-4 and abs(vr.plant.v_act) < 1e-3
    assert res.duration_s < 5 and kept[-1] == pytest.approx(res.duration_s, abs=2e-3)


def test_a_full_disk_ends_the_run_with_its_message_and_the_recording_recoverable(tmp_path):
    """`dyno run` onto a disk that fills: exit 1 naming the recorder's error first, the
    file's end reported after it, and `dyno recover` gives back what was flushed."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1200k", "tmpfs", str(disk)],
                             capture_output=True).returncode == 0
    limit = None
    if not mounted:  # no privilege to mount: the same write error from a file-size limit
        import resource

        def limit():
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (1_200_000, 1_200_000))
    try:
        out = disk / "x.mcap"
        p = subprocess.run([DYNO, "run", "sine-matrix", "--out", str(out), "amplitudes_mm=6.4", "freqs_hz=2",
                            "record_cycles=400"], capture_output=True, text=True, timeout=600, preexec_fn=limit)
        assert p.returncode == 1 and "Traceback" not in p.stderr, p.stderr
        lines = p.stderr.strip().splitlines()
        why = "No space left on device" if mounted else "File too large"
        assert lines[-1] == f"dyno: run stopped: recorder: {why}", lines[-3:]
        assert any(ln.startswith("dyno: also:") and "dyno recover" in ln for ln in lines)
        saved = tmp_path / "x.mcap"
        saved.write_bytes(out.read_bytes())
    finally:
        if mounted:
            subprocess.run(["umount", str(disk)], check=True)
    r = subprocess.run([DYNO, "recover", str(saved)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "recovered" in r.stdout, r.stderr
    summary, meta, _, messages = read(saved)
    forces = [d for topic, _, _, d in messages if topic == "/channels/force"]
    assert {"rig", "damper", "protocol", "run"} <= set(meta) and sum(len(d["t"]) for d in forces) > 5000


def test_no_repeated_setpoint_at_segment_boundaries():
    """Each segment starts where the last ended, between ticks: the setpoints of a moving
    sequence never repeat (a repeat is a 1 ms stall and a force notch in the loops)."""
    class Setpoints:
        def __init__(self):
            self.t, self.x, self.events, self.force = [], [], [], []

        def samples(self, drained):
            self.force.extend(zip(*drained["force"]))

        def setpoints(self, t, x):
            self.t += list(t)
            self.x += list(x)

        def event(self, e):
            self.events.append(e)

    obs = Setpoints()
    params = parse(sine_matrix.Params, ["amplitudes_mm=12.7", "freqs_hz=8", "record_cycles=3"])
    with cell.embedded("koni") as c:
        result = runner.run_plan(Plan(sine_matrix, params), c, [obs])
    assert result.fault is None
    x = np.array(obs.x)
    assert np.all(np.diff(x) != 0)  # a sine never stands still for a tick
    starts = [e.t for e in obs.events if isinstance(e, SegmentStart)][1:]
    assert len(starts) == 3
    t = np.array(obs.t)
    for b in starts:  # the step across each boundary is like its neighbours'
        k = np.searchsorted(t, b)
        steps = np.abs(np.diff(x[k - 3:k + 3]))
        assert steps.min() > 0.3 * steps.max()
    tf, F = np.array(obs.force).T
    for b in starts:  # and the force has no notch there: its second difference is ordinary
        k = np.searchsorted(tf, b)
        d2 = np.abs(np.diff(F[k - 40:k + 40], 2))
        assert d2[36:42].max() < 6 * np.median(d2) + 20


def test_report_of_a_step_run_measures_each_step(tmp_path):
    out = tmp_path / "step.mcap"
    p = dyno("run", "step", "steps_mm=5,-5", "--out", out)
    assert p.returncode == 0, p.stderr
    p = dyno("report", str(out), "--out", str(tmp_path / "rep"))
    assert p.returncode == 0, p.stderr
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "No measured segments" not in html and "rise 10-90 % [ms]" in html and (tmp_path / "rep" / "steps.png").exists()
    from records.reader import load_recording
    from records.data import segments
    from views.reports.recording import step_measures
    ch, events, _ = load_recording(out)
    rows = step_measures(ch, segments(events))
    # the 10 ms ramp through the 40 Hz servo: rise about the ramp's, settled within 100 ms, little overshoot
    assert [r[1] for r in rows] == [5, -5]
    assert all(5 < r[2] < 30 and r[3] < 5 and 0 < r[4] < 100 for r in rows), rows


def test_every_figure_of_a_report_speaks_its_unit_system(koni_run, tmp_path, monkeypatch):
    import re

    from views.reports import recording as page, sines
    from protocols.units import Units
    labels, save = {}, page.save

    def kept(fig, path, *a, **kw):
        labels[path.name] = [s for ax in fig.axes for s in (ax.get_xlabel(), ax.get_ylabel()) if s]
        return save(fig, path, *a, **kw)
    monkeypatch.setattr(page, "save", kept)
    monkeypatch.setattr(sines, "save", kept)
    page.report(koni_run[0], tmp_path, units=Units("us"))
    assert {"static.png", "low_speed.png", "temperature.png", "loops.png", "composite.png"} <= set(labels), labels
    shown = {m for ls in labels.values() for s in ls for m in re.findall(r"\[(.*?)\]", s)}
    assert shown and shown <= {"in", "in/s", "lbf", "F", "s", "ms", "Hz"}, labels


# planning `dyno run` in a fresh interpreter, every file it opens under sim_backend/ listed
# (Python's audit hook: imports open their sources and caches too)
_AUDITED_PLANNING = """
import os, sys
root = os.path.abspath("sim_backend") + os.sep
opened = set()
def hook(event, args):
    if event == "open" and args and isinstance(args[0], (str, bytes, os.PathLike)):
        path = os.path.abspath(os.fsdecode(args[0]))
        if path.startswith(root):
            opened.add(os.path.relpath(path))
sys.addaudithook(hook)
from commands.cli import parser
from commands.run import _plan_run
args, _ = parser().parse_known_args(["run", *sys.argv[1:]])
_plan_run(args)
print(sorted(opened))
"""


def test_a_real_cells_run_opens_no_file_of_the_simulator():
    """Planning a run on a real cell (its checks, the pre-flight, a closed loop's rehearsal,
    here against the damper model alone) reads the cell's config and the damper, never
    the virtual plant's files; the same planning on the virtual rig does (the audit sees)."""
    root = Path(__file__).resolve().parent.parent

    def planned(*argv):
        done = subprocess.run([sys.executable, "-c", _AUDITED_PLANNING, *argv], cwd=root, capture_output=True,
                              text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        return done.stdout.strip(), done.stderr

    for protocol in ("sine-matrix", "hil"):
        opened, said = planned(protocol, "--rig", "rig/configs/example-cell.toml")
        assert opened == "[]", (protocol, opened)
    assert "pre-flight (the run against the damper model alone): hil" in said
    assert "sim_backend/effects/" in planned("sine-matrix")[0]  # the virtual rig's hidden physics parsed
