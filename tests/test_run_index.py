"""The run index (views/run_index.py) on real recordings: indexing is incremental
and keeps unreadable files as errors, runs are found by serial and protocol, a serial's
force is trended at a speed, and two writers indexing at once both land."""
import json
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from views import run_index, run_terms
from records.reader import load_recording

DYNO = [str(Path(sys.executable).parent / "dyno")]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    r = subprocess.run(DYNO + ["run", "sine-matrix", "amplitudes_mm=6.4", "freqs_hz=1,4", "record_cycles=2",
                               "--serial", "D12", "--setup", "clicks=12", "--out", str(d / "d12-a.mcap")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and f"indexed in {d / run_index.DB_NAME}" in r.stderr, r.stderr
    (d / "broken.mcap").write_bytes(b"not an mcap")
    return d


def test_a_run_indexes_itself_and_the_index_keeps_an_unreadable_file_as_one_row(folder):
    with run_index.connect(folder) as c:  # dyno run indexed what it wrote
        assert [Path(r["path"]).name for r in run_index.runs(c)] == ["d12-a.mcap"]
    got = run_index.index(folder)
    assert (got.added, got.unchanged, got.failed) == (0, 1, 1)
    again = run_index.index(folder)
    assert (again.added, again.unchanged) == (0, 2)
    with run_index.connect(folder) as c:
        rows = run_index.runs(c)
    bad = [r for r in rows if r["error"]]
    assert len(bad) == 1 and "not a readable recording" in bad[0]["error"]
    good = [r for r in rows if not r["error"]][0]
    assert (good["serial"], good["protocol"], good["outcome"]) == ("D12", "sine-matrix", "completed")
    assert '"clicks": "12"' in good["setup"] and good["duration_s"] > 5


def test_a_serials_force_is_trended_at_a_speed_as_the_velocity_table_reads_it(folder):
    shutil.copy(folder / "d12-a.mcap", folder / "d12-b.mcap")
    run_index.index(folder)
    with run_index.connect(folder) as c:
        points = run_index.trend(c, "D12", "rebound@0.1m/s")
        _, peaks = run_index.run(c, points[0][2])
        assert run_index.runs(c, serial="nobody") == [] and len(run_index.runs(c, protocol="sine-matrix")) == 2
    assert len(points) == 2 and points[0][1] == points[1][1] < 0 and points[0][3] == "clicks=12"
    # between the two measured speeds: on the line through their peaks
    (v1, F1), (v2, F2) = sorted((-p["v_reb"], p["F_reb"]) for p in peaks)
    assert v1 < 0.1 < v2 and points[0][1] == pytest.approx(np.interp(0.1, [v1, v2], [F1, F2]))
    with pytest.raises(run_index.RunIndexError, match="DIRECTION@SPEED"):
        run_index.quantity("rebound at 0.5")
    assert run_index.quantity("compression@10in/s") == ("compression", pytest.approx(0.254))
    assert run_index.quantity("rebound@500mm/s") == ("rebound", pytest.approx(0.5))  # any unit the systems name


def test_two_runs_ending_at_once_are_both_indexed(folder, tmp_path):
    for name in ("x", "y"):
        shutil.copy(folder / "d12-a.mcap", tmp_path / f"{name}.mcap")
    run_index.connect(tmp_path).close()
    errors = []

    def one(name):
        try:
            with run_index.connect(tmp_path) as c:
                run_index.index_file(c, tmp_path / f"{name}.mcap")
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=one, args=(n,)) for n in ("x", "y")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    with run_index.connect(tmp_path) as c:
        assert not errors and len(run_index.runs(c)) == 2


def _write_at(start, kind, folder):
    """One run index writer of a recording, begun at the wall-clock `start` (so that four
    in four processes overlap): dyno runs index, check, identify or diagnose's write."""
    import time
    time.sleep(max(0.0, start - time.time()))
    rec = Path(folder) / "run.mcap"
    try:
        if kind == "index":
            got = run_index.index(folder)
            return "" if got.failed == 0 else f"index failed {got.failed}"
        said = {"check": lambda: run_index.add_check(rec, "ref.mcap", "5%", [SimpleNamespace(passed=True, margin_N=3.0)]),
                "model": lambda: run_index.add_model(rec, Path(folder) / "m.json", 0.01, {"c1_c": 1.0}),
                "diagnosis": lambda: run_index.add_diagnosis(rec, "baseline", [], [], True)}[kind]()
        return "" if " indexed in " in said else said
    except Exception as e:  # noqa: BLE001 - a traceback is what the test looks for
        return f"{kind}: {type(e).__name__}: {e}"


def test_four_writers_of_one_run_index_at_once_lose_no_row_twenty_times(folder, tmp_path):
    """A check, an identify, a diagnosis and an index of one recording, in four processes at
    once, on a run index that does not exist yet: each row lands, none twice, no error."""
    import multiprocessing
    import time
    from concurrent.futures import ProcessPoolExecutor
    kinds = ("index", "check", "model", "diagnosis")
    with ProcessPoolExecutor(4, mp_context=multiprocessing.get_context("fork")) as pool:
        list(pool.map(time.sleep, [0.01] * 4))  # the workers up before the first round
        for round_ in range(20):
            d = tmp_path / f"r{round_}"
            d.mkdir()
            shutil.copy(folder / "d12-a.mcap", d / "run.mcap")
            start = time.time() + 0.05
            said = list(pool.map(_write_at, [start] * 4, kinds, [str(d)] * 4))
            assert said == [""] * 4, (round_, said)
            with run_index.reading(d) as c:
                (run,) = run_index.runs(c)
                assert run["error"] is None and run["serial"] == "D12"
                assert [len(run_index.attached(c, t, run["id"])) for t in ("checks", "models", "diagnoses")] == [1, 1, 1]
                assert len(run_index.run(c, run["id"])[1]) == 2  # its two sine segments' peaks, once


def test_a_run_index_an_earlier_version_wrote_is_read_and_gains_the_new_columns(folder, tmp_path):
    """A run index without the peaks' stroke columns (written before them) is read as it
    is, and on its next write gains them and reads its runs again to fill them."""
    import sqlite3
    from contextlib import closing
    shutil.copy(folder / "d12-a.mcap", tmp_path / "d12-a.mcap")
    old_schema = run_index.SCHEMA.replace(",\n    stroke_v TEXT, stroke_F TEXT", "")
    assert old_schema != run_index.SCHEMA
    with closing(sqlite3.connect(tmp_path / run_index.DB_NAME)) as c:
        c.executescript(old_schema)
        c.execute(f"PRAGMA application_id = {run_index.APPLICATION_ID}")
        c.execute("INSERT INTO runs (path, serial, size, mtime) VALUES (?, 'D12', 1, 1.0)",
                  (str((tmp_path / "d12-a.mcap").resolve()),))
        c.commit()
    with run_index.reading(tmp_path) as c:  # read as it is: a run with no peaks yet has no force to trend
        assert np.isnan(run_index.trend(c, "D12", "rebound@0.1m/s")[0][1])
    got = run_index.index(tmp_path)
    assert (got.added, got.updated) == (0, 1)
    with run_index.reading(tmp_path) as c:
        (_, peaks), = [run_index.run(c, r["id"]) for r in run_index.runs(c)]
        assert all(len(json.loads(p["stroke_v"])) > 10 for p in peaks)
        assert run_index.trend(c, "D12", "rebound@0.1m/s")[0][1] < 0


def test_a_diagnosis_is_indexed_with_what_it_named_and_what_its_model_kept():
    """accepted: kept in the model; named: said as found. A diagnosis that kept effects it
    did not name does not read "accepted: nothing" (docs/diagnosis.md, the words)."""
    row = {"accepted": json.dumps(["sensor_delay", "valve_form"]),
           "findings": json.dumps([{"effect": "sensor_delay", "named": True}, {"effect": "valve_form", "named": False}])}
    assert run_terms.diagnosis_words(row) == "named: sensor_delay; also in the model, not named: valve_form"
    kept = {"accepted": json.dumps(["valve_form"]), "findings": json.dumps([{"effect": "valve_form", "named": False}])}
    assert run_terms.diagnosis_words(kept) == "named: nothing; also in the model, not named: valve_form"
    older = {"accepted": json.dumps(["bouc_wen"]), "findings": json.dumps([{"effect": "bouc_wen"}])}  # named alone
    assert run_terms.diagnosis_words(older) == "named: bouc_wen"


def test_runs_are_found_by_a_where_expression_on_fields_and_setup(folder):
    run_index.index(folder)
    with run_index.connect(folder) as c:
        found = run_index.runs(c, where="setup.clicks >= 10 and outcome = completed and damper ~ kon")
        assert [Path(r["path"]).name for r in found][:1] == ["d12-a.mcap"]
        assert run_index.runs(c, where="setup.clicks > 12") == []
        assert run_index.runs(c, where="serial = 'D12' and duration_s < 1") == []
        for bad, said in (("clicks >= 10", "no field 'clicks'"), ("serial D12", "is not FIELD OP VALUE"),
                          ("serial = 1; DROP TABLE runs", "is not FIELD OP VALUE")):
            with pytest.raises(run_index.RunIndexError, match=said):
                run_index.runs(c, where=bad)
    r = subprocess.run(DYNO + ["runs", "list", str(folder), "--where", "setup.clicks = 12", "--json"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and '"serial": "D12"' in r.stdout, r.stderr


def test_runs_show_and_trend_speak_the_chosen_units(folder, capsys):
    from commands.cli import main
    run_index.index(folder)
    with run_index.connect(folder) as c:
        run_id = next(r["id"] for r in run_index.runs(c) if not r["error"])
    assert main(["runs", "show", str(run_id), str(folder), "--units", "us"]) == 0
    out = capsys.readouterr().out
    assert "v comp [in/s]" in out and "F reb [lbf]" in out and "[N]" not in out, out
    import re  # file times and starts as dates, not seconds since 1970
    assert re.search(r"^mtime +20\d\d-\d\d-\d\d \d\d:\d\d:\d\d UTC$", out, re.M), out
    assert re.search(r"^started +20\d\d-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} UTC$", out, re.M), out
    assert main(["runs", "trend", str(folder), "--serial", "D12", "--quantity", "rebound@4in/s", "--units", "us",
                 "--out", str(folder / "t.png")]) == 0
    assert "rebound@4in/s [lbf]" in capsys.readouterr().out and (folder / "t.png").stat().st_size > 10_000


def test_runs_edit_corrects_the_recording_and_its_row_and_nothing_else(folder, tmp_path, capsys):
    from commands.cli import main
    shutil.copy(folder / "d12-a.mcap", tmp_path / "d12-a.mcap")  # the shared folder stays as it was
    folder = tmp_path
    run_index.index(folder)
    with run_index.connect(folder) as c:
        row = next(r for r in run_index.runs(c) if not r["error"])
    before = load_recording(row["path"])
    assert main(["runs", "edit", str(row["id"]), str(folder), "--serial", "K-77", "--operator", "ana",
                 "--setup", "clicks_reb=14", "--note", ""]) == 0
    assert "damper_serial K-77" in capsys.readouterr().out
    after = load_recording(row["path"])
    assert after[2]["run"]["damper_serial"] == "K-77" and after[2]["run"]["setup.clicks_reb"] == "14"
    assert "note" not in after[2]["run"]  # '' removes it
    assert {k for k in before[2] if before[2][k] != after[2][k]} == {"run"} and before[1] == after[1]
    assert all(np.array_equal(before[0][k][1], after[0][k][1]) for k in before[0])
    with run_index.connect(folder) as c:
        edited, _ = run_index.run(c, row["id"])
    assert edited["serial"] == "K-77" and edited["operator"] == "ana" and '"clicks_reb": "14"' in edited["setup"]
    assert main(["runs", "edit", str(row["id"]), str(folder)]) == 2  # nothing to change: one line
