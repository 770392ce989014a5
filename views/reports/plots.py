"""Damper plots an engineer expects, written as PNG (matplotlib, no display needed).

    plot_damper(damper, out_dir)  ->  list of written paths
Force positive in compression; loops run clockwise in force-displacement.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from models.damper import Damper
from models.physics.simulate import C_to_K, simulate, sine
from views.reports.page import save

AMPLITUDES = (0.0127, 0.0064, 0.0032, 0.0016)  # m, thesis test matrix (2.3.1.1)
FREQUENCIES = (1.0, 2.0, 4.0, 8.0, 16.0)  # Hz


def last_cycle(damper, amplitude, freq, T, cycles=3, samples_per_cycle=2000):
    """Compressible response over the last of `cycles` sine cycles about mid-stroke."""
    dt = 1.0 / (freq * samples_per_cycle)
    t, x, v = sine(amplitude, freq, cycles, damper.mid_stroke, dt=dt)
    r = simulate(damper, t, x, v, T=T, x_e=damper.mid_stroke)
    keep = t >= t[-1] - 1.0 / freq
    return r, keep


def _finish(fig, ax, path, title, zero_x=True):
    ax.axhline(0, color="0.6", lw=0.6)
    if zero_x:
        ax.axvline(0, color="0.6", lw=0.6)
    ax.grid(alpha=0.3)
    ax.set_title(title)
    ax.legend(fontsize=8)
    save(fig, Path(path), dpi=110)
    return path


def plot_loops(damper: Damper, out_dir, amplitude=0.0127, freqs=FREQUENCIES, T_C=94.0):
    """Force-velocity and force-displacement loops at one amplitude over frequencies."""
    out_dir = Path(out_dir)
    fv, ax_v = plt.subplots(figsize=(7, 5))
    fx, ax_x = plt.subplots(figsize=(7, 5))
    for f in freqs:
        r, k = last_cycle(damper, amplitude, f, float(C_to_K(T_C)))
        ax_v.plot(r.v[k], r.force[k] / 1e3, lw=1.2, label=f"{f:g} Hz")
        ax_x.plot(r.x[k] * 1e3, r.force[k] / 1e3, lw=1.2, label=f"{f:g} Hz")
    ax_v.set(xlabel="velocity [m/s] (compression +)", ylabel="total force [kN] (compression +)")
    ax_x.set(xlabel="displacement from full extension [mm]", ylabel="total force [kN]")
    title = f"{damper.name}: {amplitude*1e3:.1f} mm sine, {T_C:g} C"
    return [_finish(fv, ax_v, out_dir / f"{damper.name}_force_velocity.png", title + " (hysteresis from compressibility)"),
            _finish(fx, ax_x, out_dir / f"{damper.name}_force_displacement.png", title, zero_x=False)]


def plot_temperature(damper: Damper, out_dir, temps_C=(39.0, 94.0, 149.0), freq=0.5, amplitude=0.0127):
    """Low-speed force-displacement loops at several temperatures (thesis Fig 2.5a):
    the gas-spring bias and slope rise with temperature."""
    fig, ax = plt.subplots(figsize=(7, 5))
    for T_C in temps_C:
        r, k = last_cycle(damper, amplitude, freq, float(C_to_K(T_C)))
        line, = ax.plot(r.x[k] * 1e3, r.force[k] / 1e3, lw=1.2, label=f"{T_C:g} C total")
        ax.plot(r.x[k] * 1e3, r.gas[k] / 1e3, lw=0.8, ls="--", color=line.get_color(), label=f"{T_C:g} C gas")
    ax.set(xlabel="displacement from full extension [mm]", ylabel="force [kN]")
    return _finish(fig, ax, Path(out_dir) / f"{damper.name}_temperature.png",
                   f"{damper.name}: {amplitude*1e3:.1f} mm, {freq:g} Hz at several temperatures", zero_x=False)


def composite(damper: Damper, T_C=94.0, amplitudes=AMPLITUDES, freqs=FREQUENCIES):
    """Peak force and peak velocity per test of the matrix: rows (amp, freq, v_peak,
    F_comp_peak, F_reb_peak) in SI."""
    rows = []
    for a in amplitudes:
        for f in freqs:
            r, k = last_cycle(damper, a, f, float(C_to_K(T_C)), samples_per_cycle=1000)
            rows.append((a, f, 2 * np.pi * f * a, r.force[k].max(), r.force[k].min()))
    return np.array(rows)


def plot_composite(damper: Damper, out_dir, T_C=94.0):
    """Composite peak force - peak velocity curve over the thesis matrix (Fig 2.7),
    with the incompressible force-velocity curve (damping + gas at mid-stroke)."""
    c = composite(damper, T_C)
    fig, ax = plt.subplots(figsize=(7, 5))
    for a in AMPLITUDES:
        m = c[:, 0] == a
        pts, = ax.plot(c[m, 2], c[m, 3] / 1e3, "o", ms=5, label=f"{a*1e3:.1f} mm, 1-16 Hz")
        ax.plot(-c[m, 2], c[m, 4] / 1e3, "o", ms=5, color=pts.get_color())
    v = np.linspace(-c[:, 2].max(), c[:, 2].max(), 301)
    xm = np.full_like(v, damper.mid_stroke)
    r = simulate(damper, np.linspace(0, 1, len(v)), xm, v=v, T=float(C_to_K(T_C)), compressible=False)
    ax.plot(v, (r.damping + r.gas) / 1e3, "k-", lw=1, label="incompressible, damping + gas")
    ax.set(xlabel="peak velocity [m/s]", ylabel="peak force [kN]")
    return _finish(fig, ax, Path(out_dir) / f"{damper.name}_composite.png",
                   f"{damper.name}: composite peak force - peak velocity, {T_C:g} C")


def plot_pressures(damper: Damper, out_dir, amplitude=0.0127, freq=8.0, T_C=94.0):
    """Chamber pressures against velocity over one cycle (thesis Figs 4.11, 4.16)."""
    r, k = last_cycle(damper, amplitude, freq, float(C_to_K(T_C)))
    fig, ax = plt.subplots(figsize=(7, 5))
    ax.plot(r.v[k], r.P1[k] / 1e6, label="chamber 1 (compression)")
    ax.plot(r.v[k], r.P2[k] / 1e6, label="chamber 2 (rebound)")
    if damper.layout == "remote_reservoir":
        ax.plot(r.v[k], r.P_gas[k] / 1e6, label="chamber 3 / gas")
    ax.set(xlabel="velocity [m/s]", ylabel="absolute pressure [MPa]")
    return _finish(fig, ax, Path(out_dir) / f"{damper.name}_pressures.png",
                   f"{damper.name}: chamber pressures, {amplitude*1e3:.1f} mm {freq:g} Hz, {T_C:g} C")


def plot_damper(damper: Damper, out_dir, amplitude=0.0127, freqs=FREQUENCIES, T_C=94.0):
    """All damper plots into out_dir; returns the written paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return [*plot_loops(damper, out_dir, amplitude, freqs, T_C), plot_temperature(damper, out_dir),
            plot_composite(damper, out_dir, T_C), plot_pressures(damper, out_dir, amplitude, 8.0, T_C)]
