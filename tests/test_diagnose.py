"""Missing-physics diagnosis against recordings of the plain virtual rig (through the wire
protocols), with and without a hidden effect."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from records.events import SegmentEnd, SegmentStart
from models.diagnose.candidates import EFFECTS

from models.diagnose.valves import _direction
from models.diagnose import diagnose
from models.diagnose.data import DiagnoseError, prepare
from models.diagnose.words import summary
from records.reader import load_recording
from tests.conftest import recorded

# their verdicts must not be one processor's last bits: run again under another kernel (Makefile)

DYNO = [sys.executable, "-m", "commands.cli"]


# one worker makes the three recordings once for every test that reads them
ONE_WORKER = pytest.mark.xdist_group("diagnose_recordings")


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """The matrix on the plain cell, through the run API (the diagnosis reads a recording, not the wires)."""
    tmp = tmp_path_factory.mktemp("diag")
    matrix = {"amplitudes_mm": [12.7, 3.2], "freqs_hz": [1.0, 4.0, 16.0], "settle_cycles": 1}
    return {name: recorded(tmp / f"{name}.mcap", "sine-matrix", matrix, effects=fx, plain=True)[0]
            for name, fx in [("null", ()), ("lag", ["sensor_delay=0.001"]),
                             ("inertia", ["fluid_inertia=2", "sensor_delay=0.0002"])]}


def test_two_stage_valve_curve_solves_eq_3_30():
    """v = v_L(F) + v_M(F) holds for the closed-form force."""
    c1, c2, C, Fcr = 3000.0, 2e5, 1700.0, 770.0
    v = np.linspace(0, 1.5, 200)
    F = _direction(v, c1, c2, C, Fcr)
    vL = (-c1 + np.sqrt(c1 ** 2 + 4 * c2 * F)) / (2 * c2)
    vM = np.maximum(F - Fcr, 0) / C
    assert np.allclose(vL + vM, v, atol=1e-9)


@pytest.mark.rounding
@ONE_WORKER
def test_null_recording_names_no_physics(recordings):
    res = diagnose(*load_recording(recordings["null"])[:2])
    # the plant's force and motion agree to first order (sim_backend/plant/sensors.py): what
    # is left of their alignment (about 20 us) is fitted with the baseline, never a round's
    # finding, and said as under one sample
    assert [e for e in res.accepted if EFFECTS[e].nature in ("physics", "open")] == []
    assert "sensor_delay" not in res.accepted and res.cell_found() == ["alignment"]
    assert 5e-6 < abs(res.baseline.cell[0].parameters["tau_0"]) < 50e-6
    assert "Timing (the channels' alignment, fitted with the baseline" in summary(res) and "Align" not in summary(res)
    assert res.baseline.nrmse_heldout < 0.005


@pytest.mark.rounding
@ONE_WORKER
def test_a_hidden_lag_is_found_and_sized(recordings):
    res = diagnose(*load_recording(recordings["lag"])[:2])
    assert res.accepted[0] == "sensor_delay"
    # a first-order filter of 1 ms delays a sine by about 1 ms at these frequencies
    # the force leads the filtered displacement (tau > 0); a 1 ms first-order filter reads as
    # about 0.5 ms of pure delay here (not understood yet: see the issue 7 note)
    assert 0.3e-3 < res.steps[0].parameters["tau"] < 1.3e-3


@ONE_WORKER
def test_two_hidden_effects_found_larger_first(recordings):
    # on this matrix the inertia adds 27.9 N RMS to the force, the 0.2 ms lag 14.7 N (offline plant)
    res = diagnose(*load_recording(recordings["inertia"])[:2])
    assert res.accepted[:2] == ["fluid_inertia", "sensor_delay"]


@pytest.mark.rounding
@ONE_WORKER
def test_the_screen_rules_out_only_what_no_judgement_would_accept(recordings):
    """Issue 90: each candidate fitted in full beside its screen (screening=False) on a null
    and on two hidden effects: none the screen rules out gains, fitted, what a judgement's
    acceptance needs; as `dyno diagnose` runs, those are not fitted and the diagnosis says
    what the full search says."""
    from models.diagnose import screen
    from models.diagnose.referees import RELEVANCE
    from models.diagnose.stability import BAND
    for name in ("null", "inertia"):
        ch, ev = load_recording(recordings[name])[:2]
        full, quick = diagnose(ch, ev, screening=False), diagnose(ch, ev)
        ruled = {(c.round, c.effect) for c in full.candidates if c.screen < screen.BAR}
        assert all(c.relevance < RELEVANCE / BAND for c in full.candidates if (c.round, c.effect) in ruled)
        not_fitted = {(c.round, c.effect) for c in quick.candidates if c.screened}
        assert not_fitted and not_fitted <= ruled
        assert (quick.accepted, quick.named(), quick.at_edge()) == (full.accepted, full.named(), full.at_edge())
        assert quick.final.nrmse_heldout == pytest.approx(full.final.nrmse_heldout, rel=1e-9)
        if name == "null":  # its one round: most nonlinear fits are not made
            nonlinear = [c for c in quick.candidates if not EFFECTS[c.effect.split(":")[0]].linear]
            assert sum(c.screened for c in nonlinear) >= 2 / 3 * len(nonlinear)


@pytest.mark.rounding
def test_a_candidate_acting_through_a_part_held_at_zero_is_fitted_not_screened(tmp_path):
    """A real MR file (UTFSM, 25 mm 0.5 Hz 1 A) whose baseline leaves the sliding friction at
    zero: a pre-sliding friction adds nothing to it, so its linear step gains nothing (2e-15
    noise variances), yet fitted in full, with the friction raised beside it, it gains 0.61
    and is significant. The screen leaves such a candidate to the full fit (screen.INERT)."""
    src = Path(__file__).parent / "data" / "mr-damper-utfsm" / "sine" / "25mm0x5Hz1A.txt"
    rec = tmp_path / "x.mcap"
    r = subprocess.run([*DYNO, "import", str(src), "--out", str(rec), "--map", "time=1:s", "--map",
                        "displacement=2:mm", "--map", "velocity=3:mm/s", "--map", "force=4:N", "--smoothed",
                        "0.1period"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([*DYNO, "diagnose", str(rec), "--json"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["baseline"]["parameters"]["F_c"] < 1e-6
    first = {c["effect"]: c for c in doc["candidates"] if c["round"] == 1}
    assert not first["presliding_friction"]["screened"] and first["presliding_friction"]["gain_noise_variances"] > 0.3
    assert any(c["screened"] for c in doc["candidates"])  # later rounds do rule some out


@ONE_WORKER
def test_cli_json_and_summary(recordings, tmp_path):
    r = subprocess.run([*DYNO, "diagnose", str(recordings["lag"]), "--json", "--report", str(tmp_path / "rep"),
                        "--next", "--budget", "60"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert set(doc) >= {"baseline", "locations", "candidates", "accepted", "final"}
    assert doc["accepted"][0] == "sensor_delay" and doc["final"]["nrmse_heldout"] < doc["baseline"]["nrmse_heldout"]
    assert "In the cell, not the damper: a timing offset of the cell." in doc["summary"]
    assert "displacement reading lags the force by" in doc["summary"]
    lag = doc["effects"][0]
    assert lag["nature"] == "cell" and lag["depends_on"] == ["time"] and lag["size_rms_n"] > 0
    assert (tmp_path / "rep" / "index.html").exists() and (tmp_path / "rep" / "residuals.png").exists()
    # the next test: within the budget, each proposal with why and the line that records it
    assert doc["next"] and sum(p["rig_s"] for p in doc["next"]) <= 60
    # a 1 ms lag against an oil mass (with the channels' alignment the lag took over): fast sines part them
    # (against the noise read from one fold's model, 1.5 N, frequency-dependent damping is a rival too)
    assert doc["next"][0]["other"][:2] == ["alignment", "fluid_inertia"]
    assert all(p["command"].startswith("dyno run sine-matrix ") and p["why"] for p in doc["next"])
    # the run index keeps what the diagnosis found (dyno runs show)
    from views import run_index
    with run_index.beside(recordings["lag"]) as c:
        run_id = c.execute("SELECT id FROM runs WHERE path = ?", (str(recordings["lag"].resolve()),)).fetchone()["id"]
        kept = run_index.attached(c, "diagnoses", run_id)[-1]
    assert json.loads(kept["accepted"]) == doc["accepted"] and kept["baseline"] == "minimal"
    assert json.loads(kept["findings"])[0]["effect"] == "sensor_delay" and "tau" in json.loads(kept["findings"])[0]["parameters"]


@ONE_WORKER
def test_gaps_missing_temperature_and_too_short(recordings):
    ch, ev, _ = load_recording(recordings["null"])
    del ch["T_body"], ch["T_reservoir"]
    t, F = ch["force"]
    k = (t < 10.0) | (t > 10.3)  # a dropout of 0.3 s in the force
    ch["force"] = (t[k], F[k])
    res = diagnose(ch, ev)
    notes = " ".join(res.data.notes)
    assert "gap" in notes and "no temperature channel" in notes
    assert not {"gas_temperature", "damping_temperature"} & {c.effect for c in res.candidates}
    short = {n: (t[t < 1.5], v[t < 1.5]) for n, (t, v) in ch.items()}
    with pytest.raises(DiagnoseError, match="to judge"):
        prepare(short, [e for e in ev if e.t < 1.5])


@ONE_WORKER
def test_a_one_sample_spike_costs_its_samples_not_the_cycle(recordings):
    """A wired cell's actuator jerks at a late setpoint: a one-sample inertial spike in the
    force every 0.7 s. Each costs the samples around it; the 1 Hz cycles all stay whole."""
    ch, ev, _ = load_recording(recordings["null"])
    clean = prepare(ch, ev)
    t, F = ch["force"]
    F = F.copy()
    at = np.searchsorted(t, np.arange(t[0] + 0.35, t[-1], 0.7))
    F[at] -= 1000.0
    ch["force"] = (t, F)
    d = prepare(ch, ev)
    one_hz = [k for k, (_, f) in enumerate(d.segments) if f == 1.0]
    assert one_hz and len(d.t) < len(clean.t)
    for k in one_hz:
        assert len(np.unique(d.cycle[d.segment == k])) == len(np.unique(clean.cycle[clean.segment == k]))
    for i in at:  # no sample within 10 ms of a spike is judged
        assert not np.any(np.abs(d.t - t[i]) < 0.01)


@ONE_WORKER
def test_a_damper_model_as_baseline(recordings):
    """--baseline PRESET: the plain cell's own damper model, simulated along the motion and
    refitted, leaves nothing on the null and finds the hidden inertia first."""
    from models.damper import load as load_damper
    res = diagnose(*load_recording(recordings["null"])[:2], baseline=("koni-plain", load_damper("koni-plain")))
    assert [e for e in res.accepted if EFFECTS[e].nature in ("physics", "open")] == []
    assert res.baseline.name == "koni-plain"
    assert res.baseline.nrmse_heldout < 0.001  # within the noise: it is the rig's own damper
    assert abs(res.baseline.parameters["k_damping"] - 1.0) < 0.02
    res = diagnose(*load_recording(recordings["inertia"])[:2], baseline=("koni-plain", load_damper("koni-plain")))
    assert res.accepted[0] == "fluid_inertia"


@pytest.mark.parametrize("baseline, message", [("nosuch", "unknown damper preset"),
                                               ("simplified-I", "simplified model")])
@ONE_WORKER
def test_cli_refuses_a_baseline_it_cannot_use(recordings, baseline, message):
    r = subprocess.run([*DYNO, "diagnose", str(recordings["null"]), "--baseline", baseline],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and message in r.stderr and "Traceback" not in r.stderr


def test_cli_refuses_a_recording_without_force(tmp_path):
    r = subprocess.run([*DYNO, "diagnose", str(tmp_path / "none.mcap")], capture_output=True, text=True)
    assert r.returncode != 0 and "no such file" in r.stderr and "Traceback" not in r.stderr


def test_prove_finds_a_concealed_effect_and_nothing_on_a_null(prove_keep):
    """dyno prove in CI with one seed and two rows (the full proof: docs/results/prove.md)."""
    # free play: the effect hardest to see (one process: the suite's other worker has the other core)
    r = subprocess.run([*DYNO, "prove", "--seeds", "1", "--effects", "free_play,null", "--jobs", "1",
                        "--keep", prove_keep, "--json"], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    rows = {row["effect"]: row for row in json.loads(r.stdout)["effects"]}
    assert rows["null"]["false_positive"] == 0.0
    assert rows["free_play"]["detection"] == 1.0
    # concealed: what the effect adds to the force is no more than the sensor noise (1.5 N)
    assert rows["free_play"]["contribution_rms"] <= 1.6


def test_prove_open_hides_a_users_force_law_and_names_it(prove_keep):
    """dyno prove --open: 3 N of 50 Hz written by the user, hidden in the plain cell through
    the wires, is named as the cell's interference, and the null of the same seed claims
    no physics."""
    r = subprocess.run([*DYNO, "prove", "--open", "3*sin(2*pi*50*t)", "--seeds", "1", "--jobs", "1",
                        "--keep", prove_keep, "--json"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    run = json.loads(r.stdout)["runs"][0]
    assert 1.8 < run["contribution_rms"] < 2.4 and run["null_claims"] == []
    assert [f["effect"] for f in run["found"]][:1] == ["interference"] and run["explained"] > 0.6


def test_force_is_taken_at_its_own_stamps_when_a_segment_starts_between_them():
    """A plan's segment times fall between ticks: the diagnosis's time base is still the
    force's own stamps and its force the raw samples (not the mean of two across a valve's
    knee, hundreds of newtons apart at 12 Hz)."""
    t = np.arange(0.0, 3.0, 1e-3)
    x = 0.04 + 0.01 * np.sin(2 * np.pi * 12 * t)
    v = 0.01 * 2 * np.pi * 12 * np.cos(2 * np.pi * 12 * t)
    F = 3000.0 * v + 700.0 * np.tanh(v / 0.02) + np.random.default_rng(0).normal(0.0, 1.5, len(t))
    t0 = 0.50037  # between two samples
    t1 = t0 + 24 / 12
    ev = [SegmentStart(t0, "sine 10 mm 12 Hz", {"kind": "sine", "freq_hz": 12.0}), SegmentEnd(t1, "sine 10 mm 12 Hz")]
    d = prepare({"force": (t, F), "x": (t, x)}, ev)
    i = np.round(d.t / 1e-3).astype(int)
    assert np.allclose(d.t, t[i], atol=1e-9) and np.allclose(d.F, F[i], rtol=0, atol=1e-6)
    assert d.t[0] >= t0 and d.t[-1] < t1


def test_a_fold_stuck_in_a_local_minimum_restarts_from_the_other_folds_values():
    """A fold whose fit stopped at its step limit far off (here: begun from a valve without
    its quadratic term, with too little effort to leave it) is fitted again from the values
    of a fold that converged, and keeps the better fit of its own training cycles; with
    both folds stopped there is no converged one to start from, and restart=True fits each
    again from the other's whatever."""
    from types import SimpleNamespace
    from models.diagnose import holdout_masks
    from models.diagnose.candidates import Minimal, Model
    from models.diagnose.design import Sine, motion
    from models.diagnose.fitting import cross_fit
    d = motion(Sine(0.01, 2.0, 0.038), SimpleNamespace(T=None, aux={}))
    truth = {"c1_c": 3000.0, "c2_c": 2e5, "C_c": 1700.0, "Fcr_c": 770.0, "c1_r": 6900.0, "c2_r": 2.8e5,
             "C_r": 4700.0, "Fcr_r": 1060.0, "G0": 430.0, "L": 0.28, "F_c": 70.0}
    d.F = Model(d, base=Minimal(d)).force(d, truth) + np.random.default_rng(0).normal(0.0, 1.5, len(d.t))
    m = Model(d, base=Minimal(d))
    folds = holdout_masks(d)[0]
    # (fitted in each parameter's own units, a low-speed path 3x too stiff is left within 11
    # evaluations now: one 30x too stiff with a soft mid valve is not)
    stuck = {**truth, "c1_r": 2e5, "c2_r": 0.0, "F_c": 3.0, "C_r": 200.0}
    rms = lambda v, k: float(np.sqrt(np.mean((m.force(d, v) - d.F)[k] ** 2)))
    both, _, _ = cross_fit(m, d, folds, [stuck, stuck], effort=1, stopped=(limits := []))
    assert limits == [True, True] and min(rms(v, k) for v, (k, _) in zip(both, folds)) > 10.0
    for restart in (False, True):
        again, _, r = cross_fit(m, d, folds, [truth, stuck], effort=1, restart=restart)
        assert rms(again[1], folds[1][0]) < 2.0 and np.sqrt(np.mean(r[folds[1][1]] ** 2)) < 2.0


def test_rivals_are_the_candidates_the_held_out_blocks_cannot_tell_from_the_winner():
    """A paired test block by block: a candidate whose held-out error is the winner's, give or
    take noise, is its rival in each judgement in which it was accepted, and in no other; one
    clearly worse is not; another form of the same effect is the same physics. The sentence
    names the group and tells no mechanism's story."""
    from models.diagnose.referees import rivals
    from models.diagnose.result import Candidate, Step, Tried
    from models.diagnose.stability import Judge, Variant
    from models.diagnose.words import rivals_sentence
    rng = np.random.default_rng(0)
    block = np.repeat(np.arange(40), 50)
    judged, ids = np.ones(len(block), bool), np.arange(40)
    r_best = rng.normal(0, 10.0, len(block))

    def cand(effect, r, accepted=(1.0, 1.0, 1.0)):
        c = Candidate(effect, 1, {}, {}, 0.01, 10.0, 0.99, 1e-4, 50.0, 2.0)
        c.accept_votes = np.array(accepted)
        return Tried(c, {}, [], r)
    alike = cand("presliding_friction", r_best * (1 + rng.normal(0, 0.02, len(block))))
    worse = cand("compressibility", r_best * 1.5)
    own_form = cand("bouc_wen:aux.current", r_best)
    once = cand("cavitation", r_best * (1 + rng.normal(0, 0.02, len(block))), accepted=(0.0, 1.0, 0.0))
    never = cand("fluid_inertia", r_best, accepted=(0.0, 0.0, 0.0))
    best = Candidate("bouc_wen", 1, {}, {}, 0.01, 10.0, 0.99, 1e-4, 60.0, 2.4)
    best.accept_votes = np.ones(3)
    judge = Judge(judged, [Variant(block, ids, s) for s in (1, 2, 3)])
    found, votes = rivals(best, r_best, [alike, worse, own_form, once, never], judge)
    assert [e for e, _, _ in found] == ["presliding_friction"] and found[0][2] >= 0.01
    assert votes["presliding_friction"].tolist() == [1.0] * 3 and votes["compressibility"].tolist() == [0.0] * 3
    assert votes["cavitation"].tolist() == [0.0, 1.0, 0.0] and "fluid_inertia" not in votes
    best.accept_votes = np.array([1.0, 0.5, 0.0])  # a winner at the edge of its own acceptance
    assert rivals(best, r_best, [alike], judge)[1]["presliding_friction"].tolist() == [1.0, 0.5, 0.0]
    step = Step("bouc_wen", 0.03, 0.02, {}, {}, 1e-4, r_best, r_best, [], [], [], rivals=found,
                depends_on=["displacement", "direction"], character="elastic", region="both directions",
                size_rms_n=80.0, size_peak_n=200.0)
    text = rivals_sentence(step)
    assert text.startswith("The recording cannot tell which physics was left out: hysteresis")
    assert "pre-sliding friction" in text and "magnetorheological" not in text and "--next" in text


def test_a_significant_gain_below_the_practical_size_is_kept_but_not_named():
    """Issue 44's null: a Bouc-Wen element took 16 % of the held-out error above the noise
    (19.8 to 18.9 N against 13.4 N of noise) and was told as an MR fluid. Below NAMED_SHARE
    it is said as small, with its size, and not among the names; the cell's timing is never
    held to it."""
    from models.diagnose import NAMED_SHARE, _sized
    from models.diagnose.result import Step
    from models.diagnose.words import small_sentence
    sigma, excess = 13.4, 19.8 ** 2 - 13.4 ** 2

    def steps(*pairs):  # (effect, gain in noise variances) in the order accepted
        out = [Step(e, 0.0, 0.0, {}, {}, 1e-4, np.zeros(3), np.zeros(3), [], [], [], relevance=g) for e, g in pairs]
        _sized(out, excess, sigma)
        return out
    bw, = steps(("bouc_wen", (19.8 ** 2 - 18.9 ** 2) / sigma ** 2))  # 16 % of the excess
    assert bw.small and abs(bw.excess_share - 0.16) < 0.01
    bw, = steps(("bouc_wen", 1.1 * NAMED_SHARE * excess / sigma ** 2))
    assert not bw.small
    # the cell's own timing took most of the excess: the physics is sized against what is left
    lag, fp = steps(("sensor_delay", 0.9 * excess / sigma ** 2), ("free_play", 0.05 * excess / sigma ** 2))
    assert not lag.small and not fp.small and abs(fp.excess_share - 0.5) < 0.01
    step = Step("bouc_wen", 0.021, 0.020, {}, {}, 1e-4, np.zeros(3), np.zeros(3), [], [], [], relevance=0.19,
                excess_share=0.16, small=True, size_rms_n=5.6)
    text = small_sentence(step, 1200.0)
    assert text.startswith("Small, not named: a misfit that hysteresis (Bouc-Wen) takes up, 5.6 N RMS, 0.47 %")
    assert "16 % of the held-out error above the noise" in text and "magnetorheological" not in text


def _crank_run(extra, seconds=40.0, rate=300.0, hz=1.05, seed=0):
    """A crank dyno's one stroke (300 Hz, the issue's student dyno): channels and events of a
    damper with valves, gas and friction, plus extra(t, x, v, F) [N], with 3 N of noise."""
    t = np.arange(int(seconds * rate)) / rate
    th = 2 * np.pi * hz * t
    x = 0.03 + 0.019 * (1 - np.cos(th)) + (0.019 ** 2 / 0.24) * np.sin(th) ** 2
    v = np.gradient(x, t)
    F = 150 + 800 * x + np.where(v > 0, 2500 * v, 4200 * v) + 30 * np.tanh(v / 0.01)
    F = extra(t, x, v, F) + np.random.default_rng(seed).normal(0.0, 3.0, len(t))
    return {"force": (t, F), "x": (t, x)}, [
        SegmentStart(0.0, "crank", {"kind": "sine", "freq_hz": hz}), SegmentEnd(t[-1] + 1e-9, "crank")]


def _spot(t, x, v, F):
    """Friction in a band of the bore."""
    return F + 30.0 * np.exp(-((x - 0.045) / 0.012) ** 2) * np.tanh(v / 0.01)


@pytest.fixture(scope="module")
def spot_diagnosis():
    return diagnose(*_crank_run(_spot))


@pytest.mark.xdist_group("spot")  # one worker computes the fixture
def test_one_stroke_cannot_tell_a_mechanism_of_the_loop_from_a_flexible_stand_in(spot_diagnosis):
    """Friction in a band of the bore, on one crank stroke: position friction is accepted,
    but a smooth surface in displacement, speed and direction with no mechanism in it
    explains as much, so the dependence and its size are said and no mechanism named."""
    res = spot_diagnosis
    step = res.steps[0]
    assert step.effect == "position_friction" and step.stand_in and step.stand_in[0] == "loop_surface"
    assert res.named() == [] and res.final.nrmse_heldout < 0.7 * res.baseline.nrmse_heldout
    text = summary(res)
    assert "Not named: the force depends on displacement, direction beyond the baseline" in text
    assert "Left out" not in text


@pytest.mark.xdist_group("spot")
def test_a_round_fitted_in_two_processes_gives_what_one_gives(spot_diagnosis):
    """diagnose(jobs=2): each round's candidates are fitted in forked children, the costliest
    first; the verdicts and values are those of one process."""
    one, two = spot_diagnosis, diagnose(*_crank_run(_spot), jobs=2)
    assert [(c.effect, c.p_value, c.gain) for c in one.candidates] == [(c.effect, c.p_value, c.gain)
                                                                       for c in two.candidates]
    assert one.accepted == two.accepted and one.final.parameters == two.final.parameters


def _sines_run(extra, freqs=(1.0, 3.0, 9.0), v_peak=0.3, cycles=8, rate=1000.0, seed=0):
    """Sine segments of one peak speed (so every frequency covers the same velocities):
    channels (force, x, and T rising 1 K/s) and events of a damper with valves, gas and
    friction, plus extra(t, x, v, F, f, T) [N], with 1.5 N of noise."""
    ts, xs, vs, fs, events, t0 = [], [], [], [], [], 0.0
    for f in freqs:
        t = t0 + np.arange(int(cycles / f * rate)) / rate
        A = v_peak / (2 * np.pi * f)
        xs.append(0.04 + A * np.sin(2 * np.pi * f * (t - t0)))
        vs.append(v_peak * np.cos(2 * np.pi * f * (t - t0)))
        ts.append(t), fs.append(np.full(len(t), f))
        events += [SegmentStart(t0, f"sine {f:g} Hz", {"kind": "sine", "freq_hz": f}),
                   SegmentEnd(t[-1] + 1e-9, f"sine {f:g} Hz")]
        t0 = t[-1] + 1.0 / rate
    t, x, v, f = (np.concatenate(a) for a in (ts, xs, vs, fs))
    T = 300.0 + t
    F = 150 + 800 * x + np.where(v > 0, 2500 * v, 4200 * v) + 30 * np.tanh(v / 0.01)
    F = extra(t, x, v, F, f, T) + np.random.default_rng(seed).normal(0.0, 1.5, len(t))
    return {"force": (t, F), "x": (t, x), "T_body": (t, T)}, events


def test_damping_that_changes_with_the_test_frequency_is_said_as_that_dependence():
    """Damping 10 % higher at each tripling of the frequency, at the same speeds: outside
    the catalogue, said as the dependence on frequency, not as a valve form or physics."""
    res = diagnose(*_sines_run(lambda t, x, v, F, f, T: F + 0.1 * np.log(f / 3.0) * np.where(v > 0, 2500 * v, 4200 * v)))
    step = res.steps[0]
    assert step.effect == "frequency_damping" and not step.stand_in and not step.small, summary(res)
    assert "frequency" in step.depends_on
    assert "damping that changes with the test frequency at the same velocity" in summary(res)


def test_a_temperature_effect_the_time_explains_as_well_is_not_named():
    """A reservoir's gas force, flat along the stroke, growing with a temperature
    that only rises: a drift in time, with no mechanism in it, explains it as well, so the
    time dependence is said and gas heating is not named."""
    res = diagnose(*_sines_run(lambda t, x, v, F, f, T: F - 800 * x + 1.5 * (T - 300.0)))
    text = summary(res)
    assert "gas_temperature" not in res.named() and "charge is heating" not in text, text
    gas = [s for s in res.steps if s.effect == "gas_temperature"]
    if gas:  # it took a round: the drift stood in for it
        assert gas[0].stand_in[0] == "drift" and "or on time" in text, text
    else:
        assert res.steps[0].effect == "drift" and "a slow offset in time" in text, text


@pytest.mark.rounding
def test_a_rival_group_on_a_recording_made_for_it():
    """The force channel read 2 ms late on one crank stroke: compressibility and the cell's
    timing explain the same misfit about equally and the answer names them as a group."""
    late = (lambda t, x, v, F: np.interp(t - 0.002, t, F))
    res = diagnose(*_crank_run(late))
    group = {res.steps[0].effect} | {e for e, _, _ in res.steps[0].rivals}
    assert {"sensor_delay", "compressibility"} <= group and res.named() == []
    assert "a timing offset of the cell" in summary(res) and "Left out" not in summary(res)


def test_a_lag_under_one_sample_is_unresolved_and_never_asks_to_realign():
    from models.diagnose.result import Step
    from models.diagnose.words import sentence

    def said(tau, sample_s):
        step = Step("sensor_delay", 0.0249, 0.0193, {"tau": tau}, {"tau": [0.8 * tau, 1.2 * tau]}, 1e-4,
                    np.zeros(3), np.zeros(3), [], [], [])
        return sentence(step, sample_s)
    small = said(1.6e-5, 1e-3)  # a sixtieth of a 1 kHz sample
    assert "below one sample, unresolved" in small and "Align" not in small and "0.016 ms" in small
    assert "Align the channels" in said(2e-4, 1e-4)  # two samples: a real offset


def test_a_finding_whose_rivals_depend_on_other_variables_says_either():
    """A zero drifting in time over a matrix whose amplitudes rise with it: hysteresis, an
    elastic force along the stroke and a drift explain it about equally. The dependence
    said is the group's, displacement or time, never displacement alone. A group with the
    valve curve's form says that the form may be no physics left out at all. The cell's
    timing carried in a group says its rivals' variables: a lag depends on the motion, not on
    the time elapsed."""
    from models.diagnose.result import Step
    from models.diagnose.words import rivals_sentence, stand_in_sentence
    step = Step("bouc_wen", 0.0128, 0.012, {}, {}, 3e-5, np.zeros(3), np.zeros(3), [], [], [],
                rivals=[("elastic_stroke", 0.27, 0.4), ("drift", 0.23, 0.3)], stand_in=("loop_surface", 1.0),
                nature="physics", depends_on=["displacement", "direction"], size_rms_n=0.63, size_peak_n=2.0)
    assert "the force depends on displacement, direction, or on time beyond the baseline" in \
        stand_in_sentence(step, 1e4)
    assert "it depends on displacement, direction, or on time;" in rivals_sentence(step)
    alone = Step("bouc_wen", 0.0128, 0.012, {}, {}, 3e-5, np.zeros(3), np.zeros(3), [], [], [],
                 rivals=[("presliding_friction", 0.2, 0.4)], stand_in=("loop_surface", 1.0), nature="physics",
                 depends_on=["displacement", "direction"], size_rms_n=0.63, size_peak_n=2.0)
    assert "depends on displacement, direction beyond the baseline" in stand_in_sentence(alone, 1e4)
    assert "may be no physics" not in rivals_sentence(step)
    stribeck = Step("breakaway_friction", 0.0212, 0.0196, {}, {}, 3e-5, np.zeros(3), np.zeros(3), [], [], [],
                    rivals=[("valve_form", 0.5, 0.98)], nature="physics", depends_on=["velocity", "direction"],
                    size_rms_n=0.69, size_peak_n=5.3)
    assert "the valve curve's form is the baseline's own law reshaped, so it may be no physics left out at all" \
        in rivals_sentence(stribeck)
    lag = Step("sensor_delay", 0.024, 0.0056, {"tau": 1e-3}, {}, 3e-5, np.zeros(3), np.zeros(3), [], [], [],
               rivals=[("presliding_friction", 20.0, 0.4)], stand_in=("loop_surface", 1.0), nature="cell",
               depends_on=["time"], size_rms_n=71.1, size_peak_n=200.0)
    assert "Not named: the force depends on displacement, direction beyond the baseline" in stand_in_sentence(lag, 3e3)
    assert "it depends on displacement, direction;" in rivals_sentence(lag)


def test_the_recorded_dampers_own_compressibility_is_not_said_as_left_out(tmp_path):
    """The embedded Koni has compressible oil by design. By default the baseline is the
    damper the recording names, refitted: its compressibility is in the model from the
    start. The minimal baseline leaves it out, and the diagnosis says it is the damper's own
    physics, with no repair advice."""
    out, _ = recorded(tmp_path / "koni.mcap", "sine-matrix",
                      {"amplitudes_mm": [12.7], "freqs_hz": [1.0, 4.0], "record_cycles": 3})
    r = subprocess.run([*DYNO, "diagnose", str(out), "--json"], capture_output=True, text=True, timeout=600)
    doc = json.loads(r.stdout)
    assert doc["baseline"]["name"] == "koni" and "compressibility" not in doc["accepted"], doc["accepted"]
    assert "Bleed the damper" not in doc["summary"]
    r = subprocess.run([*DYNO, "diagnose", str(out), "--baseline", "minimal", "--json"], capture_output=True,
                       text=True, timeout=600)
    doc = json.loads(r.stdout)
    own = [e for e in doc["effects"] if e["effect"] == "compressibility"]
    assert own and own[0]["in_own_description"] == "koni", doc["accepted"]
    assert "In koni's own description, not a fault: compressibility" in doc["summary"]
    assert "Bleed the damper" not in doc["summary"]


def _motion_with_every_channel():
    """Data of two sine frequencies with a temperature, an aux channel and a tone: every
    effect of the catalogue and every term can act on it."""
    t = np.arange(0.0, 4.0, 1e-3)
    f = np.where(t < 2.0, 3.0, 7.0)
    x = 0.04 + 0.01 * np.sin(2 * np.pi * f * t)
    v = 0.01 * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
    F = 3000.0 * v + 700.0 * np.tanh(v / 0.02) + 200.0 + np.random.default_rng(0).normal(0.0, 1.5, len(t))
    ev = [SegmentStart(0.0, "sine 3 Hz", {"kind": "sine", "freq_hz": 3.0}), SegmentEnd(2.0, "sine 3 Hz"),
          SegmentStart(2.0, "sine 7 Hz", {"kind": "sine", "freq_hz": 7.0}), SegmentEnd(3.999, "sine 7 Hz")]
    d = prepare({"force": (t, F), "x": (t, x), "T_body": (t, 300.0 + 5.0 * t),
                 "aux.valve_current": (t, 0.5 + 0.1 * np.sin(0.7 * t))}, ev)
    d.tone_hz = 50.0
    return d


# where each effect's derivative is checked: a clearance, an oil spring and a cap that act
# (the defaults leave them at nothing), and valves that crack within the motion
AT = {"c1_c": 3000.0, "c2_c": 2e5, "C_c": 1700.0, "Fcr_c": 770.0, "c1_r": 6900.0, "c2_r": 2.8e5, "C_r": 4700.0,
      "Fcr_r": 1060.0, "G0": 430.0, "L": 0.05, "F_c": 70.0, "inv_k_oil": 1e-7, "c_play": 2e-4, "Fcav_c": 400.0,
      "Fcav_r": 500.0, "kcav": 2.0, "r_break": 2.0, "v_break": 0.02, "x_stick": 2e-4}


@pytest.mark.rounding
@pytest.mark.parametrize("effect", [e for e in EFFECTS if EFFECTS[e].acts_on != "motion"])
def test_each_effects_derivatives_are_its_differences_beside_every_other(effect):
    """Model.columns: the baseline's derivatives carried through each effect by its
    tangent, with the effect's own added, which the fits read instead of a model
    evaluation per parameter. Each effect alone and beside those that change the whole
    force after it (an oil spring, a clearance, a cap): every column a central difference
    of the force; only a timing's and a shape's parameters are left to differences."""
    from models.diagnose.candidates import ORDER, WITH_BASELINE, Model
    d = _motion_with_every_channel()
    rng = np.random.default_rng(1)
    e = effect + (":aux.valve_current" if EFFECTS[effect].needs == "aux" else "")
    left = {"tau_0", "x_y", "gamma_bw", "lag:aux.valve_current"}  # a timing's, a yield's shape
    for beside in ([], ["compressibility"], ["free_play"], ["cavitation"]):
        effects = sorted({e, *beside}, key=lambda x: ORDER.index(x.split(":")[0]))
        m = Model(d, WITH_BASELINE + effects)
        p = {q.name: AT.get(q.name, q.x0 + (rng.uniform(0.05, 0.3) * (q.hi - q.lo) if q.x0 == 0.0 else 0.0))
             for q in m.params}
        f0 = m.forces(d, p)
        cols = m.columns(f0)
        assert set(cols) == {q.name for q in m.params} - left, (effects, {q.name for q in m.params} - set(cols))
        scale = np.max(np.abs(f0.F))
        for q in m.params:
            if q.name not in cols:
                continue
            h = 1e-6 * max(abs(p[q.name]), 1e-3 * (q.hi - q.lo))
            diff = (m.force(d, {**p, q.name: p[q.name] + h}) - m.force(d, {**p, q.name: p[q.name] - h})) / (2 * h)
            # a difference's rounding (eps |F| / h, with room) and a tenth-mille of its size (kinks)
            atol = 1e-12 * scale / h + 1e-4 * np.max(np.abs(diff))
            assert np.allclose(cols[q.name], diff, rtol=1e-4, atol=atol), \
                (effects, q.name, float(np.max(np.abs(cols[q.name] - diff))), float(np.max(np.abs(diff))))


def test_the_spline_basis_is_scipys_to_the_last_bit():
    """terms.bspline's compiled de Boor recursion gives scipy's design matrix exactly, knots
    and ends included: a basis that differed in its last digits would move fits that
    stop in flat valleys, and so the diagnosis's answers."""
    from scipy.interpolate import BSpline

    from models.diagnose.terms import DEGREE, bspline
    rng = np.random.default_rng(0)
    for _ in range(100):
        n = int(rng.integers(DEGREE + 1, 12))
        lo = float(rng.normal())
        hi = lo + float(rng.uniform(1e-3, 5.0))
        u = np.r_[rng.uniform(lo - 1.0, hi + 1.0, int(rng.integers(1, 500))), lo, hi, np.linspace(lo, hi, n - DEGREE + 1)]
        knots = np.r_[[lo] * DEGREE, np.linspace(lo, hi, n - DEGREE + 1), [hi] * DEGREE]
        assert np.array_equal(bspline(u, lo, hi, n), BSpline.design_matrix(np.clip(u, lo, hi), knots, DEGREE).toarray())


def test_effects_that_pass_one_test_but_not_the_rounds_bar_are_said_as_not_proven():
    """The UTFSM 25 mm 0.1 Hz 0.5 A file (three cycles): seven effects halve the held-out error
    with p down to 0.0008, short of 0.01 over the 14 tried. Not "nothing takes it further":
    the recording cannot tell whether any is real. Only the last round counts, and only an
    effect between the round's bar and one test's."""
    from types import SimpleNamespace
    from models.diagnose.result import Candidate
    from models.diagnose.words import short_of_the_bar

    def c(effect, rnd, nrmse, p, relevance=5.0):
        return Candidate(effect, rnd, {}, {}, nrmse, 0.0, 0.0, p, 0.0, relevance)
    last = [c("bouc_wen", 2, 0.0265, 0.00094), c("stroke_damping", 2, 0.0275, 0.0008),
            c("free_play", 2, 0.045, 0.017), c("drift", 2, 0.059, 1.0), c("cavitation", 2, 0.03, 0.002, 0.05)]
    res = SimpleNamespace(candidates=[c("sensor_delay", 1, 0.04, 1e-5)] + last + [c(f"e{i}", 2, 0.05, 0.5)
                                                                              for i in range(9)],
                          steps=[SimpleNamespace(after=0.0499)], baseline=SimpleNamespace(nrmse_heldout=0.06))
    text = short_of_the_bar(res)
    assert text.startswith("Not proven: 2 of the 14 effects tried lower the held-out error from 4.99 % "
                           "(hysteresis (Bouc-Wen) to 2.65 %, stroke damping to 2.75 %), p = 0.0008 at best"), text
    assert "short of the bar for 14 tried (p < 0.00071)" in text and "cannot tell" in text
    res.candidates[1] = c("bouc_wen", 2, 0.0265, 0.0005)  # one clears the bar: it was accepted, or refused otherwise
    res.candidates[2] = c("stroke_damping", 2, 0.0275, 0.0001)
    assert short_of_the_bar(res) == ""
    assert short_of_the_bar(SimpleNamespace(candidates=[], steps=[], baseline=res.baseline)) == ""
