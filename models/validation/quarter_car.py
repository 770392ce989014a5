"""Quarter-car rows of `dyno validate` (thesis 5.3, 6.2): natural frequencies, step
responses (Tables 6.2-6.3) and frequency responses (Tables 6.4-6.6) of the laboratory
simulator with each damper at the chapter's 90 C.

The model column is compared with the thesis's *analytical* column where it gives both:
our model is the thesis's model, so that is the number it should reproduce; the
experimental value is in the row's case text. Tolerances, declared here before any result
was computed: 25 % on ratios, ride heights and settling times, 1 Hz on frequencies, 10
percentage points on percent overshoot (a relative tolerance means nothing on 0-1 %).
"""
from __future__ import annotations


from models import quarter_car as qcm
from models.quarter_car import sweeps
from models.parallel import run_all

DAMPERS = ("koni", "mechformance", "fox-heavy", "fox-light")
TOL_RATIO, TOL_HZ, TOL_OVERSHOOT = 0.25, 1.0, 10.0
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
# Tables 6.2 (Koni) and 6.3 (+2.5 cm, all dampers): step [m] -> (mass, overshoot % exp,
# analytical, settling s exp, analytical). Table 6.2 lists two "+5" rows with nearly the
# same numbers; the tests used 5.08 cm steps (2.4), we take the first row.
STEPS = {
    ("koni", 0.0508): {"sprung": (23, 17, 0.218, 0.214), "unsprung": (23, 20, 0.171, 0.171)},
    ("koni", 0.025): {"sprung": (9, 1, 0.085, 0.088), "unsprung": (41, 33, 0.087, 0.089)},
    ("koni", -0.025): {"sprung": (52, 63, 0.241, 0.227), "unsprung": (20, 24, 0.179, 0.188)},
    ("mechformance", 0.025): {"sprung": (0, 0, 1.05, 1.86), "unsprung": (70, 63, 0.51, 0.42)},
    ("fox-heavy", 0.025): {"sprung": (0, 0, 0.63, 1.95), "unsprung": (46, 41, 0.31, 0.26)},
    ("fox-light", 0.025): {"sprung": (0, 2.2, 0.145, 0.219), "unsprung": (46, 48, 0.087, 0.093)},
}


def row(source, case, unit, thesis, model, tolerance, note, absolute=False):
    """One validation row; `tolerance` relative (fraction) or, if absolute, in `unit`."""
    model = float(model)
    rel = abs(model - thesis) / abs(thesis) if thesis else None
    ok = abs(model - thesis) <= tolerance if absolute else rel is not None and rel <= tolerance
    return {"source": source, "group": "quarter-car", "case": case, "unit": unit, "thesis": thesis,
            "model": model, "rel_error": rel, "tolerance": tolerance,
            "tolerance_type": "absolute" if absolute else "relative", "pass": bool(ok), "note": note}


def _step_job(job):
    damper, amplitude = job
    return sweeps.step_response(qcm.load("simulator"), damper, amplitude, duration=3.0)[1]


def wheel_hop_onset(fr, i):
    """Lowest frequency of the continuous lift-off range that reaches the sweep's top."""
    hop = fr.values["lift_off_fraction"][i] > 0
    if not hop[-1]:
        return float("nan")
    k = len(hop) - 1
    while k > 0 and hop[k - 1]:
        k -= 1
    return float(fr.freqs[k])


def rows(executor=None, workers=None, progress=None):
    car = qcm.load("simulator")
    out = []
    bounce, hop = qcm.natural_frequencies(qcm.load("simulator-9kg"))
    # Table 5.3 gives the thesis's own linear-model frequencies; the 9 kg unsprung option
    # is not stated for it (with 45.4 kg the wheel hop would be 15.3 Hz).
    out.append(row("Table 5.3", "simulator bounce mode, linear 2-DOF, unsprung 45.4 + 9 kg", "Hz", 2.41,
                   bounce, 0.02, "check"))
    out.append(row("Table 5.3", "simulator wheel-hop mode, linear 2-DOF, unsprung 45.4 + 9 kg", "Hz", 14.10,
                   hop, 0.02, "check"))
    out.append(row("Sec 6.2.1", "single-DOF tire mode, sprung + 45.4 kg unsprung on the tire", "Hz", 5.46,
                   qcm.tire_mode_frequency(car), 0.02, "check"))

    steps = run_all(_step_job, list(STEPS), executor, workers, progress, "step responses")
    for ((name, A), ref), m in zip(STEPS.items(), steps):
        table = "Table 6.2" if name == "koni" else "Table 6.3"
        for mass, (os_exp, os_an, ts_exp, ts_an) in ref.items():
            what = f"{name} {A * 100:+.2f} cm step, {mass} mass"
            out.append(row(table, f"{what} overshoot (experiment {os_exp} %)", "%", os_an,
                           m[f"overshoot_{mass}"], TOL_OVERSHOOT, "check", absolute=True))
            out.append(row(table, f"{what} settling time to 10 % (experiment {ts_exp} s)", "s", ts_an,
                           m[f"settling_{mass}"], TOL_RATIO, "check"))

    # all harmonic points of all dampers in one parallel batch
    responses = sweeps.sweep_cases(car, [(n, n, sweeps.T_BASE) for n in DAMPERS], executor=executor,
                                   workers=workers, progress=progress, label="frequency sweeps")
    for name, fr in responses.items():
        for i, A in enumerate(sweeps.AMPLITUDES):
            amp = f"{A * 100:.2f} cm"
            r_s, r_u, f_s, f_u = TABLE_6_4[name][A]
            for mass, ref_r, ref_f in (("sprung", r_s, f_s), ("unsprung", r_u, f_u)):
                value, freq = fr.peak(f"rms_ratio_{mass}", i)
                out.append(row("Table 6.4", f"{name} {amp} peak rms velocity ratio, {mass}", "-", ref_r,
                               value, TOL_RATIO, "check"))
                out.append(row("Table 6.4", f"{name} {amp} frequency of that peak, {mass}", "Hz", ref_f,
                               freq, TOL_HZ, "check", absolute=True))
            ref_h, ref_f = TABLE_6_6[name][A]
            value, freq = fr.peak("ride_height_change", i, sign=-1.0)
            out.append(row("Table 6.6", f"{name} {amp} peak change in average ride height", "cm", ref_h,
                           100 * value, TOL_RATIO, "check"))
            out.append(row("Table 6.6", f"{name} {amp} frequency of that peak", "Hz", ref_f, freq, TOL_HZ,
                           "check", absolute=True))
        i = sweeps.AMPLITUDES.index(0.0127)
        out.append(row("Table 6.5", f"{name} 1.27 cm wheel-hop range starts (lift-off up to 20 Hz)", "Hz",
                       TABLE_6_5[name], wheel_hop_onset(fr, i), TOL_HZ, "check", absolute=True))
    return out
