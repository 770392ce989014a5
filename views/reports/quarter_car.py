"""Quarter-car plots (thesis Figs 6.1-6.45 in kind), written as PNG.

Frequency responses in the thesis's terms; step responses of both masses; the
parametric study as the change against the baseline; simplified against comprehensive.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from views.reports.page import save
from views.reports.plots import plt

# (metric, axis label, scale) of the frequency-response panels
PANELS = (
    ("rms_ratio_sprung", "sprung rms velocity ratio", 1.0),
    ("rms_ratio_unsprung", "unsprung rms velocity ratio", 1.0),
    ("peak_v_sprung", "sprung peak velocity [m/s]", 1.0),
    ("peak_v_unsprung", "unsprung peak velocity [m/s]", 1.0),
    ("peak_damper_v", "damper peak velocity [m/s]", 1.0),
    ("ride_height_change", "average ride-height change [cm]", 100.0),
    ("lift_off_fraction", "normalised tire lift-off [-]", 1.0),
    ("min_tire_load_ratio", "minimum tire load / static [-]", 1.0),
)
PAIRS = {"peak_v_sprung": ("peak_v_sprung_up", "peak_v_sprung_down"),
         "peak_v_unsprung": ("peak_v_unsprung_up", "peak_v_unsprung_down"),
         "peak_damper_v": ("peak_damper_v_compression", "peak_damper_v_rebound")}


def _grid(title, n=len(PANELS)):
    cols = 4
    fig, axes = plt.subplots((n + cols - 1) // cols, cols, figsize=(4.2 * cols, 3.4 * ((n + cols - 1) // cols)),
                             squeeze=False)
    fig.suptitle(title)
    return fig, axes.ravel()


def save_figure(fig, path):
    """Grid on every axis, saved through the page's checks; the path back."""
    for ax in fig.axes:
        ax.grid(alpha=0.3)
    save(fig, Path(path))
    return Path(path)


def plot_frequency_response(fr, path):
    """All metrics against frequency, one line per amplitude (Figs 6.11-6.23)."""
    fig, axes = _grid(f"Quarter car '{fr.car}' with {fr.damper} at {fr.T - 273.15:.0f} C: harmonic road input")
    for ax, (metric, label, scale) in zip(axes, PANELS):
        for i, A in enumerate(fr.amplitudes):
            color = f"C{i}"
            if metric in PAIRS:
                up, down = PAIRS[metric]
                ax.plot(fr.freqs, fr.values[up][i], color=color, label=f"{A * 100:.2f} cm up/comp.")
                ax.plot(fr.freqs, fr.values[down][i], color=color, ls="--", label=f"{A * 100:.2f} cm down/reb.")
            else:
                ax.plot(fr.freqs, scale * fr.values[metric][i], color=color, marker=".", ms=3,
                        label=f"{A * 100:.2f} cm")
        ax.set_xlabel("excitation frequency [Hz]")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    stops = fr.values["stop_fraction"]
    if np.any(stops > 0):
        k = np.nonzero(stops.max(axis=0) > 0)[0]
        axes[5].set_title(f"damper on its stops {fr.freqs[k[0]]:.2f}-{fr.freqs[k[-1]]:.2f} Hz", fontsize=9,
                          color="C3")
    return save_figure(fig, path)


def plot_steps(steps, path, title):
    """steps: list of (amplitude m, QuarterCarResult, metrics): displacements of both
    masses against time (Figs 6.1-6.10)."""
    fig, axes = plt.subplots(1, len(steps), figsize=(4.6 * len(steps), 3.8), squeeze=False)
    fig.suptitle(title)
    for ax, (A, r, m) in zip(axes[0], steps):
        ax.plot(r.t, 100 * r.y_in, color="0.5", lw=1, label="road")
        ax.plot(r.t, 100 * r.y1, label=f"sprung: {m['overshoot_sprung']:.0f} %, {m['settling_sprung']:.3f} s")
        ax.plot(r.t, 100 * r.y2, label=f"unsprung: {m['overshoot_unsprung']:.0f} %, {m['settling_unsprung']:.3f} s")
        ax.set_xlim(0, min(r.t[-1], 1.0 if abs(A) < 0.03 else 1.5))
        ax.set_title(f"{A * 100:+.2f} cm step (overshoot, settling)", fontsize=9)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("displacement from static [cm]")
        ax.legend(fontsize=7)
    return save_figure(fig, path)


def plot_parametric(study, out_dir, damper_name):
    """One figure per varied property: ride height, minimum tire load, lift-off and the
    sprung rms velocity ratio normalised by the baseline's (Figs 6.24-6.43)."""
    out_dir = Path(out_dir)
    base = study["baseline"]
    groups = {}
    for label in study:
        if label != "baseline":
            groups.setdefault(label.rsplit(" ", 1)[0], []).append(label)
    written = []
    panels = (("ride_height_change", "average ride height vs baseline static [cm]", 100.0),
              ("min_tire_load_ratio", "minimum tire load / static [-]", 1.0),
              ("lift_off_fraction", "normalised tire lift-off [-]", 1.0),
              ("rms_norm", "sprung rms velocity ratio / baseline [-]", 1.0))
    for group, labels in groups.items():
        fig, axes = plt.subplots(len(base.amplitudes), len(panels), figsize=(17, 3.4 * len(base.amplitudes)),
                                 squeeze=False)
        fig.suptitle(f"{damper_name} on quarter car '{base.car}': influence of {group}")
        for i, A in enumerate(base.amplitudes):
            for ax, (metric, label, scale) in zip(axes[i], panels):
                for j, lab in enumerate(["baseline"] + labels):
                    fr = study[lab]
                    if metric == "rms_norm":
                        y = fr.values["rms_ratio_sprung"][i] / base.values["rms_ratio_sprung"][i]
                    elif metric == "ride_height_change":
                        y = scale * (fr.values[metric][i] + fr.static_offset)
                    else:
                        y = scale * fr.values[metric][i]
                    ax.plot(fr.freqs, y, color="k" if lab == "baseline" else f"C{j}",
                            label=lab.replace(group + " ", "") if lab != "baseline" else "baseline")
                ax.set_title(f"{A * 100:.2f} cm", fontsize=9)
                ax.set_xlabel("excitation frequency [Hz]")
                ax.set_ylabel(label)
                ax.legend(fontsize=7)
        written.append(save_figure(fig, out_dir / f"parametric-{group.replace(' ', '-')}.png"))
    return written


def plot_simplified(res, path):
    """Simplified models I and II against the comprehensive model (Fig 6.45)."""
    panels = (("ride_height_change", "average ride-height change [cm]", 100.0),
              ("rms_ratio_sprung", "sprung rms velocity ratio", 1.0),
              ("rms_ratio_unsprung", "unsprung rms velocity ratio", 1.0),
              ("min_tire_load_ratio", "minimum tire load / static [-]", 1.0))
    first = next(iter(res.values()))
    fig, axes = plt.subplots(1, len(panels), figsize=(17, 3.8))
    fig.suptitle(f"Simplified damper models against the comprehensive model, quarter car '{first.car}', "
                 f"{first.amplitudes[0] * 100:.2f} cm")
    for ax, (metric, label, scale) in zip(axes, panels):
        for name, fr in res.items():
            ax.plot(fr.freqs, scale * fr.values[metric][0], label=name)
        ax.set_xlabel("excitation frequency [Hz]")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    return save_figure(fig, path)
