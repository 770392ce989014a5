"""The proof on real recordings (issue 72): effects hidden in a copy of a real file and found
(`dyno prove --on`), a source's low-pass passed through every model, the sign read by physics."""
import json
import subprocess

from pathlib import Path

import numpy as np
import pytest

from tests.conftest import DYNO as _DYNO
from tests.test_foreign_import import _imported, _written

DYNO = [_DYNO]

UTFSM = Path(__file__).parent / "data/mr-damper-utfsm/sine/25mm0x5Hz0A.txt"
UTFSM_MAP = ["--map", "time=1:s", "--map", "displacement=2:mm", "--map", "velocity=3:mm/s", "--map", "force=4:N"]


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """The real 25 mm, 0.5 Hz, 0 A UTFSM run, imported as its README says (smoothed by its source)."""
    d = tmp_path_factory.mktemp("real")
    r = subprocess.run([*DYNO, "import", UTFSM, "--out", d / "real.mcap", *UTFSM_MAP, "--smoothed", "0.1period"],
                       cwd=d, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return d / "real.mcap"


def test_a_lag_a_zero_drift_and_temperature_damping_hidden_in_a_real_file_are_found(real, tmp_path):
    r = subprocess.run([*DYNO, "prove", "--on", real, "--effects", "lag,zero_drift,damping_temperature",
                        "--sizes", "5", "--rounds", "2", "--json"], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    rows = {row["hidden"]: row for row in doc["rows"]}
    assert set(rows) == {"lag", "zero_drift", "damping_temperature"}
    for name, row in rows.items():  # each found: named, in its group, or its dependence said
        assert row["outcome"] in ("named", "in a group", "as a dependence"), (name, row)
        assert abs(row["rms_n"] - 0.05 * doc["force_range_n"]) < 1e-3 * doc["force_range_n"]
    # the untouched file names none of them and holds neither the lag nor the drift in a group
    # (with the heat ramp its own slow change is among what a damping drift takes up)
    assert not rows["lag"]["also_untouched"] and not rows["zero_drift"]["also_untouched"], rows
    for null in doc["untouched"].values():
        assert not {"sensor_delay", "drift", "damping_temperature", "damping_drift"} & set(null["named"])
    # one timing figure for the file: prove --on's untouched copy, diagnose and its report say the same
    d = subprocess.run([*DYNO, "diagnose", real, "--report", tmp_path / "rep"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=900)
    assert d.returncode == 0, d.stderr
    timing = next(line for line in d.stdout.splitlines() if line.startswith("Timing"))
    assert timing == doc["untouched"]["untouched"]["timing"], (timing, doc["untouched"])
    assert timing in (tmp_path / "rep" / "index.html").read_text().replace("&#39;", "'")
    lag = rows["lag"]  # at one frequency, said with the cell's timing among the rivals; its size
    assert "sensor_delay" in lag["said_as"], lag  # against the file's own timing: within 30 %
    assert abs(lag["found_value"] - lag["value"]) <= 0.3 * lag["value"], lag
    assert doc["smallest_found"] == {"lag": 5.0, "zero_drift": 5.0, "damping_temperature": 5.0}


def test_prove_on_refuses_what_it_cannot_hide_in_one_line(real, tmp_path):
    r = subprocess.run([*DYNO, "prove", "--on", real, "--effects", "warp_drive"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert "'warp_drive': not something prove --on hides" in r.stderr.strip().splitlines()[-1]
    r = subprocess.run([*DYNO, "prove", "--on", tmp_path / "none.mcap"], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode != 0 and "no such file" in r.stderr and "Traceback" not in r.stderr


def test_a_butterworth_filtered_force_is_read_through_its_filter(tmp_path):
    """A DAQ's causal 2nd-order Butterworth at 15 Hz delays a 1 Hz force by 15 ms: declared
    at import, every model goes through it and no lag is left; undeclared, the cell's timing
    reads it."""
    from models.diagnose import diagnose
    from records.source_filter import parse_filtered
    from proof.on_plant import offline_recording
    ch, ev, _ = offline_recording({}, 0)
    ch = {n: (t[t < 12.0], y[t < 12.0]) for n, (t, y) in ch.items()}  # its first segments: enough, and quick
    lowpass = parse_filtered("force=butter:2:15Hz")
    t, F = ch["force"]
    filtered = {**ch, "force": (t, lowpass.apply(F, t, float(np.median(np.diff(t)))))}
    plain = diagnose(filtered, ev, jobs=2, max_effects=1)
    assert "sensor_delay" in plain.accepted, plain.accepted
    tau, fit = plain.channel_timing()  # the one timing figure is the delay accepted, the force later (15 ms at 1 Hz,
    assert fit.effect == "sensor_delay" and -0.02 < tau < -0.005, tau  # one delay fitted over all the segments)
    from models.diagnose.words import timing_sentence
    assert timing_sentence(plain).startswith("Timing (a sensor delay, accepted): the force reading lags the "
                                             f"displacement by {-1e3 * tau:.3g} ("), timing_sentence(plain)
    # undeclared, the noise's correlation reads the filter (a smooth roll-off, not a box)
    said = [f.message for f in plain.data.flags if f.kind == "smoothed"]
    assert len(said) == 1 and "--filtered force=butter:2:" in said[0], said
    read = diagnose(filtered, ev, jobs=2, max_effects=1, smoothing=lowpass)
    from models.diagnose.candidates import EFFECTS  # the valve curve's form is no claim of physics
    assert [e for e in read.named() if EFFECTS[e].nature in ("physics", "cell")] == [], read.named()
    # the import's option, said and kept with the recording
    rows = "t,x,F\n" + "".join(f"{a:.4f},{1e3 * b:.5f},{c:.3f}\n" for a, b, c in zip(t[:4000], ch["x"][1][:4000],
                                                                                 filtered["force"][1][:4000]))
    src = _written(tmp_path, "daq.csv", rows)
    _, meta, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F",
                           "--filtered", "force=butter:2:15Hz")
    assert "filtered by its source: the force through a causal butter:2:15Hz low-pass" in r.stdout, r.stdout
    from records import source_filter
    assert source_filter.of(meta) == lowpass
    r = subprocess.run([*DYNO, "import", src, "--out", tmp_path / "y.mcap", "--map", "time=t", "--map",
                        "displacement=x:mm", "--map", "force=F", "--filtered", "force=butter:2"], capture_output=True,
                       text=True)
    assert r.returncode != 0 and "expected force=butter:ORDER:CUTOFFHz" in r.stderr and "Traceback" not in r.stderr


def test_the_sign_of_a_gas_charge_pair_is_read_by_physics(tmp_path):
    """One real damper at two gas charges (its force at rest +50 and +150 N), written by a
    source that counts the other way: import advises the flip that leaves the gas force at
    or above zero, and read with it the higher charge pushes harder, by the 100 N added."""
    from records.gas_force import at_turns
    cols = np.loadtxt(UTFSM)
    t, x, F = cols[:, 0], cols[:, 1], cols[:, 3]
    args = ["--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F"]
    read = {}
    for gas in (50.0, 150.0):
        for way, (xs, Fs, flip) in {"tension": (x, -(F + gas), "force"),
                                    "other end": (-x, F + gas, "displacement")}.items():
            src = _written(tmp_path, f"{gas:g}-{way.replace(' ', '-')}.csv",
                           "t,x,F\n" + "".join(f"{a},{b},{c}\n" for a, b, c in zip(t, xs, Fs)))
            _, _, r = _imported(tmp_path, src, *args, "--overwrite")
            said = next(line for line in r.stdout.splitlines() if line.startswith("sign: "))
            assert f"import it again with --flip {flip}:" in said and "a gas spring's is above zero" in said, said
            assert "--flip force" not in said if flip == "displacement" else "--flip displacement" not in said
            channels, _, _ = _imported(tmp_path, src, *args, "--flip", flip, "--overwrite",
                                       "--setup", f"gas_psi={gas:g}")
            read[gas, way] = at_turns(channels["x"][0], channels["x"][1],
                                      np.interp(channels["x"][0], *channels["force"])).level
            (tmp_path / "x.mcap").rename(tmp_path / f"{gas:g}-{flip}.mcap")
    for way in ("tension", "other end"):
        assert read[50.0, way] > 0 and abs(read[150.0, way] - read[50.0, way] - 100.0) < 5.0, read
    # the set checked by the comparison: the gas force rises with the charge, by how much
    r = subprocess.run([*DYNO, "report", tmp_path / "150-force.mcap", tmp_path / "50-force.mcap", "--out",
                        tmp_path / "cmp"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "cmp" / "index.html").read_text()
    assert "(friction cancelled) against the gas charge: B at 50: +" in page and "it rises with the charge (+100 +- " \
        in page and "A against B over the same test, the mean force: +100 +- " in page, page
    # one of the pair read with the other flip: its gas force falls below zero, and the set says so
    _imported(tmp_path, tmp_path / "150-tension.csv", *args, "--overwrite", "--setup", "gas_psi=150")
    (tmp_path / "x.mcap").rename(tmp_path / "150-unflipped.mcap")
    r = subprocess.run([*DYNO, "report", tmp_path / "150-unflipped.mcap", tmp_path / "50-force.mcap", "--out",
                        tmp_path / "cmp2"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert "it does not rise with the charge" in (tmp_path / "cmp2" / "index.html").read_text()


def test_the_noise_is_what_repeats_not_a_drift_or_a_heat_gun():
    """A crank whose speed wanders 1 %, a load cell's zero drifting 40 N, damping falling
    16 % over the run as a heat gun warms it: the noise read is the noise's, within 10 %."""
    from models.diagnose.data import Data
    from models.diagnose.noise import noise_sd
    rng = np.random.default_rng(3)
    h, f0, n = 1 / 300, 1.5, 300 * 96
    t = np.arange(n) * h
    phase = 2 * np.pi * np.cumsum(f0 * (1 + 0.01 * np.sin(2 * np.pi * t / 40))) * h  # the crank's speed wanders
    v = np.cos(phase)
    u = t / t[-1]
    misfit = 30 * np.sign(v) * np.abs(v) ** 0.5 * (1 - 0.16 * np.sin(np.pi * u / 2))  # a valve misfit, warming
    for sigma in (2.0, 7.0):
        r = misfit + 40 * u + sigma * rng.standard_normal(n)
        d = Data(t, np.sin(phase), v, -np.sin(phase), r, np.floor(t * f0).astype(int), np.zeros(n, int),
                 np.full(n, h), [("sine", f0)])
        assert abs(noise_sd(r, d, np.ones(n, bool)) / sigma - 1) < 0.1, (sigma, noise_sd(r, d, np.ones(n, bool)))


def test_prove_on_stopped_keeps_the_copies_it_diagnosed(real, tmp_path):
    """Issue 92: SIGTERM while the copies are diagnosed ends prove --on as an operator's stop
    (exit 130, one line) with the rows done printed and the rest marked stopped."""
    from tests.conftest import operator_stopped
    p = subprocess.Popen([*DYNO, "prove", "--on", real, "--effects", "lag,zero_drift", "--sizes", "5", "--rounds",
                          "1", "--jobs", "1"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = ""
    while "1/2" not in seen:  # the first copy diagnosed (the progress bar counts it)
        c = p.stderr.read(1)
        assert c, f"prove --on ended before a copy was diagnosed: {seen}"
        seen += c
    err = operator_stopped(p)
    assert err.strip().splitlines()[-1].startswith("dyno: stopped by the operator; the copies diagnosed"), err
    rows = [line for line in p.stdout.read().splitlines()  # the proof's table, not the smallest-found one
            if line.startswith(("| lag", "| zero")) and line.count("|") == 9]
    done = [r for r in rows if "| stopped |" not in r]
    assert len(rows) == 2 and len(done) == 1 and "| lag | 5 |" in done[0], rows
