"""One verdict per recording (issue 71): every decision of the diagnosis is taken on several
judgements of the held-out blocks, so that one near its threshold is said as such and none
flips with the last bits of the arithmetic: another processor's rounding, or a force
rescaled by a millionth of any load cell's resolution."""
import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from models.diagnose import blocks, stability
from models.diagnose.kernels import delayed, plateau, plateau_reach, plateau_tangent
from models.diagnose.referees import _first
from models.diagnose.result import Candidate, Tried
from tests.conftest import dyno
from tests.verdicts import verdict

DYNO = str(Path(sys.executable).parent / "dyno")
SINE = Path(__file__).parent / "data" / "mr-damper-utfsm" / "sine"
MAP = ["--map", "time=1:s", "--map", "displacement=2:mm", "--map", "velocity=3:mm/s", "--map", "force=4:N",
       "--smoothed", "0.1period"]  # the files' README (tests/real_data.toml)
OTHER_KERNEL = {"OPENBLAS_CORETYPE": "Sandybridge", "NUMBA_CPU_NAME": "generic"}


def test_shifted_blocks_cut_every_cycle_into_as_many_blocks_elsewhere():
    cycle = np.repeat(np.arange(6), [40, 41, 39, 40, 40, 43])
    d = SimpleNamespace(cycle=cycle)
    own = blocks(d)
    assert np.array_equal(own // 4, cycle) and len(np.unique(own)) == 24
    for k in range(1, stability.SHIFTS):
        moved = blocks(d, offset=k / stability.SHIFTS)
        assert np.array_equal(moved // 4, cycle) and len(np.unique(moved)) == 24
        assert 0.05 < np.mean(moved != own) < 0.95  # another partition, of the same cycles


def test_a_statistic_near_its_fixed_bar_counts_half():
    assert stability.against(0.2, 0.1) == 1.0 and stability.against(0.05, 0.1) == 0.0
    assert stability.against(0.11, 0.1) == 0.5 and stability.against(0.09, 0.1) == 0.5
    assert stability.against(float("nan"), 0.1) == 0.0
    assert stability.holds(10 / 15) and not stability.holds(9 / 15)
    assert stability.at_edge(0.5) and not stability.at_edge(5 / 15) and not stability.at_edge(10 / 15)
    n = stability.SHIFTS * stability.DRAWS
    assert n % 2 == 1  # no share of judgements is one half: a majority is always one


@pytest.mark.rounding
def test_of_equals_the_model_carries_the_catalogues_first_whichever_gained_more():
    """Two candidates the held-out blocks cannot tell apart: which gained 0.1 % more is the
    last bits' choice, the one carried is not."""
    rng = np.random.default_rng(0)
    block = np.repeat(np.arange(60), 30)
    judge = stability.Judge(np.ones(len(block), bool),
                            [stability.Variant(block, np.arange(60), s) for s in range(3)])
    r = rng.normal(0, 10.0, len(block))

    def cand(effect, gain, resid):
        return Tried(Candidate(effect, 1, {}, {}, 0.01, 10.0, 0.99, 1e-4, gain, 1.0), {}, [], resid)
    a = cand("compressibility", 50.0, r * (1 + rng.normal(0, 0.01, len(r))))
    b = cand("sensor_delay", 49.9, r)
    worse = cand("free_play", 60.0, r * 0.5)  # clearly better: carried whatever the order
    order = ["sensor_delay", "free_play", "compressibility"]
    assert _first([a, b], [a, b], order, judge).candidate.effect == "sensor_delay"
    assert _first([b, a], [b, a], order, judge).candidate.effect == "sensor_delay"
    assert _first([a], [a, b], order, judge).candidate.effect == "sensor_delay"  # b accepted in fewer judgements: at the edge
    assert _first([a, b, worse], [a, b, worse], order, judge).candidate.effect == "free_play"


@pytest.mark.rounding
def test_the_baselines_derivatives_are_its_differences():
    """The valves' (eq 3.30, both sides of the cracking force), the gas force's and the
    friction's exact derivatives (Minimal.columns), which the fits read instead of a model
    evaluation per parameter: each equals a central difference of the force."""
    from models.diagnose.candidates import Minimal, Model
    from models.diagnose.design import Sine, motion
    d = motion(Sine(0.01, 2.0, 0.038), SimpleNamespace(T=None, aux={}))
    d.F = np.zeros(len(d.t))
    p = {"c1_c": 3000.0, "c2_c": 2e5, "C_c": 1700.0, "Fcr_c": 770.0, "c1_r": 6900.0, "c2_r": 2.8e5,
         "C_r": 4700.0, "Fcr_r": 1060.0, "G0": 430.0, "L": 0.05, "F_c": 70.0}
    m = Model(d, base=Minimal(d))
    # and valves whose quadratic terms a fit drove to almost nothing, where the closed form
    # used before lost the cracking force below the last bit (its difference read zero)
    for q in (p, {**p, "c2_c": 3e-6, "c2_r": 2e-6}):
        exact = m.columns(m.forces(d, q))
        assert set(exact) == set(q)
        for k, v in q.items():
            h = 1e-6 * max(abs(v), 1.0)
            diff = (m.force(d, {**q, k: v + h}) - m.force(d, {**q, k: v - h})) / (2 * h)
            assert np.allclose(exact[k], diff, rtol=1e-5, atol=1e-5 * max(np.max(np.abs(diff)), 1e-3)), k
    # an effect that changes the damping carries them through (tests/test_diagnose.py, each effect's)
    altered = Model(d, ["compressibility"], base=Minimal(d))
    assert set(altered.columns(altered.forces(d, {**p, "inv_k_oil": 1e-7}))) == set(p) | {"inv_k_oil"}


def test_a_clearance_s_derivatives_worked_near_its_crossings_are_those_worked_everywhere():
    """plateau_tangent works only on plateau_reach's samples: every sample the clearance
    changes is among them, and the derivatives there are those of the samples the dense
    rows give (gathered from rows known everywhere), whatever the clearance, rate and
    spacing: a crossing it missed would leave a derivative of the force without the gap."""
    rng = np.random.default_rng(3)
    for trial in range(60):
        n = int(rng.integers(50, 3000))
        h = 10 ** rng.uniform(-4, -2.5)
        t = np.cumsum(rng.uniform(0.7, 1.3, n) * h) if trial % 2 else np.arange(n) * h
        F = 500 * np.sin(2 * np.pi * rng.uniform(0.5, 20) * t) + rng.normal(0, 20, n)
        S = np.abs(rng.normal(2000, 500, n))
        W = 0.5 * h
        for c in (0.0, 1e-7, 1e-5, 1e-3):
            reach = plateau_reach(F, S, t, c, W)
            at = reach[0]
            assert set(np.flatnonzero(plateau(F, S, t, c, W) != F)) <= set(at), (trial, c)
            dF, dS = rng.normal(size=(3, n)), rng.normal(size=(3, n))
            out = plateau_tangent(F, S, t, W, reach, dF[:, at], dS[:, at], np.array([0.0, 1.0, 0.0]))
            # a row's samples outside the reach are its own: the reach is where it changes
            wider = np.unique(np.r_[at, rng.choice(n, min(n, 40), replace=False)])
            again = plateau_tangent(F, S, t, W, (wider, reach[1]), dF[:, wider], dS[:, wider], np.array([0.0, 1.0, 0.0]))
            assert np.array_equal(again[:, np.searchsorted(wider, at)], out), (trial, c)
            assert np.array_equal(np.delete(again, np.searchsorted(wider, at), axis=1),
                                  np.delete(dF[:, wider], np.searchsorted(wider, at), axis=1)), (trial, c)


@pytest.mark.rounding
def test_a_delayed_channel_is_numpys_interpolation_to_the_last_bit():
    """kernels.delayed (a sensor delay's or the alignment's shift) is np.interp(t - tau, t, y)
    bit for bit: even and uneven spacing, shifts within a sample and beyond both ends, nan and
    inf among the values; each row of several shifted at once (the motion's three) as alone."""
    rng = np.random.default_rng(7)
    for trial in range(300):
        n = int(rng.integers(2, 2000))
        h = 10 ** rng.uniform(-5, -2)
        t = np.arange(n) * h + rng.uniform(0, 100) if trial % 2 else np.cumsum(rng.uniform(0.5, 1.5, n) * h)
        Y = rng.normal(size=(3, n)) * 10 ** rng.uniform(-6, 4, (3, 1))
        for tau in (0.0, h * rng.uniform(-3, 3), h * rng.uniform(-0.1, 0.1), t[1] - t[0], 1e9, -1e9):
            out = delayed(Y, t, tau)
            for y, row in zip(Y, out):
                assert np.array_equal(row, np.interp(t - tau, t, y)), (trial, tau)
            assert np.array_equal(delayed(Y[1:2], t, tau)[0], out[1])
    Y, t = np.array([[1.0, np.inf, 3.0, np.nan, 5.0], [np.nan, 1.0, -np.inf, 2.0, 2.0]]), np.arange(5.0)
    for tau in (0.3, -0.3, 0.0, 1.0):
        for y, row in zip(Y, delayed(Y, t, tau)):
            assert np.array_equal(row, np.interp(t - tau, t, y), equal_nan=True), tau


@pytest.mark.parametrize("current", ["0x25"])  # its verdict, measured three ways on this machine: stroke damping, a stand-in
def test_a_real_recording_gets_one_verdict_three_ways(tmp_path, current):
    """The UTFSM damper's 25 mm 0.5 Hz test: diagnosed as it is, under another processor's
    rounding (OpenBLAS's Sandybridge kernels, numba for a generic x86-64) and with its force
    rescaled by 1 + 1e-9: the same names, the same at the edge, the same groups; the JSON
    and the sentence carry each finding's share."""
    docs = []
    for name, gain, env in (("as-is", [], {}), ("kernel", [], OTHER_KERNEL),
                            ("rescaled", ["--gain", f"force={1 + 1e-9!r}"], {})):
        rec = tmp_path / f"{name}.mcap"
        assert dyno("import", SINE / f"25mm0x5Hz{current}A.txt", "--out", rec, *MAP, *gain).returncode == 0
        p = subprocess.run([DYNO, "diagnose", str(rec), "--json"], capture_output=True, text=True, timeout=600,
                           env={**os.environ, **env})
        assert p.returncode == 0, p.stderr
        docs.append(json.loads(p.stdout))
    verdicts = [verdict(d) for d in docs]  # named, at the edge, groups, each decision held or at the edge
    assert verdicts[1] == verdicts[0] and verdicts[2] == verdicts[0], verdicts
    doc = docs[0]
    assert doc["judgements"] == stability.SHIFTS * stability.DRAWS
    assert all(0.0 <= e["held_in"] <= 1.0 for e in doc["effects"] if "held_in" in e)
    said = [e for e in doc["effects"] if e.get("held_in", 0) > stability.EDGE]
    assert all(f"{100 * e['held_in']:.0f} % of {doc['judgements']} judgements" in doc["summary"] for e in said)



def test_a_fit_that_stops_at_its_step_limit_is_said_not_converged(monkeypatch):
    """Convergence is checked: a fit cut at its step limit says so (cross_fit's stopped,
    the baseline's sentence and the JSON), one that converges does not."""
    from models.diagnose import diagnose, fitting
    from models.diagnose.candidates import Minimal, Model
    from models.diagnose.design import Sine, motion
    from models.diagnose.words import summary
    from views.reports.diagnosis import to_json
    from tests.test_diagnose import _sines_run
    d = motion(Sine(0.01, 2.0, 0.038), SimpleNamespace(T=None, aux={}))
    m = Model(d, base=Minimal(d))
    truth = {p.name: p.x0 for p in m.params} | {"c1_c": 3000.0, "c1_r": 6900.0, "G0": 430.0, "F_c": 70.0}
    d.F = m.force(d, truth) + np.random.default_rng(0).normal(0.0, 2.0, len(d.t))
    folds = [(d.cycle % 2 == k, d.cycle % 2 != k) for k in (0, 1)]
    cut, done = [], []
    fitting.cross_fit(m, d, folds, [{}, {}], stopped=done)
    monkeypatch.setattr(fitting, "MAX_STEPS", 2)
    fitting.cross_fit(m, d, folds, [{}, {}], stopped=cut)
    assert cut == [True, True] and done == [False, False]
    res = diagnose(*_sines_run(lambda t, x, v, F, f, T: F), max_effects=0)
    assert res.baseline.stopped == 2 and to_json(res)["baseline"]["folds_not_converged"] == 2
    assert "Not converged: the baseline's fit stopped at its limit of 2 steps on 2 folds" in summary(res)


@pytest.mark.rounding
def test_a_fit_stopped_at_a_kink_starts_again_where_it_stopped(tmp_path):
    """A trust region that shrank at a kink of the residual stops on the cost's tolerance
    short of its optimum, wherever the last bits left it (fitting.solve): a fresh start
    checks each stop. The minimal baseline on the UTFSM 25 mm 0.5 Hz 0 A file, both folds,
    its first three starts: one trust region alone stopped 1.2e-3 of the cost short on one of
    six, under this machine's rounding and the other kernel's (3 and 5 of 6 beyond 1e-5); with
    fresh starts each stopped within 1e-3 of a tightly polished optimum (one 2-5e-4 short), and
    with a rectangular trust region tried where a fresh one gains less than FTOL, all eight
    within 1.5e-5 under both (the whole cycles cut at import, 2026-12-05: the first start
    1.3e-5 short under both, the fourth 0.6e-5 and 1.4e-5; a polish of hundreds of evaluations
    finds that much, 1e-4 of the gain a decision counts, referees.RELEVANCE)."""
    from scipy.optimize import least_squares
    from models.diagnose import _starts, fitting, holdout_masks
    from models.diagnose.candidates import WITH_BASELINE, Minimal, Model
    from models.diagnose.data import prepare
    from records import source_filter
    from records.reader import load_recording
    rec = tmp_path / "r.mcap"
    assert dyno("import", SINE / "25mm0x5Hz0A.txt", "--out", rec, *MAP).returncode == 0
    ch, events, meta = load_recording(rec)
    d = prepare(ch, events, None, source_filter.of(meta))
    base = Minimal(d)
    m = Model(d, list(WITH_BASELINE), base=base)
    names = [p.name for p in m.params]
    lo, hi = np.array([p.lo for p in m.params]), np.array([p.hi for p in m.params])
    Fs = float(np.std(d.F))
    short = []
    for train, _ in holdout_masks(d)[0]:
        resid = lambda z, train=train: (m.force(d, dict(zip(names, z))) - d.F)[train] / Fs
        for start in [{}] + _starts(d, base):
            landed = fitting.fit(m, d, train, start)[0]
            z = np.array([landed[n] for n in names])
            scale = np.maximum((hi - lo) * 1e-3, np.abs(z) * 0.1)
            best = least_squares(lambda u: resid(u * scale), z / scale, bounds=(lo / scale, hi / scale), ftol=1e-14,
                                 xtol=1e-14, gtol=1e-14, x_scale="jac", max_nfev=300)
            cost = float(np.sum(resid(z) ** 2))
            short.append((cost - 2 * best.cost) / cost)
    assert max(short) < 1e-4 and sum(s > 1e-5 for s in short) <= 2, short


@pytest.mark.rounding
def test_the_baseline_lands_in_one_valley_whatever_the_last_bits(tmp_path):
    """The UTFSM 2 mm 5 Hz 1 A file, an MR fluid's pre-yield stiffness in its loop: from the
    data's starts one of the baseline's six fits found the valley where the gas spring carries
    that stiffness (held-out error 4.0 % of the range), and with the force x (1 + 1e-9) none
    (6.3 %, every verdict after it another). A start from the loop's stiffness lands there
    both ways."""
    from models.diagnose import _fit_baseline, holdout_masks
    from models.diagnose.candidates import WITH_BASELINE, Minimal
    from models.diagnose.data import prepare
    from records import source_filter
    from records.reader import load_recording
    errors = []
    for k, gain in enumerate(([], ["--gain", f"force={1 + 1e-9!r}"])):
        rec = tmp_path / f"{k}.mcap"
        assert dyno("import", SINE / "2mm5Hz1A.txt", "--out", rec, *MAP, *gain).returncode == 0
        ch, events, meta = load_recording(rec)
        d = prepare(ch, events, None, source_filter.of(meta))
        folds, _, shown = holdout_masks(d)
        errors.append(_fit_baseline(d, Minimal(d), list(WITH_BASELINE), folds, shown)[0].nrmse_heldout)
    assert max(errors) < 0.045 and abs(errors[1] - errors[0]) < 1e-3, errors


def test_repeats_diagnose_perturbed_copies_and_count_what_each_named(tmp_path):
    """`dyno diagnose --repeats N`: N diagnoses, the recording's and N - 1 copies with the force
    rescaled by 1 +- k 1e-9; how often each effect was named or at the edge, in the JSON and
    in words. A count outside 1..50 is one line, exit 2."""
    from models.diagnose import diagnose, repeated
    from models.diagnose.words import repeats_text
    from tests.test_diagnose import _sines_run
    run = _sines_run(lambda t, x, v, F, f, T: F + 3.0 * np.gradient(v, t))  # 3 kg of fluid inertia, named
    first = diagnose(*run, max_effects=1)
    again = repeated(first, *run, 3, max_effects=1)
    assert again["n"] == 3 and again["named"] and set(again["named"]) >= set(first.named() + first.at_edge())
    for e in again["named"]:
        assert 0.0 <= again["named"][e] + again["at_edge"][e] <= 1.0
    text = repeats_text(again)
    assert text.startswith("Diagnosed 3 times (this recording and 2 copies with the force x (1 +- k 1e-9)"), text
    assert text.count(" of 3, at the edge in ") == len(again["named"]) and text.endswith(".")
    assert repeats_text({"n": 2, "named": {}, "at_edge": {}}).endswith("1 copy with the force x (1 +- k 1e-9) and "
                                                                        "other draws): nothing named or at the edge.")
    for bad in ("0", "51", "x"):
        p = subprocess.run([DYNO, "diagnose", str(tmp_path / "none.mcap"), "--repeats", bad], capture_output=True,
                           text=True)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "--repeats" in p.stderr, p.stderr
