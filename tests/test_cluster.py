"""--cluster on a real Dask LocalCluster (2 worker processes on 127.0.0.1): the same results
as in this process, a task whose worker dies is re-run elsewhere, bad specs are named."""
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from models.damper import load as load_damper
from models.physics.simulate import simulate, sine
from protocols import cluster
from rig.errors import UsageError
from tests.conftest import operator_stopped, recorded

DYNO = str(Path(sys.executable).parent / "dyno")


def _force(freq):
    """The Koni's force over two cycles of a 12.7 mm sine at freq [Hz] (compressible model)."""
    d = load_damper("koni")
    t, x, v = sine(0.0127, freq, 2, d.mid_stroke, samples_per_cycle=400)
    return simulate(d, t, x, v).force


def _array_faults():
    """This process's page faults over 50 arrays of 1 MiB made, touched and freed: about 250
    when they come from the heap, 12,800 when each is mapped anew."""
    import resource
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(50):
        np.ones(1 << 17).sum()
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before


def _dies_once(marker):
    """Kill this worker process the first time (marker absent), answer the second."""
    if not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(3)
    return os.getpid()


@pytest.mark.xdist_group("cluster")
def test_a_local_cluster_gives_what_this_process_gives_and_survives_a_dead_worker(tmp_path):
    freqs = [1.0, 4.0, 8.0, 16.0]
    env = dict(os.environ)
    with cluster.pool("local:2", jobs=1) as (pool, workers):
        assert workers == 2
        remote = list(pool.map(_force, freqs))
        # a nanny starts its worker with MALLOC_TRIM_THRESHOLD_, which maps every large array anew
        assert pool.submit(_array_faults).result(timeout=120) < 3000
        pid = pool.submit(_dies_once, str(tmp_path / "died")).result(timeout=120)
    # ... and sets it in this process too, for every process started here afterwards
    assert dict(os.environ) == env
    for f, r in zip(freqs, remote):
        assert np.array_equal(r, _force(f))
    assert pid != os.getpid() and (tmp_path / "died").exists()


@pytest.mark.parametrize("spec, message", [("locl", "give local, local:WORKERS or tcp://HOST:PORT"),
                                           ("local:0", "WORKERS must be 1-1024"),
                                           ("tcp://127.0.0.1", "give local")])
def test_a_bad_cluster_is_named(spec, message):
    with pytest.raises(UsageError, match=message):
        cluster.parse(spec)


def test_an_unreachable_scheduler_is_named(monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_S", 0.5)  # nothing listens there: the test need not wait 10 s
    with pytest.raises(UsageError, match="cannot connect"):
        with cluster.executor("tcp://127.0.0.1:9"):
            pass


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    """(good, bad): a short sine-matrix recording and a file that is not one."""
    folder = tmp_path_factory.mktemp("archive")
    good, bad = folder / "good.mcap", folder / "bad.mcap"
    recorded(good, "sine-matrix", {"amplitudes_mm": [6.4, 3.2], "freqs_hz": [2.0, 8.0], "record_cycles": 4},
             plain=True)
    bad.write_text("not a recording\n")
    return good, bad


@pytest.mark.xdist_group("cluster")
@pytest.mark.parametrize("command, suffix, compare", [("diagnose", ".diagnosis.json", ("final", "accepted")),
                                                      ("identify", ".model.json", ("gas_spring", "valves"))])
def test_a_batch_on_the_cluster_equals_the_local_one_and_a_bad_file_fails_alone(archive, tmp_path, command, suffix,
                                                                                  compare):
    good, bad = archive
    docs = []
    for how in (["--jobs", "1"], ["--cluster", "local:2"]):
        summary = tmp_path / f"summary{len(docs)}.csv"
        p = subprocess.run([DYNO, command, "--batch", str(good), str(bad), "--summary", str(summary), *how,
                            "--overwrite"],  # the second run replaces the first's FILE.diagnosis.json
                           capture_output=True, text=True, timeout=600)
        assert p.returncode == 1, p.stderr[-2000:]  # one recording failed
        rows = {Path(r["recording"]).name: r for r in csv.DictReader(open(summary))}
        assert "not a readable recording" in rows["bad.mcap"]["error"] and rows["good.mcap"]["error"] == ""
        assert "Traceback" not in p.stderr
        docs.append(json.loads(good.with_suffix(suffix).read_text()))
    for key in compare:
        assert docs[0][key] == docs[1][key]
    if command == "diagnose":
        assert rows["good.mcap"]["named"] == ";".join(docs[0]["named"])
    if command == "identify":  # the damper model beside the recording; its parameters in the summary
        from models.damper import from_dict
        assert from_dict(docs[0]).layout == "monotube"
        assert float(rows["good.mcap"]["gas_spring.gamma"]) == docs[0]["gas_spring"]["gamma"]


@pytest.mark.xdist_group("cluster")
def test_a_sweep_on_the_cluster_equals_the_serial_one():
    from models.quarter_car import load as load_car
    from models.quarter_car.sweeps import frequency_response
    car, freqs = load_car("simulator"), [2.0, 9.0, 15.0]
    serial = frequency_response(car, "koni", [0.0032], freqs, workers=1)
    with cluster.pool("local:2", jobs=1) as (pool, _):
        remote = frequency_response(car, "koni", [0.0032], freqs, executor=pool)
    for k, v in serial.values.items():
        assert np.array_equal(v, remote.values[k]), k


def test_the_diagnosis_summary_says_what_the_recording_cannot_tell_apart():
    """The UTFSM 10 mm 1 Hz files: the model carries hysteresis for the MR fluid, but a
    flexible surface explains as much; a pandas reader of the summary sees that, not a name."""
    from commands.diagnose_batch import _row
    held = {"nrmse_heldout": 0.005, "rmse_heldout": 9.3, "r2_heldout": 0.9998}
    doc = {"baseline": held, "final": held, "accepted": ["bouc_wen", "position_friction"], "named": [],
           "not_proven": ["stroke_damping", "presliding_friction"],
           "may_compensate": {}, "left_over": {"within_noise": True},
           "effects": [{"effect": "bouc_wen", "rivals": [{"effect": "sensor_delay"}],
                        "stand_in": {"term": "loop_surface", "paired_p": 0.4}},
                       {"effect": "position_friction", "rivals": [], "stand_in": None},
                       {"effect": "drift", "replaced_by": "elastic_stroke"}]}
    row = _row("a.mcap", doc, None)
    assert row["accepted"] == "bouc_wen;position_friction" and row["named"] == ""
    assert row["cannot_tell_from"] == "bouc_wen~sensor_delay/loop_surface" and row["left_over_within_noise"] is True
    assert row["not_proven"] == "stroke_damping;presliding_friction"


@pytest.mark.xdist_group("cluster")
def test_a_stopped_batch_keeps_what_it_analysed_and_its_summary_says_the_rest(archive, tmp_path):
    """A lab's archive is hours of work: each result is written as it comes in, and a stop
    (SIGTERM, Ctrl-C) writes the summary with the recordings it did not reach marked."""
    import shutil
    import time
    files = [tmp_path / f"g{i}.mcap" for i in range(4)]
    for f in files:
        shutil.copy(archive[0], f)
    p = subprocess.Popen([DYNO, "diagnose", "--batch", *map(str, files), "--jobs", "1", "--summary",
                          str(tmp_path / "s.csv")], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while not files[0].with_suffix(".diagnosis.json").exists() and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.05)
    time.sleep(0.1)  # past the instant g0's file is renamed into place and its row kept
    err = operator_stopped(p)
    rows = list(csv.DictReader(open(tmp_path / "s.csv")))
    assert [Path(r["recording"]).name for r in rows] == [f.name for f in files]
    assert rows[0]["error"] == "" and rows[3]["error"] == "stopped before it was analysed", rows
    assert "diagnose: stopped; " in err and " of 4 analysed and written beside their recordings" in err, err
    assert json.loads(files[0].with_suffix(".diagnosis.json").read_text())["accepted"] is not None
