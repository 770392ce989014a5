"""`dyno bench sim`: speed of the compressible damper model against a scipy reference.

Case (issue 2): compressible Koni and Fox-heavy, 12.7 mm at 16 Hz, 10 s simulated,
output every 0.1 ms. The reference integrates the *same* right-hand side with
scipy.integrate.solve_ivp (Radau, rtol 1e-6), as a user would without our integrator.
"""
from __future__ import annotations

import math
import time

import numpy as np
from scipy.integrate import solve_ivp

from models.damper import load
from models.physics.kernel import pack
from models.physics.simulate import ASSEMBLY, C_to_K, simulate, sine

CASES = ("koni", "fox-heavy")


def reference(damper, t, amplitude, freq, x_mid, T, rtol=1e-6):
    """Forces [N] (damping + gas) at times t from solve_ivp Radau on the same equations.
    Returns (force, wall seconds)."""
    asm = ASSEMBLY[damper.layout]
    x0 = x_mid - amplitude
    prm, vp, vh = pack(damper, T, x0)
    w = 2 * np.pi * freq
    dydt = np.empty(asm.NSTATE)
    row = np.empty(5)

    def motion(tt):
        return x_mid - amplitude * np.cos(w * tt), amplitude * w * np.sin(w * tt)

    def f(tt, y):
        x, xd = motion(tt)
        asm.rhs(y, x, xd, prm, vp, vh, dydt)
        return dydt.copy()

    y0 = asm.initial_state(prm, x0)
    atol = np.full(asm.NSTATE, 1e-14)  # m^3 of oil, about 1 Pa
    t0 = time.perf_counter()
    sol = solve_ivp(f, (t[0], t[-1]), y0, method="Radau", t_eval=t, rtol=rtol, atol=atol)
    wall = time.perf_counter() - t0
    if not sol.success:
        raise RuntimeError(f"reference solver failed: {sol.message}")
    F = np.empty(len(t))
    for i, tt in enumerate(sol.t):
        x, xd = motion(tt)
        asm.outputs(sol.y[:, i], x, xd, prm, vp, vh, row)
        F[i] = row[0] + row[1]
    return F, wall


def run_case(name, seconds=10.0, freq=16.0, amplitude=0.0127, dt=1e-4, T_C=94.0,
             ref_seconds=None, repeats=3):
    """Benchmark one damper. ref_seconds shortens the reference run (the comparison then
    covers that span and its speed is scaled per simulated second)."""
    d = load(name)
    T = float(C_to_K(T_C))
    t, x, v = sine(amplitude, freq, seconds * freq, d.mid_stroke, dt=dt)
    simulate(d, t[:100], x[:100], v[:100], T=T)  # compile outside the timing
    wall = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = simulate(d, t, x, v, T=T)
        wall = min(wall, time.perf_counter() - t0)
    ours = r.damping + r.gas
    n_ref = len(t) if ref_seconds is None else int(round(ref_seconds / dt)) + 1
    F_ref, ref_wall = reference(d, t[:n_ref], amplitude, freq, d.mid_stroke, T)
    span = t[n_ref - 1] - t[0]
    diff = np.max(np.abs(ours[:n_ref] - F_ref)) / np.max(np.abs(F_ref))
    return {
        "damper": name,
        "simulated_s": seconds,
        "wall_s": wall,
        "realtime_factor": seconds / wall,
        "reference_simulated_s": span,
        "reference_wall_s": ref_wall,
        "speedup_vs_reference": (ref_wall / span) / (wall / seconds),
        "max_force_diff_fraction": float(diff),
        "peak_force_N": float(np.max(np.abs(F_ref))),
        "newton_capped_steps": r.newton_capped,
    }


def bench(seconds=10.0, ref_seconds=None):
    cases = {name: run_case(name, seconds=seconds, ref_seconds=ref_seconds) for name in CASES}
    goals = {"realtime_factor": 200.0, "speedup_vs_reference": 10.0, "max_force_diff_fraction": 0.005}
    ok = all(c["realtime_factor"] >= goals["realtime_factor"]
             and c["speedup_vs_reference"] >= goals["speedup_vs_reference"]
             and c["max_force_diff_fraction"] <= goals["max_force_diff_fraction"]
             for c in cases.values())
    return {"cases": cases, "goals": goals, "goals_met": ok}


def bench_sweep(workers=None, damper="koni", goal_wall_s=60.0, spec=None):
    """Issue 3's sweep: comprehensive compressible Koni on the simulator, 0.32 and 1.27 cm
    x 60 frequencies 1.25-20 Hz, in parallel (spec: a --cluster); wall time includes
    process start-up and compilation in the workers, as a user sees it."""
    import os

    from models import quarter_car as qcm
    from models.quarter_car import sweeps
    from protocols import cluster
    freqs = np.linspace(1.25, 20.0, 60)
    t0 = time.perf_counter()
    with cluster.pool(spec, workers or os.cpu_count() or 1) as (ex, workers):
        fr = sweeps.frequency_response(qcm.load("simulator"), damper, sweeps.AMPLITUDES, freqs,
                                       executor=ex, progress=True)
    wall = time.perf_counter() - t0
    simulated = float(sum((math.ceil(max(sweeps.SETTLE[0] * f, sweeps.SETTLE[1]))
                           + math.ceil(max(sweeps.MEASURE[0] * f, sweeps.MEASURE[1]))) / f for f in freqs)
                      * len(sweeps.AMPLITUDES))
    return {"damper": damper, "amplitudes_m": list(sweeps.AMPLITUDES), "freqs_hz": freqs.tolist(),
            "points": int(fr.values["rms_ratio_sprung"].size), "workers": workers, "simulated_s": simulated,
            "wall_s": wall, "goal_wall_s": goal_wall_s, "goal_met": wall < goal_wall_s}
