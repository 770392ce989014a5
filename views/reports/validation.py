"""Figures of `dyno validate --report DIR`: the step responses and the ride-height sweeps
of the quarter-car rows beside the thesis's own numbers (Tables 6.2, 6.3 and 6.6)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from views.reports.plots import plt
from views.reports.quarter_car import save_figure

MASSES = (("sprung", "y1", "C0"), ("unsprung", "y2", "C1"))


def plot_steps(kept, steps, path, edge_s):
    """kept: {(damper, step m): QuarterCarResult}; steps: {same key: {mass: (overshoot %
    experiment, analytical, settling s experiment, analytical)}}. Each mass's displacement
    change from the edge; dotted: the thesis model's peak (1 + overshoot) times our steady
    state, and its settling time; crosses: the experiment's settling time (on the steady
    state) and its peak (at the left edge: the thesis gives no peak time)."""
    fig, axes = plt.subplots(2, (len(kept) + 1) // 2, figsize=(5.0 * ((len(kept) + 1) // 2), 7.6), squeeze=False)
    fig.suptitle("Quarter-car steps (square-wave edge at 0.1 Hz) against Tables 6.2-6.3: "
                 "dotted = thesis model, x = experiment")
    for ax, (key, r) in zip(axes.ravel(), kept.items()):
        t = r.t - edge_s
        after_s = max(1.0, 1.2 * max(max(v[2], v[3]) for v in steps[key].values()))
        shown = (t >= -0.1) & (t <= after_s)
        for mass, attr, colour in MASSES:
            y = getattr(r, attr)
            d = 100 * (y - y[t < 0][-1])
            steady = float(np.mean(d[-max(1, len(d) // 20):]))
            os_exp, os_an, ts_exp, ts_an = steps[key][mass]
            ax.plot(t[shown], d[shown], color=colour, label=mass)
            ax.axhline(steady * (1 + os_an / 100), color=colour, ls=":", lw=1)
            ax.axvline(ts_an, color=colour, ls=":", lw=1)
            ax.plot([ts_exp], [steady], "x", color=colour, ms=7)
            ax.plot([-0.1], [steady * (1 + os_exp / 100)], "x", color=colour, ms=7)
        ax.set_title(f"{key[0]} {100 * key[1]:+.2f} cm", fontsize=9)
        ax.set_xlabel("time from the edge [s]")
        ax.set_ylabel("displacement change [cm]")
        ax.legend(fontsize=7)
    for ax in axes.ravel()[len(kept):]:
        ax.set_visible(False)
    return save_figure(fig, Path(path))


def plot_ride_height(responses, table, path):
    """responses: {damper: FrequencyResponse}; table: {damper: {amplitude m: (peak change
    cm, its frequency Hz)}} (Table 6.6), drawn as stars on our curves."""
    fig, axes = plt.subplots(1, len(responses), figsize=(4.4 * len(responses), 3.8), squeeze=False)
    fig.suptitle("Average ride-height change against Table 6.6 (stars: the thesis's peak)")
    for ax, (name, fr) in zip(axes[0], responses.items()):
        for i, A in enumerate(fr.amplitudes):
            line, = ax.plot(fr.freqs, 100 * fr.values["ride_height_change"][i], label=f"{100 * A:.2f} cm")
            cm, hz = table[name][A]
            ax.plot([hz], [cm], "*", ms=11, color=line.get_color())
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("ride-height change [cm]")
        ax.legend(fontsize=7)
    return save_figure(fig, Path(path))
