"""Sweeps, the parallel runner and the parametric variations on cases with known answers."""
import io
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from linear_car import linear_car, transmissibility
from models import quarter_car as qcm
from models.validation import quarter_car as qv
from models.quarter_car import sweeps
from models.damper import DamperError, SimplifiedDamper, SimplifiedDirection, load
from workers.pool import TaskFailed, run_all
from models.physics.simulate import simulate


def _square(x):
    return x * x


def test_run_all_keeps_job_order_in_processes_and_any_executor():
    jobs = list(range(12))
    assert run_all(_square, jobs, workers=2) == [j * j for j in jobs]
    stream = io.StringIO()
    with ThreadPoolExecutor(3) as ex:  # stands in for a distributed executor
        assert run_all(_square, jobs, executor=ex, progress=stream, label="squares") == [j * j for j in jobs]
    assert "squares" in stream.getvalue() and "12/12" in stream.getvalue()


def _fails_once(marker):
    """Raise the first time (marker absent), answer the second."""
    if not os.path.exists(marker):
        open(marker, "w").close()
        raise OSError("a passing fault")
    return marker


def _two_is_bad(job):
    if job == 2:
        raise ValueError(f"bad job {job}")
    return job


@pytest.mark.parametrize("workers", [1, 2])
def test_run_all_runs_a_failed_job_once_more_and_names_one_that_fails_twice(tmp_path, workers):
    jobs = [str(tmp_path / "a"), str(tmp_path / "b")]
    stream = io.StringIO()
    assert run_all(_fails_once, jobs, workers=workers, progress=stream, names=["job A", "job B"]) == jobs
    assert "job A failed (OSError: a passing fault): run again" in stream.getvalue()
    with pytest.raises(TaskFailed, match="job B failed twice: bad job 2"):
        run_all(_two_is_bad, [1, 2], workers=workers, names=["job A", "job B"])

def linear_damper(c):
    side = SimplifiedDirection(c_low=c, c_mid=c)
    return SimplifiedDamper("linear", "simplified", side, side)


def test_frequency_response_of_a_linear_car_is_its_transmissibility():
    # harmonic steady state: the rms velocity ratio equals the displacement transmissibility
    qc, c = linear_car(), 2500.0
    freqs = [1.5, 2.4, 5.0, 12.0]
    fr = sweeps.frequency_response(qc, linear_damper(c), [0.001], freqs, workers=1)
    for k, f in enumerate(freqs):
        t1, t2 = transmissibility(qc, c, f)
        assert fr.values["rms_ratio_sprung"][0, k] == pytest.approx(t1, rel=0.01)
        assert fr.values["rms_ratio_unsprung"][0, k] == pytest.approx(t2, rel=0.01)
    # small input: the tire never leaves the road and a linear car does not pack down
    assert np.all(fr.values["lift_off_fraction"] == 0.0)
    assert np.max(np.abs(fr.values["ride_height_change"])) < 1e-6


def test_asymmetric_damping_packs_the_car_down():
    # thesis 6.2.3: more rebound than compression damping lowers the average ride height
    side = lambda c: SimplifiedDirection(c_low=c, c_mid=c)
    packing = SimplifiedDamper("3:1", "simplified", side(1000.0), side(3000.0))
    fr = sweeps.frequency_response(linear_car(), packing, [0.0032], [5.0], workers=1)
    assert fr.values["ride_height_change"][0, 0] < -1e-3


@pytest.mark.parametrize("amplitudes, freqs, message", [
    ([0.0032], [], "frequency list is empty"),
    ([0.0032], [2.0, 0.0], "frequencies must be positive"),
    ([0.0032], [-1.0], "frequencies must be positive"),
    ([], [2.0], "amplitude list is empty"),
    ([0.05], [2.0], "bottoms the suspension"),
])
def test_bad_sweeps_are_refused_before_running(amplitudes, freqs, message):
    with pytest.raises(DamperError, match=message):
        sweeps.frequency_response(qcm.load("simulator"), "koni", amplitudes, freqs, workers=1)


def test_variations_scale_only_their_own_valve_range():
    koni = load("koni")
    v = np.array([0.02, -0.02, 0.6, -0.6])  # low speed, then well into the mid valves
    xm = np.full(4, koni.mid_stroke)

    def force(d):
        return simulate(d, np.arange(4.0), xm, v=v, compressible=False, T=koni.temperature.T_ref).damping

    base = force(koni)
    low_c = force(sweeps.vary(koni, "low_speed_compression", 2.0))
    assert low_c[0] > 1.5 * base[0] and low_c[1] == pytest.approx(base[1])
    mid_r = force(sweeps.vary(koni, "mid_speed_rebound", 2.0))
    assert mid_r[0] == pytest.approx(base[0]) and mid_r[3] < 1.3 * base[3]
    assert sweeps.vary(koni, "friction", 0.5).friction.F_table[0] == pytest.approx(0.5 * koni.friction.F_table[0])
    assert sweeps.vary(koni, "compliance", 2.0).compressibility.beta_inv == pytest.approx(
        koni.compressibility.beta_inv / 2)
    with pytest.raises(DamperError, match="unknown variation"):
        sweeps.vary(koni, "mid_speed_sideways", 2.0)


def test_parametric_cases_cover_section_6_3():
    labels = [c[0] for c in sweeps.parametric_cases(load("koni"))]
    assert labels[0] == "baseline" and len(labels) == 1 + 2 * len(sweeps.VARIATIONS) + 2
    assert "temperature 45C" in labels and "mid_speed_rebound x2" in labels


def test_wheel_hop_onset_is_the_start_of_the_range_reaching_the_top():
    freqs = np.array([3.0, 4.0, 5.0, 6.0, 7.0, 8.0])
    lift = np.array([[0.0, 0.1, 0.0, 0.2, 0.3, 0.3]])
    fr = sweeps.FrequencyResponse("car", "d", 363.15, np.array([0.0127]), freqs, {"lift_off_fraction": lift})
    assert qv.wheel_hop_onset(fr, 0) == 6.0
    fr.values["lift_off_fraction"] = np.array([[0.0, 0.1, 0.0, 0.2, 0.3, 0.0]])
    assert np.isnan(qv.wheel_hop_onset(fr, 0))


def test_a_flat_peak_reports_the_band_within_ten_percent_of_it():
    freqs = np.arange(5.0, 13.0)
    ride = np.array([[-0.2, -1.0, -2.0, -2.3, -2.4, -2.25, -1.5, -0.5]])  # cm-like, peak at 9 Hz
    fr = sweeps.FrequencyResponse("car", "d", 363.15, np.array([0.0127]), freqs, {"ride_height_change": ride})
    assert qv.flat_band(fr, "ride_height_change", 0, sign=-1.0) == (8.0, 10.0)
    r = qv._peak_frequency_row("Table 6.6", "x", 5.0, fr, "ride_height_change", 0, -1.0, ("ride_height",))
    assert not r["pass"] and "8-10 Hz" in r["sensitivity"] and "outside" in r["sensitivity"]


def test_every_step_row_names_readings_that_exist_and_cite_a_line():
    from models.validation import readings
    known = readings()
    assert all(isinstance(v["line"], int) and v["line"] > 0 and v["reading"] for v in known.values())
    metrics = {f"{k}_{m}": 10.0 for k in ("overshoot", "settling") for m in ("sprung", "unsprung")}
    rows = [r for *_, r in qv._step_rows([metrics] * len(qv.STEPS))]
    assert len(rows) == 4 * len(qv.STEPS)
    assert all(r["reading"] and set(r["reading"]) <= set(known) and r["experiment"] is not None for r in rows)


def test_a_square_wave_edge_jumps_by_its_peak_to_peak_about_the_static_position():
    from models.quarter_car.road import square_edge
    t = np.array([0.0, 4.9, 5.0, 6.0])
    assert square_edge(t, 0.0254, 5.0).tolist() == [-0.0127, -0.0127, 0.0127, 0.0127]


def test_the_damper_install_position_moves_it_towards_its_stop():
    car = qcm.load("simulator")
    koni = load("koni")
    _, mid = sweeps.step_response(car, koni, 0.0508, duration=1.0)
    _, low = sweeps.step_response(car, koni, 0.0508, duration=1.0, x_install=koni.mid_stroke - 0.015)
    assert low["overshoot_sprung"] < mid["overshoot_sprung"] - 5  # 15 mm further from the bump stop
