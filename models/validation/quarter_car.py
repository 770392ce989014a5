"""Quarter-car rows of `dyno validate` (thesis 5.3, 6.2): natural frequencies, step
responses (Tables 6.2-6.3) and frequency responses (Tables 6.4-6.6) of the laboratory
simulator, each test read as models/validation/readings.toml states (the line of the
thesis each reading rests on): the car of Table 2.2, each damper at the temperature its
quarter-car tests held (line 719), steps as the edge of a 0.1 Hz square wave (line 713).

The model column is compared with the thesis's *analytical* column where it gives both:
our model is the thesis's model, so that is the number it should reproduce. The
experimental value has its own column, with the thesis model's own error against it
beside ours. Tolerances, declared here before any result was computed: 25 % on ratios,
ride heights and settling times, 1 Hz on frequencies, 10 percentage points on percent
overshoot (a relative tolerance means nothing on 0-1 %).
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import brentq

from models import quarter_car as qcm
from models.damper import load
from models.physics.simulate import C_to_K, warm
from models.quarter_car import sweeps
from workers.pool import run_all

DAMPERS = ("koni", "mechformance", "fox-heavy", "fox-light")
TOL_RATIO, TOL_HZ, TOL_OVERSHOOT = 0.25, 1.0, 10.0
# damper temperature during the quarter-car tests [C] (line 719: Koni body 95 C,
# Mechformance and Fox reservoirs 44 C and 46 C)
TEST_C = {"koni": 95.0, "mechformance": 44.0, "fox-heavy": 46.0, "fox-light": 46.0}
# Table 5.3 (theoretical, experimental) [Hz]
TABLE_5_3 = {"bounce": (2.41, 2.4), "wheel-hop": (14.10, 13.0)}
SETTLE_S, RECORD_S = 5.0, 3.0  # half a 0.1 Hz period held before the edge; what is measured after it
INSTALL_MM = tuple(range(-20, 21, 4))
ALT_C = 90.0  # the damper temperature a missed sweep row is rerun at (line 2570's baseline)  # install offsets from mid-stroke tried for a missed step row [mm]
# Table 6.4: amplitude m -> (peak rms velocity ratio sprung, unsprung, frequency sprung, unsprung)
TABLE_6_4 = {
    "koni": {0.0032: (1.91, 2.02, 4.5, 4.5), 0.0127: (1.6, 1.45, 3.25, 3.25)},
    "mechformance": {0.0032: (2.93, 2.85, 4.5, 4.5), 0.0127: (2.16, 2.03, 3.5, 3.5)},
    "fox-heavy": {0.0032: (2.3, 2.41, 4.5, 4.5), 0.0127: (1.69, 1.60, 3.5, 3.5)},
    "fox-light": {0.0032: (1.32, 1.33, 3.0, 10.0), 0.0127: (1.86, 1.29, 2.25, 2.75)},
}
# Table 6.5: lowest frequency of the wheel-hop range at 1.27 cm [Hz] (Fox-light: "5.0,
# 7-20": an isolated point at 5 Hz, then 7-20 Hz; we compare the start of the range)
TABLE_6_5 = {"koni": 4.5, "mechformance": 3.5, "fox-heavy": 3.5, "fox-light": 7.0}
# Table 6.6: amplitude m -> (peak change in average ride height [cm], its frequency [Hz])
TABLE_6_6 = {
    "koni": {0.0032: (-0.3, 6.5), 0.0127: (-1.0, 9.0)},
    "mechformance": {0.0032: (-1.7, 5.5), 0.0127: (-2.8, 5.0)},
    "fox-heavy": {0.0032: (-1.5, 6.0), 0.0127: (-2.79, 9.0)},
    "fox-light": {0.0032: (-0.5, 12.0), 0.0127: (-2.34, 10.0)},
}
# Tables 6.2 (Koni) and 6.3 (+2.5 cm, all dampers): (damper, step peak to peak [m]) ->
# {mass: (overshoot % experiment, analytical, settling s experiment, analytical)}. Table
# 6.2 lists two "+5" rows with nearly the same numbers; the tests used 5.08 cm steps
# (line 713), we take the first row.
STEPS = {
    ("koni", 0.0508): {"sprung": (23, 17, 0.218, 0.214), "unsprung": (23, 20, 0.171, 0.171)},
    ("koni", 0.025): {"sprung": (9, 1, 0.085, 0.088), "unsprung": (41, 33, 0.087, 0.089)},
    ("koni", -0.025): {"sprung": (52, 63, 0.241, 0.227), "unsprung": (20, 24, 0.179, 0.188)},
    ("mechformance", 0.025): {"sprung": (0, 0, 1.05, 1.86), "unsprung": (70, 63, 0.51, 0.42)},
    ("fox-heavy", 0.025): {"sprung": (0, 0, 0.63, 1.95), "unsprung": (46, 41, 0.31, 0.26)},
    ("fox-light", 0.025): {"sprung": (0, 2.2, 0.145, 0.219), "unsprung": (46, 48, 0.087, 0.093)},
}


def _error(a, b, absolute):
    """a's error against b: in the unit if absolute, else relative (None at b = 0)."""
    if absolute:
        return abs(a - b)
    return abs(a - b) / abs(b) if b else None


def row(source, case, unit, thesis, model, tolerance, note, absolute=False, reading=(), experiment=None):
    """One validation row; `tolerance` relative (fraction) or, if absolute, in `unit`.
    reading: the readings.toml entries it rests on; experiment: the thesis's measured
    value where it gives one, compared apart (thesis model and ours, each against it)."""
    model = float(model)
    rel = abs(model - thesis) / abs(thesis) if thesis else None
    ok = abs(model - thesis) <= tolerance if absolute else rel is not None and rel <= tolerance
    out = {"source": source, "group": "quarter-car", "case": case, "unit": unit, "thesis": thesis,
           "model": model, "rel_error": rel, "tolerance": tolerance,
           "tolerance_type": "absolute" if absolute else "relative", "pass": bool(ok), "note": note,
           "reading": list(reading), "experiment": experiment, "sensitivity": None}
    if experiment is not None:
        out["thesis_vs_experiment"] = _error(thesis, experiment, absolute)
        out["model_vs_experiment"] = _error(model, experiment, absolute)
    return out


def _step_job(job):
    """(QuarterCarResult or None, metrics) of one step case; the result only when asked
    (a sensitivity scan needs the metrics alone)."""
    damper, amplitude, offset_mm, whole = job
    d = load(damper)
    x = None if offset_mm is None else d.mid_stroke + offset_mm * 1e-3
    r, m = sweeps.step_response(qcm.load("simulator"), d, amplitude, T=float(C_to_K(TEST_C[damper])),
                                duration=SETTLE_S + RECORD_S, t_step=SETTLE_S, square=True, x_install=x)
    return (r if whole else None), m


def _step_rows(steps):
    """[((damper, step), metric, row)] for Tables 6.2-6.3 from step_response's metrics."""
    out = []
    for (key, ref), m in zip(STEPS.items(), steps):
        name, A = key
        table = "Table 6.2" if name == "koni" else "Table 6.3"
        for mass, (os_exp, os_an, ts_exp, ts_an) in ref.items():
            what = f"{name} {A * 100:+.2f} cm step, {mass} mass"
            out.append((key, f"overshoot_{mass}", row(
                table, f"{what} overshoot", "%", os_an, m[f"overshoot_{mass}"], TOL_OVERSHOOT, "check",
                absolute=True, reading=("car", "temperature_car", "step_input", "overshoot"), experiment=os_exp)))
            out.append((key, f"settling_{mass}", row(
                table, f"{what} settling time", "s", ts_an, m[f"settling_{mass}"], TOL_RATIO, "check",
                reading=("car", "temperature_car", "step_input", "settling"), experiment=ts_exp)))
    return out


def step_sensitivity(step_rows, executor=None, workers=None, progress=None):
    """For each missed step row, the install offset from mid-stroke [mm] (INSTALL_MM, the
    thesis does not say where the damper sits) nearest zero that would bring it within
    its tolerance, written into the row's `sensitivity`; reported, never applied."""
    cases = list(dict.fromkeys(key for key, _, r in step_rows if not r["pass"]))
    jobs = [(n, A, mm, False) for n, A in cases for mm in INSTALL_MM]
    got = {j[:3]: m for j, (_, m) in zip(jobs, run_all(_step_job, jobs, executor, workers, progress,
                                                         "install offsets", warm=warm))}
    def meets(r, key, metric, mm):
        return row("", "", "", r["thesis"], got[(*key, mm)][metric], r["tolerance"], "",
                   absolute=r["tolerance_type"] == "absolute")["pass"]

    for key, metric, r in step_rows:
        if r["pass"]:
            continue
        fits = [mm for mm in INSTALL_MM if meets(r, key, metric, mm)]
        every = [mm for mm in INSTALL_MM if all(meets(q, k, m, mm) for k, m, q in step_rows if k == key)]
        r["sensitivity"] = "; ".join(filter(None, [
            f"install {min(fits, key=abs):+d} mm from mid-stroke" if fits else
            f"no install offset in {INSTALL_MM[0]:+d}..{INSTALL_MM[-1]:+d} mm",
            every and f"this step's 4 rows all meet at {min(every, key=abs):+d} mm"]))


def wheel_hop_onset(fr, i):
    """Lowest frequency of the continuous lift-off range that reaches the sweep's top."""
    hop = fr.values["lift_off_fraction"][i] > 0
    if not hop[-1]:
        return float("nan")
    k = len(hop) - 1
    while k > 0 and hop[k - 1]:
        k -= 1
    return float(fr.freqs[k])


FLAT = 0.1  # a peak is flat over the band where the curve is within this share of it


def flat_band(fr, metric, i, sign=1.0):
    """(lo, hi) [Hz]: the contiguous band about a curve's peak where sign * value is within
    FLAT of the peak's: where the frequency of a peak is ill-determined."""
    v = sign * fr.values[metric][i]
    k = int(np.argmax(v))
    near = v >= v[k] - FLAT * abs(v[k])
    lo = hi = k
    while lo > 0 and near[lo - 1]:
        lo -= 1
    while hi < len(v) - 1 and near[hi + 1]:
        hi += 1
    return float(fr.freqs[lo]), float(fr.freqs[hi])


def _peak_frequency_row(source, case, ref_f, fr, metric, i, sign, reading):
    """A row on the frequency of a peak; a miss says over what band the peak is flat."""
    value, freq = fr.peak(metric, i, sign=sign)
    r = row(source, case, "Hz", ref_f, freq, TOL_HZ, "check", absolute=True, reading=reading)
    if not r["pass"]:
        lo, hi = flat_band(fr, metric, i, sign)
        inside = "inside" if lo - TOL_HZ <= ref_f <= hi + TOL_HZ else "outside"
        r["sensitivity"] = f"flat peak: within {100 * FLAT:.0f} % of it over {lo:g}-{hi:g} Hz, the thesis's {inside}"
    return r


def unsprung_for_wheel_hop(car, hz):
    """The unsprung mass [kg] whose linear wheel-hop mode is at hz (Table 5.3's sensitivity)."""
    f = lambda m: qcm.natural_frequencies(dataclasses.replace(car, m_u=m))[1] - hz
    return float(brentq(f, 10.0, 200.0))


def rows(executor=None, workers=None, progress=None, sensitivity=False, kept=None):
    """The quarter-car rows; sensitivity: what install offset would reconcile each missed
    step row (slow); kept: a dict that receives the step results ("steps": {(damper, step):
    QuarterCarResult}) and the sweeps ("sweeps": {damper: FrequencyResponse}) for plots."""
    car = qcm.load("simulator")
    out = []
    modes = dict(zip(("bounce", "wheel-hop"), qcm.natural_frequencies(car)))
    for mode, (theory, exp) in TABLE_5_3.items():
        r = row("Table 5.3", f"simulator {mode} mode, linear 2-DOF, unsprung 45.4 kg", "Hz", theory, modes[mode],
                0.02, "check", reading=("car", "natural_frequencies"), experiment=exp)
        if not r["pass"] and mode == "wheel-hop":
            m = unsprung_for_wheel_hop(car, theory)
            r["sensitivity"] = (f"unsprung {m:.1f} kg (+{m - car.m_u:.1f}: the 9 kg bolt-on of line 687 is "
                                f"plausible)")
        out.append(r)
    out.append(row("Sec 6.2.1", "single-DOF tire mode, sprung + 45.4 kg unsprung on the tire", "Hz", 5.46,
                   qcm.tire_mode_frequency(car), 0.02, "check", reading=("car",)))

    steps = run_all(_step_job, [(n, A, None, kept is not None) for n, A in STEPS], executor, workers, progress,
                    "step responses", warm=warm)
    step_rows = _step_rows([m for _, m in steps])
    if sensitivity:
        step_sensitivity(step_rows, executor, workers, progress)
    out += [r for *_, r in step_rows]

    # all harmonic points of all dampers in one parallel batch
    responses = sweeps.sweep_cases(car, [(n, n, float(C_to_K(TEST_C[n]))) for n in DAMPERS], executor=executor,
                                   workers=workers, progress=progress, label="frequency sweeps")
    if kept is not None:
        kept.update(steps=dict(zip(STEPS, [r for r, _ in steps])), sweeps=responses)
    swept = {name: _sweep_rows(name, fr) for name, fr in responses.items()}
    if sensitivity:
        _temperature_sensitivity(car, swept, executor, workers, progress)
    return out + [r for rs in swept.values() for r in rs]


def _sweep_rows(name, fr):
    """Tables 6.4-6.6 rows of one damper's frequency response."""
    out = []
    swept = ("car", "temperature_car", "sweep")
    for i, A in enumerate(sweeps.AMPLITUDES):
        amp = f"{A * 100:.2f} cm"
        r_s, r_u, f_s, f_u = TABLE_6_4[name][A]
        for mass, ref_r, ref_f in (("sprung", r_s, f_s), ("unsprung", r_u, f_u)):
            value, _ = fr.peak(f"rms_ratio_{mass}", i)
            out.append(row("Table 6.4", f"{name} {amp} peak rms velocity ratio, {mass}", "-", ref_r,
                           value, TOL_RATIO, "check", reading=swept + ("rms_ratio",)))
            out.append(_peak_frequency_row("Table 6.4", f"{name} {amp} frequency of that peak, {mass}", ref_f,
                                           fr, f"rms_ratio_{mass}", i, 1.0, swept + ("rms_ratio",)))
        ref_h, ref_f = TABLE_6_6[name][A]
        value, _ = fr.peak("ride_height_change", i, sign=-1.0)
        out.append(row("Table 6.6", f"{name} {amp} peak change in average ride height", "cm", ref_h,
                       100 * value, TOL_RATIO, "check", reading=swept + ("ride_height",)))
        out.append(_peak_frequency_row("Table 6.6", f"{name} {amp} frequency of that peak", ref_f, fr,
                                       "ride_height_change", i, -1.0, swept + ("ride_height",)))
    i = sweeps.AMPLITUDES.index(0.0127)
    out.append(row("Table 6.5", f"{name} 1.27 cm wheel-hop range starts (lift-off up to 20 Hz)", "Hz",
                   TABLE_6_5[name], wheel_hop_onset(fr, i), TOL_HZ, "check", absolute=True,
                   reading=swept + ("wheel_hop",)))
    return out


def _temperature_sensitivity(car, swept, executor, workers, progress):
    """A missed sweep row of a damper tested below ALT_C, rerun at ALT_C: a reservoir held
    at 44-46 C (line 719) says little of the oil in the body, which the valves work."""
    names = [n for n, rs in swept.items() if TEST_C[n] < ALT_C and not all(r["pass"] for r in rs)]
    if not names:
        return
    alt = sweeps.sweep_cases(car, [(n, n, float(C_to_K(ALT_C))) for n in names], executor=executor,
                             workers=workers, progress=progress, label=f"frequency sweeps at {ALT_C:g} C")
    for name, fr in alt.items():
        for r, r_alt in zip(swept[name], _sweep_rows(name, fr)):
            if not r["pass"]:
                said = "meets it" if r_alt["pass"] else "misses too"
                r["sensitivity"] = "; ".join(filter(None, [r["sensitivity"],
                                                           f"at {ALT_C:g} C: {r_alt['model']:.4g} ({said})"]))
