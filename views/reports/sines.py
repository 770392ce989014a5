"""A sine run's figures in the report (views/reports/recording.py): the loops per
amplitude with the model's force dashed, the composite curve (peak force against peak
velocity), a one-speed run's curve along its stroke, and peak force against temperature.
A recording of many amplitudes (a chirp, another dyno's sweep) shares panels and series
among neighbouring amplitudes rather than drawing one each."""
from __future__ import annotations

import numpy as np

from views.reports import peaks, velocity_table as vt
from views.reports.page import save
from views.reports.plots import plt
from protocols.units import Units, amplitude


COMPOSITE = "composite.png"  # the force-velocity curve: the test sheet's figure
# the markers' meaning, as legend entries of their own (a reader of a printed sheet has no caption to ask)
DIRECTIONS = (("o", "-", "compression"), ("s", "--", "rebound (magnitude)"))  # (marker, line style, meaning)
# the sheet's curve: drawn at about the size it is printed (115 mm wide), its text at 8 pt and more there
SHEET_FIGURE_IN, SHEET_TEXT_PT, SHEET_DPI = (4.4, 4.1), 8.0, 200
SHEET_RC = {"font.size": SHEET_TEXT_PT, "axes.titlesize": SHEET_TEXT_PT + 1, "legend.fontsize": SHEET_TEXT_PT}
MOST_PANELS = 8  # amplitudes drawn apart; beyond, neighbours share a panel and a composite series
COLUMNS = 4  # panels a row holds once more than WRAP_AFTER of them wrap
WRAP_AFTER = 6


def panels(amps, most=MOST_PANELS):
    """The amplitudes [mm], largest first, as at most `most` groups of neighbours: each its
    own up to `most` of them (a sine matrix), else runs of neighbours (a chirp's amplitude
    drifts from segment to segment: 32 panels of one segment each did not read)."""
    amps = sorted(set(amps), reverse=True)
    return [g.tolist() for g in np.array_split(amps, min(len(amps), most))] if amps else []


def title(units, group):
    """A panel's amplitudes as shown: '12.7 mm', or a group's range '0.675-0.731 mm'."""
    if len(group) == 1:
        return amplitude(units, group[0])
    return f"{units.show('length', group[-1] * 1e-3):.3g}-{amplitude(units, group[0])}"


def figures(ch, segs, out, rows, model=None, units=Units()):
    """Loops per amplitude (with the model's force along the same motion, dashed) and the
    composite curve: per amplitude and temperature, peak damping force (measured less gas
    and friction, when a full damper model is known) against peak velocity."""
    sine = peaks.sines(segs)
    if not sine or not rows:
        return []
    groups = panels(s[1]["amplitude_mm"] for s in sine)
    figures = [("Force-velocity and force-displacement loops (compression positive)",
                _loops(ch, sine, groups, out, model, units))]
    if vt.method(rows) == "stroke":  # one speed: a composite would be two points
        return figures + [stroke_figure(rows, out, model, units)] + force_temperature_figure(rows, out, units)
    figures.append(("Force against shaft speed: each test's peak force at its peak speed (the composite)",
                    _composite(rows, groups, out, model, units)))
    return figures + force_temperature_figure(rows, out, units)


def _loops(ch, sine, groups, out, model, units):
    """loops.png: per group of amplitudes a force-velocity panel over a force-displacement
    one; more than WRAP_AFTER groups wrap in rows of COLUMNS."""
    V, F_, X = (lambda si, q=q: units.show(q, si) for q in ("velocity", "force", "length"))
    cols = len(groups) if len(groups) <= WRAP_AFTER else COLUMNS
    rows = -(-len(groups) // cols)
    fig, axes = plt.subplots(2 * rows, cols, figsize=(4.5 * cols, 8 * rows), squeeze=False)
    for j, group in enumerate(groups):
        ax_v, ax_x = axes[2 * (j // cols), j % cols], axes[2 * (j // cols) + 1, j % cols]
        panel = [s for s in sine if s[1]["amplitude_mm"] in group]
        labels = [f"{prm['freq_hz']:g} Hz" + (f", {prm['amplitude_mm']:.3g} mm" if len(group) > 1 else "")
                  + (f", {prm['target_c']:g} C" if "target_c" in prm else "") for _, prm, _, _ in panel]
        for i, (name, prm, t0, t1) in enumerate(panel):
            t, (F, x, v) = peaks.window(ch, ("force", "x", "v"), t0, t1)
            if len(F) < 10:
                continue
            label = labels[i] if labels.count(labels[i]) == 1 else name  # a repeated test: its own name
            c = f"C{i % 10}"
            ax_v.plot(V(v), F_(F), lw=0.8, color=c, label=label)
            ax_x.plot(X(x), F_(F), lw=0.8, color=c, label=label)
            if model is not None:
                Fm = peaks.simulate_segment(model, t, x, v,
                                            peaks.model_temperature(peaks.segment_temperature(ch, t0, t1))).force
                k = t >= t[0] + peaks.settled_after(prm)
                ax_v.plot(V(v[k]), F_(Fm[k]), "--", lw=0.8, color=c, alpha=0.8)
                ax_x.plot(X(x[k]), F_(Fm[k]), "--", lw=0.8, color=c, alpha=0.8)
        ax_v.set(title=f"{title(units, group)}: force vs velocity", xlabel=units.label("velocity", "velocity"),
                 ylabel=units.label("force", "force"))
        ax_x.set(title=f"{title(units, group)}: force vs displacement",
                 xlabel=units.label("displacement", "length"), ylabel=units.label("force", "force"))
        for ax in (ax_v, ax_x):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, title="dashed: model" if model is not None else None, title_fontsize=7)
    for j in range(len(groups), rows * cols):  # the last row's empty places
        axes[2 * (j // cols), j % cols].set_visible(False)
        axes[2 * (j // cols) + 1, j % cols].set_visible(False)
    return save(fig, out / "loops.png")


def _composite(rows, groups, out, model, units):
    """composite.png: per group of amplitudes and temperature, peak (damping) force against
    peak velocity, compression and rebound, the model's crosses beside."""
    with plt.rc_context(SHEET_RC):  # the sheet's figure: its text at 8 pt as printed
        V, F_ = (lambda si, q=q: units.show(q, si) for q in ("velocity", "force"))
        damping = all(np.isfinite(p.Fd_comp) for p in rows)
        fig, ax = plt.subplots(figsize=SHEET_FIGURE_IN)
        series = {}
        for p in rows:
            j = next((j for j, g in enumerate(groups) if p.amplitude_mm in g), len(groups))
            series.setdefault((j, p.target_c), []).append(p)
        for (j, T), ps in sorted(series.items(), key=lambda kv: (kv[0][0], np.nan_to_num(kv[0][1]))):
            ps = sorted(ps, key=lambda p: p.v_comp)
            vc, vr = V(np.array([p.v_comp for p in ps])), -V(np.array([p.v_reb for p in ps]))
            Fc = F_(np.array([p.Fd_comp if damping else p.F_comp for p in ps]))
            Fr = -F_(np.array([p.Fd_reb if damping else p.F_reb for p in ps]))
            name = title(units, groups[j]) if j < len(groups) else amplitude(units, ps[0].amplitude_mm)
            label = name + ("" if np.isnan(T) else f", {units.show('temperature', T + 273.15):.3g} "
                                                   f"{units.unit('temperature')}")
            line = ax.plot(vc, Fc, "o-", label=label)[0]  # one entry per amplitude: the markers say the direction
            ax.plot(vr, Fr, "s--", color=line.get_color())
            if model is not None:
                gas = np.array([(p.F_comp - p.Fd_comp) if damping else 0.0 for p in ps])
                gas_r = np.array([(p.F_reb - p.Fd_reb) if damping else 0.0 for p in ps])
                ax.plot(vc, F_(np.array([p.model_comp for p in ps]) - gas), "x", color=line.get_color(), ms=8)
                ax.plot(vr, -F_(np.array([p.model_reb for p in ps]) - gas_r), "x", color=line.get_color(), ms=8)
        what = "damping force" if damping else "peak force"
        ax.set(title=f"{what.capitalize()} against peak shaft velocity" + ("\n(measured - gas - friction)" if damping else ""),
               xlabel=units.label("peak shaft velocity", "velocity"), ylabel=units.label(what, "force"))
        ax.grid(alpha=0.3)
        _direction_legend(ax, model is not None, below=True)
        return save(fig, out / COMPOSITE, dpi=SHEET_DPI)


def _direction_legend(ax, model=False, below=False, markers=True):
    """The series' legend beside the data (below: under it, in columns, as the sheet's narrow
    slot wants it), then what the line styles (and markers) mean (grey: any series)."""
    from matplotlib.lines import Line2D
    keys = [Line2D([], [], color="0.4", marker=m if markers else None, ls=ls, label=label)
            for m, ls, label in DIRECTIONS]
    if model:
        keys.append(Line2D([], [], color="0.4", marker="x", ls="", ms=8, label="model") if markers else
                    Line2D([], [], color="k", ls=":", lw=1, label="model along the same motion"))
    handles, labels = ax.get_legend_handles_labels()
    ax.legend([*handles, *keys], [*labels, *(k.get_label() for k in keys)], fontsize=None if below else 7,
              **({"loc": "upper center", "bbox_to_anchor": (0.5, -0.16), "ncol": 2 if not markers else 3} if below
                 else {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0)}))


def stroke_figure(rows, out, model, units):
    """A one-speed run's curve: the force read along its stroke against shaft speed, per
    direction (rebound as magnitude), the model's along the same motion dashed."""
    with plt.rc_context(SHEET_RC):  # the sheet's figure: its text at 8 pt as printed
        V, F_ = (lambda si, q=q: units.show(q, si) for q in ("velocity", "force"))
        fig, ax = plt.subplots(figsize=SHEET_FIGURE_IN)
        for i, p in enumerate(rows):
            c, r = p.stroke_v > 0, p.stroke_v < 0
            line = ax.plot(V(p.stroke_v[c]), F_(p.stroke_F[c]), "-", color=f"C{i % 10}",
                           label=units.segment(p.segment))[0]  # one entry a segment: the key says the directions
            ax.plot(V(-p.stroke_v[r]), -F_(p.stroke_F[r]), "--", color=line.get_color())
            if model is not None and len(p.model_stroke_F):
                ax.plot(V(p.stroke_v[c]), F_(p.model_stroke_F[c]), ":", color="k", lw=1)
                ax.plot(V(-p.stroke_v[r]), -F_(p.model_stroke_F[r]), ":", color="k", lw=1)
        what = ("Force against shaft speed\n(a random input: the mean force at each speed" if rows[0].segment == peaks.SCATTER
                else "Force along the stroke\n(one speed tested: the loop's mid-line")
        ax.set(title=what + ")", xlabel=units.label("shaft speed", "velocity"),
               ylabel=f"{units.label('force', 'force')}, rebound as magnitude")
        ax.grid(alpha=0.3)
        _direction_legend(ax, model is not None and any(len(p.model_stroke_F) for p in rows), below=True,
                          markers=False)
        return ("Force against shaft speed" + ("" if rows[0].segment == peaks.SCATTER else " along the stroke"),
                save(fig, out / COMPOSITE, dpi=SHEET_DPI))


def force_temperature_figure(rows, out, units=Units()):
    """Peak forces against the measured temperature, per amplitude and frequency run at
    temperatures at least 5 C apart (a temperature sweep, or a sweep and the sine matrix)."""
    groups = {}
    for p in rows:
        groups.setdefault((p.amplitude_mm, p.freq_hz), []).append(p)
    groups = {k: sorted(ps, key=lambda p: p.T_c) for k, ps in groups.items()
              if max(p.T_c for p in ps) - min(p.T_c for p in ps) >= 5.0}
    if not groups:
        return []
    T, F = (lambda si, q=q: units.show(q, si) for q in ("temperature", "force"))
    # the damping force where the gas and friction are known: the total's compression peak
    # rises as the gas warms while the damping falls, which reads the wrong way round
    damping = all(np.isfinite(p.Fd_comp) and np.isfinite(p.Fd_reb) for ps in groups.values() for p in ps)
    comp, reb = ("Fd_comp", "Fd_reb") if damping else ("F_comp", "F_reb")
    what = "damping force" if damping else "peak force"
    fig, ax = plt.subplots(figsize=(7, 5))
    for i, (key, ps) in enumerate(sorted(groups.items())):
        c = f"C{i % 10}"
        Ts = T(np.array([p.T_c for p in ps]) + 273.15)
        ax.plot(Ts, F(np.array([getattr(p, comp) for p in ps])), "o-", color=c,
                label=f"{amplitude(units, key[0])} {key[1]:g} Hz")
        ax.plot(Ts, F(-np.array([getattr(p, reb) for p in ps])), "s--", color=c)
    ax.set(title=f"{what.capitalize()}{'' if damping else ', gas included'} against temperature",
           xlabel=units.label("body temperature", "temperature"), ylabel=units.label(what, "force"))
    ax.grid(alpha=0.3)
    _direction_legend(ax)
    return [(f"{what.capitalize()} against temperature", save(fig, out / "force_temperature.png"))]


def blocks_figure(ch, spans, out, units=Units()):
    """The stretches an imported program holds beside its steady tests (records/segmentation:
    sweeps, ramps, random motion; the diagnosis reads them in blocks), force against velocity
    and against displacement, each sample coloured by the motion's frequency there (a
    sweep's instantaneous one)."""
    from matplotlib import cm, colors
    from records.strokes import frequency
    V, F_, X = (lambda si, q=q: units.show(q, si) for q in ("velocity", "force", "length"))
    got = []
    for s in spans:
        t, (F, x, v) = peaks.window(ch, ("force", "x", "v"), s.t0, s.t1)
        if len(t) > 16:
            got.append((F, x, v, frequency(t, x, s.t0, s.t1)))
    hz = np.concatenate([f for *_, f in got]) if got else np.zeros(0)
    hz = hz[np.isfinite(hz)]
    scale = colors.Normalize(*(np.percentile(hz, [1, 99]) if len(hz) else (0.0, 1.0)))
    fig, (ax_v, ax_x) = plt.subplots(1, 2, figsize=(12, 4.8))
    step = max(1, sum(len(F) for F, *_ in got) // 60_000)  # a point a pixel or so: the picture, not every sample
    for F, x, v, f in got:
        for ax, xv in ((ax_v, V(v)), (ax_x, X(x))):
            ax.scatter(xv[::step], F_(F)[::step], s=1, c=f[::step], cmap="viridis", norm=scale, rasterized=True,
                       plotnonfinite=True)
    ax_v.set(title="force vs velocity", xlabel=units.label("velocity", "velocity"), ylabel=units.label("force", "force"))
    ax_x.set(title="force vs displacement", xlabel=units.label("displacement", "length"),
             ylabel=units.label("force", "force"))
    for ax in (ax_v, ax_x):
        ax.grid(alpha=0.3)
    fig.colorbar(cm.ScalarMappable(scale, "viridis"), ax=ax_x, label="stroke frequency [Hz]")
    kinds = sorted({s.kind for s in spans})
    return (f"Beside the steady tests: {', '.join(kinds)} ({sum(s.t1 - s.t0 for s in spans):.1f} s, read in blocks)",
            save(fig, out / "blocks.png"))

