"""A file whose source smoothed force and displacement (the UTFSM sine files: a moving average
a tenth of a test period long) is compared with every model through the same filter once
import is told it (records/source_filter.py)."""
import json

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from records import source_filter
from models.minimal import MinimalModel
from records.reader import load_recording
from tests.conftest import dyno
from tests.test_hostile_inputs import one_line_error

# their verdicts must not be one processor's last bits: run again under another kernel (Makefile)
pytestmark = pytest.mark.rounding

# a minimal model's baseline as identified on the UTFSM 5 mm 3 Hz 0.5 A file, filter declared
TRUTH = {"c1_c": 25908.4, "c2_c": 4624.7, "C_c": 2543.5, "Fcr_c": 542.1, "c1_r": 12987.4, "c2_r": 43198.3,
         "C_r": 2203.4, "Fcr_r": 444.1, "G0": -56.8, "L": 0.0137, "F_c": 235.6}
MAP = ["--map", "time=time [s]", "--map", "displacement=displacement [mm]", "--map", "force=force [N]"]


def test_the_width_is_a_share_of_the_period_or_a_time():
    assert source_filter.parse("0.1period") == source_filter.Smoothing(0.1, True)
    assert source_filter.parse(" 0.1 period ").text() == "0.1 period"
    assert source_filter.parse("20ms") == source_filter.Smoothing(0.02, False)
    assert source_filter.parse("0.02s").samples(1e-3, None) == 20
    assert source_filter.parse("0.1period").samples(1e-3, 3.0) == 33
    assert source_filter.parse("0.1period").samples(1e-3, None) == 1  # no period: no filter
    for bad in ("2", "0period", "-5ms", "1.5period", "nanperiod", "fast"):
        with pytest.raises(ValueError):
            source_filter.parse(bad)


def test_a_centred_average_keeps_a_level_and_shrinks_a_sine_by_its_sinc():
    h, f = 1e-3, 1.0
    t = np.arange(0, 4.0, h)
    s = source_filter.parse("0.1period")
    assert np.allclose(s.apply(np.full(len(t), 7.0), t, h, f), 7.0)
    y = s.apply(np.sin(2 * np.pi * f * t), t, h, f)
    inner = slice(100, -100)  # no phase: the peak stays where it was
    assert np.max(y[inner]) == pytest.approx(np.sinc(0.1), abs=2e-3)
    assert abs(np.argmax(y[:1000]) - 250) <= 1
    # never across a hole: a gap longer than 1.5 samples starts a new stretch
    k = (t < 1.0) | (t > 1.5)
    y = s.apply(np.where(t < 1.0, 0.0, 1.0)[k], t[k], h, f)
    assert np.all(y[t[k] < 1.0] == 0.0)


def _smoothed_file(path, amp_mm, f, h=1e-3, cycles=10):
    """A sine test of the TRUTH damper with 3 N of load-cell noise, both channels then
    through a centred moving average a tenth of the period long, as the source wrote them."""
    t = np.arange(0, cycles / f, h)
    x = amp_mm * 1e-3 * np.sin(2 * np.pi * f * t)
    F = MinimalModel("truth", TRUTH, 0.0).force(x, np.gradient(x, t)) + np.random.default_rng(1).normal(0, 3.0, len(t))
    n = int(round(0.1 / (f * h)))
    x, F = uniform_filter1d(x, n, mode="nearest"), uniform_filter1d(F, n, mode="nearest")
    np.savetxt(path, np.c_[t, 1e3 * x, F], fmt="%.6f", header="time [s],displacement [mm],force [N]",
               comments="", delimiter=",")
    return path


def test_a_model_identified_through_the_declared_filter_is_the_damper_and_carries_to_another_period(tmp_path):
    """Without the filter the rounding at each reversal was identified as physics (a
    hysteresis, a delay) and the friction read 31 N of 236; the model of the 1 Hz test then
    missed the 3 Hz test's velocity table by up to 14 %."""
    one, three = _smoothed_file(tmp_path / "1hz.csv", 10, 1.0), _smoothed_file(tmp_path / "3hz.csv", 5, 3.0)
    for src in (one, three):
        r = dyno("import", src, *MAP, "--smoothed", "0.1period", "--out", src.with_suffix(".mcap"))
        assert r.returncode == 0 and "a centred moving average of 0.1 period" in r.stdout, r.stderr
    assert source_filter.of(load_recording(three.with_suffix(".mcap"))[2]) == source_filter.Smoothing(0.1, True)
    r = dyno("identify", one.with_suffix(".mcap"), "--json", "--out", tmp_path / "1hz.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    got = {k: p["value"] for k, p in doc["parameters"].items()}
    for name in ("F_c", "C_c", "C_r", "Fcr_c", "Fcr_r"):
        assert got[name] == pytest.approx(TRUTH[name], rel=0.05), name
    # no hysteresis is named (a filter's rounding at each reversal was): what the model keeps
    # beyond the truth may differ with a machine's rounding, its fit may not
    assert "bouc_wen" not in doc["named"] + doc["at_edge"] and doc["heldout_nrmse"] < 0.005
    r = dyno("check", three.with_suffix(".mcap"), "--against", tmp_path / "1hz.json")
    assert r.returncode == 0 and "PASS: 6 of 6" in r.stdout, r.stdout
    # the same file read as unsmoothed: the damper's own force is not what the file holds
    assert dyno("import", three, *MAP, "--out", tmp_path / "plain.mcap").returncode == 0
    r = dyno("check", tmp_path / "plain.mcap", "--against", tmp_path / "1hz.json")
    assert r.returncode == 1 and "FAIL" in r.stdout, r.stdout
    # identify of recordings smoothed differently: one filter cannot stand for both
    one_line_error(dyno("identify", one.with_suffix(".mcap"), tmp_path / "plain.mcap", "--out", tmp_path / "b.json"),
                   "give recordings smoothed alike")


def test_a_full_model_identified_through_the_declared_filter_fits_its_held_out_sine_better(tmp_path):
    """identify --damper: the compressible fit and its held-out segment simulate the
    described damper, and the simulated force goes through the source's filter too. The
    Koni's loops, written through a tenth-of-a-period average: held out 1.78 % unfiltered,
    0.82 % through the filter."""
    from models.damper import load
    from models.physics.simulate import simulate
    d, h, rng = load("koni"), 1e-3, np.random.default_rng(3)
    rows, t0 = [], 0.0
    for amp, f in ((0.010, 1.0), (0.005, 3.0), (0.008, 2.0)):
        t = np.arange(0, 8 / f, h)
        x = d.mid_stroke + amp * np.sin(2 * np.pi * f * t)
        F = simulate(d, t, x, np.gradient(x, t), T=293.15, compressible=True, x_e=d.mid_stroke).force
        n = int(round(0.1 / (f * h)))
        rows.append(np.c_[t + t0, 1e3 * uniform_filter1d(x, n, mode="nearest"),
                          uniform_filter1d(F + rng.normal(0, 3.0, len(t)), n, mode="nearest")])
        t0 += t[-1] + h
    np.savetxt(tmp_path / "k.csv", np.concatenate(rows), fmt="%.6f", delimiter=",",
               header="time [s],displacement [mm],force [N]", comments="")
    held = {}
    for name, extra in (("plain", []), ("smoothed", ["--smoothed", "0.1period"])):
        assert dyno("import", tmp_path / "k.csv", *MAP, *extra, "--out", tmp_path / f"{name}.mcap").returncode == 0
        r = dyno("identify", tmp_path / f"{name}.mcap", "--damper", "koni", "--json", "--out", tmp_path / f"{name}.json")
        assert r.returncode == 0, r.stderr
        held[name] = json.loads(r.stdout)["heldout_nrmse"]
    # a band, not one machine's last bits: 1.62 % against 3.19 % here, 1.76 % against 2.70 % on
    # an AMD EPYC (segments begun at a crossing); 0.82 % against 1.78 % (issue 88's cut: each
    # test's whole cycles, less the filter's reach at their ends when it is declared); 1.25 %
    # against 1.8-3.3 % with a valve law validated on the slowest training segment
    assert held["smoothed"] < 0.02 and held["smoothed"] < 0.75 * held["plain"], held
    # the report's and check's overlay of the damper itself along the smoothed recording goes
    # through the filter too: 10-14 N RMS from the recorded force, 43-50 N unfiltered
    from records.data import segments
    from views.reports import peaks
    ch, events, meta = load_recording(tmp_path / "smoothed.mcap")
    through = peaks.along(d, ch, events, meta)
    assert isinstance(through, peaks.ThroughSource)
    for _, prm, t0, t1 in segments(events, kinds=("sine",)):
        t, (F, x, v) = peaks.window(ch, ("force", "x", "v"), t0, t1)
        k = t >= t[0] + peaks.settled_after(prm)
        rms = [np.sqrt(np.mean((peaks.simulate_segment(m, t, x, v, 293.15).force[k] - F[k]) ** 2)) for m in (d, through)]
        assert rms[1] < 0.4 * rms[0], rms
    assert dyno("report", tmp_path / "smoothed.mcap", "--model", "koni", "--out", tmp_path / "rep").returncode == 0


def test_a_width_import_cannot_read_or_apply_is_one_line(tmp_path):
    src = _smoothed_file(tmp_path / "s.csv", 5, 3.0, cycles=4)
    one_line_error(dyno("import", src, *MAP, "--smoothed", "10", "--out", tmp_path / "s.mcap"),
                   "--smoothed '10'", "0.1period")
    assert not (tmp_path / "s.mcap").exists()
    # motion that does not repeat has no period to take a share of; a time applies
    t = np.arange(0, 20.0, 1e-3)
    x = np.cumsum(np.random.default_rng(2).normal(0, 1e-5, len(t)))
    np.savetxt(tmp_path / "r.csv", np.c_[t, 1e3 * x, 3e3 * np.gradient(x, t)], fmt="%.6f", delimiter=",",
               header="time [s],displacement [mm],force [N]", comments="")
    one_line_error(dyno("import", tmp_path / "r.csv", *MAP, "--smoothed", "0.1period", "--out", tmp_path / "r.mcap"),
                   "no stroke of this file repeats", "as a time")
    assert not (tmp_path / "r.mcap").exists()
    assert dyno("import", tmp_path / "r.csv", *MAP, "--smoothed", "20ms", "--out", tmp_path / "r.mcap").returncode == 0
