"""Spencer's MR damper model (models/mr/): its integration, its identification from a record
of random motion and a random coil command, held out as published work holds out, and
`dyno identify --model spencer` on an imported CSV."""
from __future__ import annotations

import json
from dataclasses import astuple, replace

import numpy as np
import pytest

from conftest import dyno
from models.mr.identify import identify
from models.mr.spencer import SPENCER_1997, force

# a prototype with every term at work: a series stiffness, a damping and a yield rising with the current
TRUE = replace(SPENCER_1997, alpha_b=40000.0, c0_b=1500.0, c1_b=2000.0, k0=3000.0, k1=800.0, f0=25.0)
RATE_HZ = 2000.0
NOISE_N = 5.0


def _record(seconds=8.0, seed=1):
    """(t, x [m], x' [m/s], command [V], force [N]): sines of random phase 0.5-8 Hz (some 6 mm)
    and a command switching at random between 0 and 2 V every 0.1-0.4 s, the load cell's noise on."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
    f = np.geomspace(0.5, 8.0, 9)
    a = 1.5e-3 / np.sqrt(f / f[0])
    ph = rng.uniform(0, 2 * np.pi, len(f))
    x = np.sum(a[:, None] * np.sin(2 * np.pi * f[:, None] * t + ph[:, None]), axis=0)
    xd = np.sum((a * 2 * np.pi * f)[:, None] * np.cos(2 * np.pi * f[:, None] * t + ph[:, None]), axis=0)
    edges = np.cumsum(rng.uniform(0.1, 0.4, int(seconds / 0.1)))
    v = rng.uniform(0.0, 2.0, len(edges) + 1)[np.searchsorted(edges, t)]
    F = force(TRUE, x, xd, v, 1.0 / RATE_HZ) + rng.normal(0.0, NOISE_N, len(t))
    return t, x, xd, v, F


@pytest.fixture(scope="module")
def record():
    return _record()


def test_the_integration_does_not_depend_on_its_step(record):
    t, x, xd, v, _ = record
    h = 1.0 / RATE_HZ
    coarse, fine = force(TRUE, x, xd, v, h), force(TRUE, x, xd, v, h, stable=0.01)
    assert np.max(np.abs(coarse - fine)) < 1e-3 * np.ptp(fine)
    # a stroke of 1 m/s through Spencer's narrow yield: stable, bounded by its physics
    fast = force(TRUE, np.linspace(0, 0.01, 300), np.full(300, 1.0), np.full(300, 2.0), 1e-4)
    assert np.all(np.isfinite(fast)) and np.max(np.abs(fast)) < 1e5


@pytest.mark.rounding
def test_the_model_is_identified_from_its_own_record_and_holds_out(record):
    t, x, xd, v, F = record
    fitted = identify(t, x, xd, v, F, holdout=0.15)
    assert fitted.held.r2 > 0.999 and fitted.held.rmse < 3 * NOISE_N, fitted.held
    assert fitted.held.from_s == pytest.approx(0.85 * t[-1], abs=0.01)
    truth = dict(zip([e.name for e in fitted.estimates], astuple(TRUE)))
    named = {e.name: e for e in fitted.estimates}
    # the yield's size and the viscous term, each with its rise with the current, and the coil's lag
    for name in ("alpha_a", "alpha_b", "c0_a", "c0_b", "eta"):
        e = named[name]
        assert e.determined and e.ci[0] < truth[name] < e.ci[1], (e, truth[name])


def test_a_record_at_one_current_does_not_determine_the_current_s_terms(record):
    """At one command the yield's size at no current and its rise with the current trade
    exactly: said as not determined, not given an interval."""
    t, x, xd, _, F = record
    one = np.full(len(t), 1.0)
    F = force(TRUE, x, xd, one, 1.0 / RATE_HZ) + np.random.default_rng(2).normal(0.0, NOISE_N, len(t))
    named = {e.name: e for e in identify(t, x, xd, one, F, holdout=0.15).estimates}
    assert not (named["alpha_a"].determined and named["alpha_b"].determined)
    assert not (named["c0_a"].determined and named["c0_b"].determined)


def test_identify_model_spencer_on_an_imported_table(tmp_path, record):
    t, x, xd, v, F = record
    csv = tmp_path / "mr.csv"
    np.savetxt(csv, np.column_stack([t, x * 1e3, F, v]), delimiter=",", header="time,disp,force,volts", comments="")
    rec = tmp_path / "mr.mcap"
    p = dyno("import", csv, "--out", rec, "--map", "time=time:s", "--map", "displacement=disp:mm",
             "--map", "force=force:N", "--map", "aux.coil=volts:V")
    assert p.returncode == 0, p.stderr
    p = dyno("identify", rec, "--model", "spencer", "--holdout", "tail:0.2", "--json", "--report", tmp_path / "rep")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert {f.name for f in (tmp_path / "rep").iterdir()} == {"index.md", "mr-heldout.png", "mr-loops.png"}
    assert "not determined" not in (tmp_path / "rep" / "index.md").read_text().split("| alpha_b |")[1].split("\n")[0]
    assert doc["coil"] == "aux.coil" and doc["holdout_tail"] == 0.2
    assert doc["heldout"]["r2"] > 0.99, doc["heldout"]
    assert json.loads((tmp_path / "mr.spencer.json").read_text())["parameters"].keys() == doc["parameters"].keys()
    for args, message in ((("--holdout", "tail:0.7", "--overwrite"), "0 < F < 0.5"),
                          (("--holdout", "tail:abc"), "0 < F < 0.5"),  # named before the existing output
                          (("--coil", "aux.coil"), "--model spencer"),
                          (("--model", "spencer", "--coil", "aux.none", "--overwrite"), "no aux.none channel")):
        p = dyno("identify", rec, *(["--model", "spencer"] if args[0] == "--holdout" else []), *args)
        assert p.returncode == 2 and p.stderr.count("\n") == 1 and message in p.stderr, p.stderr


def test_the_rig_at_its_stop_is_left_out_where_its_accelerometer_says_so(tmp_path, record):
    """Issue 91: the NEES record ends with the actuator banging at its stop, its accelerometer
    (a reading, column A) pinned at both rails, the force the rig's. Mapped as an aux
    reading, its rails leave those samples out of the fit and the judgement, and say so;
    the coil's command (declared a drive) sits at its extremes unflagged."""
    t, x, xd, v, F = record
    rng = np.random.default_rng(3)
    acc = np.gradient(xd, t) + rng.normal(0.0, 0.05, len(t))  # m/s^2, changing every sample
    stop = (t >= 7.0) & (t < 7.3)  # in the held-out tail (the last 20 %)
    rail = float(np.max(np.abs(acc))) * 1.2
    acc[stop] = np.clip(50.0 * rail * np.sin(2 * np.pi * 25 * t[stop]), -rail, rail)
    F = F.copy()
    F[stop] = 3000.0 * np.sin(2 * np.pi * 40 * t[stop])  # what the load cell reads of the impacts
    csv = tmp_path / "stop.csv"
    np.savetxt(csv, np.column_stack([t, x * 1e3, F, v, acc]), delimiter=",", header="time,disp,force,volts,acc",
               comments="")
    rec = tmp_path / "stop.mcap"
    p = dyno("import", csv, "--out", rec, "--map", "time=time:s", "--map", "displacement=disp:mm", "--map",
             "force=force:N", "--map", "aux.coil=volts:V", "--drive", "aux.coil=coil voltage", "--map", "aux.acc=acc")
    assert p.returncode == 0, p.stderr
    p = dyno("identify", rec, "--model", "spencer", "--holdout", "tail:0.2", "--json")
    assert p.returncode == 0, p.stderr
    held = json.loads(p.stdout)["heldout"]
    assert "saturated run(s) in aux.acc" in p.stderr and "in aux.coil" not in p.stderr, p.stderr
    tail = t >= t[len(t) - int(round(0.2 * len(t)))]
    assert held["samples"] <= int(np.sum(tail & ~stop)) and held["r2"] > 0.99, held
