"""`dyno check`: production QA of a run against a reference run or a damper model."""
import json

import numpy as np
import pytest

from views.reports import peaks, qa
from tests.conftest import dyno, recorded



def _peak(freq, F):
    return peaks.Peak(f"sine 12.7 mm {freq} Hz", 12.7, freq, np.nan, 20.0, 0.1 * freq, F, -0.1 * freq, -1.5 * F)


def test_the_tolerance_is_a_percentage_newtons_or_the_larger_of_both():
    assert qa.parse_tolerance("5%").band(np.array([1000.0, -200.0])).tolist() == [50.0, 10.0]
    assert qa.parse_tolerance("5%,30N").band(np.array([1000.0, -200.0])).tolist() == [50.0, 30.0]
    assert qa.parse_tolerance("40N").band(np.array([1000.0])).tolist() == [40.0]
    assert qa.parse_tolerance("5 lbf").newtons == pytest.approx(22.2411, abs=1e-4)
    for bad in ("5x", "-5%", "0N", "150%", ""):
        with pytest.raises(ValueError, match="--tolerance"):
            qa.parse_tolerance(bad)
    # a bare number is refused with the units: 5 % and 5 N differ thirtyfold at 150 N
    with pytest.raises(ValueError, match=r"'5' is not a force with its unit \(one of N, lbf"):
        qa.parse_tolerance("5")


def test_one_qa_sentence_with_the_count_inside_and_where_it_is_outside():
    out = qa.Verdict(0.5, "rebound", -1000.0, -959.0, 20.0)
    assert qa.verdict(18, 1, [out]) == "FAIL: 17 of 18 inside the band; 1 outside: rebound at 500 mm/s, -4.1 % (-41 N)"
    # a reference near zero: the percentage explodes, the force beside it says how much
    near = qa.Verdict(0.05, "compression", -38.0, 250.0, 5.0)
    assert qa.verdict(4, 1, [near]).endswith("compression at 50.0 mm/s, +557.9 % (+212 N)")
    assert qa.verdict(18, 1) == "FAIL: 17 of 18 inside the band; 1 outside"
    assert qa.verdict(8, 0) == "PASS: 8 of 8 inside the band"


def test_each_speed_and_direction_passes_or_fails_with_its_margin():
    ref = [_peak(f, 1000.0 * 0.1 * f) for f in (1, 2, 4, 8)]  # 1000 N per m/s, 1500 in rebound
    run = [_peak(f, 1000.0 * 0.1 * f * (1.08 if f == 8 else 1.0)) for f in (1, 2, 4, 8)]  # 8 % strong at 0.8 m/s
    out = qa.verdicts(run, ref, qa.parse_tolerance("5%"), speeds=[0.1, 0.4, 0.8, 1.0])
    assert [(r.v_m_s, r.direction) for r in out][:2] == [(0.1, "compression"), (0.1, "rebound")]
    assert len(out) == 6  # 1.0 m/s was measured by neither
    assert all(r.passed for r in out[:4]) and out[0].margin_N == pytest.approx(5.0)
    fast = out[4]
    assert not fast.passed and fast.margin_N == pytest.approx(40.0 - 64.0)


def test_dyno_check_passes_a_run_against_itself_and_fails_it_against_another_damper(tmp_path):
    rec, _ = recorded(tmp_path / "k.mcap", "sine-matrix", {"amplitudes_mm": [12.7], "freqs_hz": [2.0, 8.0],
                                                          "record_cycles": 2})
    p = dyno("check", str(rec), "--against", str(rec), "--out", str(tmp_path / "qa"))
    assert p.returncode == 0, p.stderr
    assert "PASS" in p.stdout and (tmp_path / "qa" / "check.png").stat().st_size > 10_000
    p = dyno("check", str(rec), "--against", "koni", "--tolerance", "3%")
    assert p.returncode == 0 and "PASS" in p.stdout, p.stdout + p.stderr  # the plant is the koni model
    p = dyno("check", str(rec), "--against", "mechformance", "--units", "us")
    assert p.returncode == 1 and "FAIL" in p.stdout and " lbf, margin " in p.stdout, p.stdout + p.stderr
    p = dyno("check", str(rec), "--against", str(tmp_path / "none.mcap"))
    assert p.returncode == 2 and p.stderr.strip().endswith("none.mcap: no such file")
    # each check made is a row of the run index beside the run: three verdicts, the last a FAIL
    p = dyno("runs", "list", str(tmp_path), "--json")
    run_id = json.loads(p.stdout)[0]["id"]
    p = dyno("runs", "show", str(run_id), str(tmp_path), "--json")
    checks = json.loads(p.stdout)["checks"]
    assert [k["failed"] > 0 for k in checks] == [False, False, True], p.stderr
    assert checks[2]["reference"].startswith("model mechformance") and checks[2]["worst_margin_n"] < 0


def test_a_run_is_checked_against_a_force_velocity_table_a_spec_sheet_or_a_reports_csv(tmp_path):
    """A customer's spec sheet or another dyno's export: the run's force at the table's own
    speeds; the report's velocity.csv as a table gives the run back exactly."""
    from views.reports.recording import report
    rec, _ = recorded(tmp_path / "k.mcap", "sine-matrix", {"amplitudes_mm": [12.7], "freqs_hz": [1.0, 4.0],
                                                          "record_cycles": 2})
    report(rec, tmp_path / "report")
    own = tmp_path / "report" / "velocity.csv"
    p = dyno("check", rec, "--against", own, "--tolerance", "0.1%")
    assert p.returncode == 0 and "against table velocity.csv" in p.stdout and "PASS: " in p.stdout, p.stdout + p.stderr
    rows = [r.split(",") for r in own.read_text().splitlines()[1:] if r.split(",")[1]]
    # in lbf and in/s, rebound as a magnitude, the rebound 10 % stronger than the run, a speed the run never reached
    spec = tmp_path / "spec.csv"
    spec.write_text("Customer A-12 target\n\nShaft speed (in/sec),Compression (lbs),Rebound (lbs)\n" + "".join(
        f"{float(v) / 25.4:.6f},{float(c) / 4.4482216:.4f},{-1.1 * float(r) / 4.4482216:.4f}\n" for v, c, r, *_ in rows)
        + "40,500,900\n")
    p = dyno("check", rec, "--against", spec, "--tolerance", "5%")
    assert p.returncode == 1, p.stdout + p.stderr
    lines = p.stdout.splitlines()
    assert all(" pass" in line for line in lines if "compression reference" in line), p.stdout
    assert all(" FAIL" in line for line in lines if "rebound     reference" in line), p.stdout
    assert f"FAIL: {len(rows)} of {2 * len(rows)} inside the band" in p.stdout
    assert "not measured by this run, outside the speeds it reached: the table's 1016 mm/s" in p.stdout
    # a table's numbers are not guessed: no unit, one line
    bare = tmp_path / "bare.csv"
    bare.write_text("Velocity,Compression,Rebound\n0.1,500,-600\n0.2,800,-900\n")
    p = dyno("check", rec, "--against", bare)
    assert p.returncode == 2 and p.stderr.strip().splitlines()[-1].endswith(
        "column 'Velocity' gives no velocity unit: name it like 'Velocity [mm/s]' (a table's numbers are not "
        "guessed)"), p.stderr


def test_a_warmer_run_is_compensated_to_its_references_temperature_with_its_model(tmp_path):
    """The same damper at 20 C and at 60 C: the warm run fails against the cool one (thinner
    oil), passes once moved to 20 C with a model of it (here the plant's own, as a perfect
    identification would give), and says which it did."""
    from contextlib import closing

    from models.damper import load, to_dict
    from protocols import cell, runner
    from protocols.recorded import for_run
    from protocols.library import PROTOCOLS
    from protocols.plan import Plan
    from rig import config as rig_config
    from sim_backend.options import PlantOptions
    module = PROTOCOLS["sine-matrix"]
    plan = Plan(module, module.Params(amplitudes_mm=[12.7], freqs_hz=[0.5, 2.0, 8.0], record_cycles=2))
    for name, T0 in (("cool", 293.15), ("warm", 333.15)):
        with cell.direct(rig_config.load("virtual"), "koni", PlantOptions(T0=T0)) as c, \
                closing(for_run(tmp_path / f"{name}.mcap", c, plan)) as rec:
            runner.run_plan(plan, c, [rec])
    warm, cool, tol = tmp_path / "warm.mcap", tmp_path / "cool.mcap", qa.parse_tolerance("3%")
    plain = qa.check(warm, cool, tol)
    assert plain.compensation.startswith("not compensated for temperature: the run averaged 5")  # cooling from 60 C
    assert "the reference 20 C, and the run has no identified damper model (warm.model.json" in plain.compensation
    assert not all(r.passed for r in plain.results)
    (tmp_path / "warm.minimal.json").write_text('{"model": "minimal"}')  # what identify writes without --damper
    hint = qa.check(warm, cool, tol).compensation
    assert "its model warm.minimal.json has no temperature law" in hint and "writes warm.model.json" in hint
    (tmp_path / "warm.model.json").write_text(json.dumps(to_dict(load("koni"))))
    moved = qa.check(warm, cool, tol)
    assert moved.compensation.startswith("compensated for temperature: the run's forces moved from its 5")
    assert all(r.passed for r in moved.results), [(r.v_m_s, r.direction, r.margin_N) for r in moved.results]


def _one_speed(top, c):
    """A one-speed run's Peak: its stroke read as F = c v up to the top speed [m/s]."""
    p = _peak(0.1, c * top)
    p.v_comp, p.v_reb, p.F_reb = top, -top, -c * top
    p.stroke_v = np.linspace(-top, top, 41)
    p.stroke_F = c * p.stroke_v
    return p


def test_one_speed_runs_are_read_along_the_stroke_and_a_slow_one_at_its_own_speeds():
    run, ref = [_one_speed(0.3, 1000.0)], [_one_speed(0.3, 1030.0)]
    out = qa.verdicts(run, ref, qa.parse_tolerance("5%"))
    from views.reports.velocity_table import standard_speeds
    assert [r.v_m_s for r in out[::2]] == [s for s in standard_speeds() if s <= 0.3]  # never past the top
    assert all(r.passed for r in out) and out[0].measured_N == pytest.approx(1000.0 * out[0].v_m_s)
    assert not any(r.passed for r in qa.verdicts(run, [_one_speed(0.3, 1200.0)], qa.parse_tolerance("5%")))
    slow = [_one_speed(0.012, 1000.0)]  # 12 mm/s: below every standard speed
    out = qa.verdicts(slow, slow, qa.parse_tolerance("5%"))
    assert [r.v_m_s for r in out[::2]] == pytest.approx([0.003, 0.006, 0.009]) and all(r.passed for r in out)


def test_an_indexed_one_speed_run_trends_as_unmeasured_not_as_an_error():
    """The run index keeps a run's peaks, not its strokes: a one-speed run's force at a speed
    is unknown there (nan), never an AttributeError in `runs trend`."""
    from views.run_index import force_at
    row = {"segment": "sine 19 mm 1.05 Hz", "amplitude_mm": 19.0, "freq_hz": 1.05, "target_c": None,
           "v_comp": 0.125, "F_comp": 500.0, "v_reb": -0.125, "F_reb": -400.0}
    assert np.isnan(force_at([row], "compression", 0.1))


def test_an_indexed_run_trends_its_first_run_of_a_differing_test_and_a_random_input_without_an_amplitude():
    """`runs trend` reads a run's force as its velocity table does: of a test whose repeats
    differ (a coil current changed), the first run's; a random input's row, whose amplitude
    SQLite keeps as null, is read too."""
    from views.run_index import force_at

    def row(segment, amplitude, freq, F):
        return {"segment": segment, "amplitude_mm": amplitude, "freq_hz": freq, "target_c": None, "v_comp": 0.09,
                "F_comp": F, "v_reb": -0.09, "F_reb": -F, "stroke_v": "[-0.09, 0, 0.09]",
                "stroke_F": json.dumps([-F, 0.0, F])}
    assert force_at([row("sine 5 mm 3 Hz", 5.0, 3.0, 200.0), row("sine 5 mm 3 Hz (2)", 5.0, 3.0, 1500.0)],
                    "compression", 0.045) == pytest.approx(100.0)
    assert force_at([row("motion that does not repeat", None, None, 900.0)], "compression", 0.045) == pytest.approx(450.0)
