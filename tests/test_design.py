"""The next test (models/diagnose/design.py): rivals from a diagnosis, sines within the
cell's limits, the one where two explanations differ most per second of rig time."""
from types import SimpleNamespace

import numpy as np

from models.diagnose.candidates import Model
from models.diagnose.design import Limits, Sine, feasible, key, motion, propose, rivals
from models.diagnose.result import Candidate

CELL = Limits(x_min=0.002, x_max=0.074, velocity_max=1.5, force_max=1e4, frequency_max=20.0)


def _diagnosis(extra=()):
    base = SimpleNamespace(x=np.array([0.03, 0.04]), T=None, aux={})
    d = motion(Sine(0.005, 2.0, 0.038), base)
    final = {p.name: p.x0 for p in Model(d, ["sensor_delay"]).params}
    final["tau"] = 2e-4
    cand = lambda e, own, rel, p=1e-4, rnd=1: Candidate(e, rnd, own, {k: [v * 0.9, v * 1.1] for k, v in own.items()},
                                                         0.0, 0.0, 0.0, p, rel, rel)
    cands = [cand("sensor_delay", {"tau": 2e-4}, 0.55), cand("fluid_inertia", {"m_oil": 0.4}, 0.30),
             cand("free_play", {"c_play": 1e-7}, 0.01, p=0.5)] + list(extra)
    # the model as accepted: the lag took the place of the channels' alignment (supersedes)
    return SimpleNamespace(data=d, accepted=["sensor_delay"], effects=lambda: ["sensor_delay"], candidates=cands, steps=[],
                           noise_sd=1.0, final=SimpleNamespace(parameters=final))


def test_an_effect_taken_over_a_close_runner_up_is_a_rival_and_a_weak_one_is_not():
    rv = rivals(_diagnosis())
    assert [r.other for r in rv] == [("fluid_inertia",)]
    assert rv[0].values["m_oil"] == 0.4 and "tau" not in rv[0].values
    assert "sensor delay was taken over fluid inertia" in rv[0].said


def test_the_next_test_is_the_feasible_sine_where_the_rivals_differ_most_per_second():
    diag = _diagnosis()
    (p,) = propose(diag, CELL, budget_s=120.0)
    sines = feasible(CELL, diag.data)
    assert p.sine in sines
    assert all(2 * np.pi * s.frequency_hz * s.amplitude_m <= CELL.velocity_max and s.frequency_hz <= 20.0
               for s in sines)
    # a lag and an oil mass differ in proportion to the acceleration: the fastest sine the cell allows
    assert p.sine.frequency_hz == max(s.frequency_hz for s in sines if s.amplitude_m == p.sine.amplitude_m)
    assert p.ratio > 1 and "differ by" in p.why and p.sine.rig_s <= 120.0


def test_a_hint_under_the_noise_is_a_rival_unless_it_is_below_what_a_sample_resolves():
    hint = Candidate("presliding_friction", 2, {"x_stick": 1e-9}, {"x_stick": [0.0, 2e-9]}, 0, 0, 0, 0.02, 0.0, 0.0)
    assert all("presliding_friction" not in r.other for r in rivals(_diagnosis([hint])))
    hint = Candidate("breakaway_friction", 2, {"r_break": 1.5, "v_break": 0.005, "d_break": 2.0},
                     {"r_break": [1.0, 2.0], "v_break": [0.003, 0.007], "d_break": [1.0, 3.0]}, 0, 0, 0, 0.02, 0.0, 0.0)
    got = [r for r in rivals(_diagnosis([hint])) if "breakaway_friction" in r.other]
    assert got and "hinted at" in got[0].said


def test_nothing_is_proposed_when_the_budget_is_shorter_than_any_sine():
    assert propose(_diagnosis(), CELL, budget_s=0.5) == []


def test_no_sine_is_proposed_outside_the_envelope_the_nulls_are_proven_on():
    """Below it the baseline's own sampled friction reversal reads as physics on a null."""
    from protocols.discover import limits
    from rig import config
    lim = limits(config.load("virtual"))
    # the proven plan (protocols/proven.toml): 3.2 mm at 2 Hz to 12.7 mm at 16 Hz
    assert (lim.amplitude_min, lim.amplitude_max, round(lim.velocity_min, 4)) == (0.0032, 0.0127, 0.0402)
    assert round(lim.velocity_proven, 3) == 1.277
    sines = feasible(lim, _diagnosis().data)
    assert sines and all(0.0032 <= s.amplitude_m <= 0.0127
                         and 0.0402 <= 2 * np.pi * s.frequency_hz * s.amplitude_m <= 1.277 for s in sines)
    assert any(not 0.0032 <= s.amplitude_m <= 0.0127 for s in feasible(CELL, _diagnosis().data))


def test_a_sine_run_for_a_rival_is_not_asked_for_again_for_it():
    diag = _diagnosis()
    (p,) = propose(diag, CELL, budget_s=120.0)
    (q,) = propose(diag, CELL, budget_s=120.0, tried={(key(p.rival), p.sine)})
    assert q.sine != p.sine and q.rival.other == p.rival.other


def test_no_proposal_says_whether_none_is_needed_or_none_the_cell_can_run_would_tell():
    """The UTFSM 0.1 Hz file (mean removed by its source, so centred 0.7 mm from full
    extension on the virtual cell) has rivals but no sine the cell's stroke holds: "none
    needed" was wrong there."""
    from dataclasses import replace
    from commands.next_test import text
    diag = _diagnosis()
    assert "none within 0.5 s of rig time would decide" in text([], diag, CELL, 0.5)
    assert "sensor delay was taken over fluid inertia" in text([], diag, CELL, 0.5)
    said = text([], diag, replace(CELL, x_min=0.038), 120.0)
    assert said.startswith("Next test: none the cell can run, though explanations compete") and "38 mm" in said, said
    diag.candidates = diag.candidates[:1]
    assert text([], diag, CELL, 120.0).startswith("Next test: none needed")


def test_a_findings_own_rivals_are_designed_for_beside_the_runner_up():
    """The cell's timing at one frequency (referees.timing_rival) is a step's rival though
    another candidate gained more: the next test parts each pair."""
    diag = _diagnosis([Candidate("compressibility", 1, {"inv_k_oil": 1e-8}, {"inv_k_oil": [9e-9, 1.1e-8]}, 0.0, 0.0,
                                 0.0, 1e-4, 0.50, 0.50)])
    assert [r.other for r in rivals(diag)] == [("compressibility",)]
    diag.steps = [SimpleNamespace(effect="sensor_delay", rivals=[("fluid_inertia", 0.30, 0.2)])]
    assert [r.other for r in rivals(diag)] == [("compressibility",), ("fluid_inertia",)]
