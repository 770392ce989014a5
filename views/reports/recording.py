"""`dyno report FILE.mcap --out DIR [--model M]`: an HTML page with what a damper engineer
expects (docs/report.md): the header, the peak-force table (views/reports/peaks.py,
also peaks.csv), loops and the composite damping-force curve with the model overlaid, peak
force against temperature, gas force and friction from static holds, low-speed loops, a
sweep's temperatures, step responses, and a hardware-in-the-loop run's tracking and car
responses (views/reports/hil.py)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from records.events import STOPS, Findings, NextTest, RunEnd, Skipped, DiscoveryVerdict
from records.data import segments, sign_problem
from records.segmentation import BLOCK_KINDS, cut, division
from records.reader import load_recording
from models.identify.static import static_holds
from views.reports import hil, peaks, sheet, sines, velocity_table as vt
from views.reports.page import Page, save
from views.reports.pdf import first_page_png, write_pdf
from views.reports.plots import plt
from protocols.units import Units, fmt


def report(path, out_dir, model=None, speeds=None, paper="a4", units=Units(), check=None):
    """Write DIR/index.html with its PNGs, peaks.csv and velocity.csv, report.pdf (page 1 the
    test sheet, views/reports/sheet.py; the rest its appendix) and sheet.png; model: a
    damper model to overlay (the run's identified RECORDING.model.json when there is one);
    speeds [m/s]: the velocity table's (default velocities.toml); paper: report.pdf's, a4
    or letter; units: the tables', CSVs' and figures' unit system; check: (verdict
    sentence, what it is against) for the sheet (views/reports/qa.py). (index, [PNG
    paths])."""
    ch, events, meta = load_recording(path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    segs = cut(ch, events)
    full = model if model is not None and getattr(model, "layout", "simplified") != "simplified" else None
    model = peaks.along(model, ch, events, meta)
    rows = peaks.peaks(ch, segs, damper=full or peaks.recorded_damper(meta), model=model)
    figures = (sines.figures(ch, segs, out, rows, model, units) + _static_figures(ch, events, segs, out, units)
               + _low_speed_figures(ch, segs, out, units) + _temperature_figures(ch, segs, out, units)
               + _step_figures(ch, segs, out, units) + hil.figures(ch, events, out, units))
    scattered = [] if rows else peaks.scattered(ch, segs, model)
    if scattered:
        figures.append(sines.stroke_figure(scattered, out, model, units))
    table, how = _velocity_table(rows or scattered, speeds, units)
    if table:
        vt.write_csv(table, out / "velocity.csv", units)
    curve = next(((title, png) for title, png in figures if png == sines.COMPOSITE), None)
    note = " ".join(n for n in (vt.width_note(table), vt.repeats_note(rows)) if n) if table else ""
    facts = sheet.sheet(path, meta, ch, _params(meta.get("protocol", {}).get("params", "")), table, curve,
                        _gas_range(ch, events, segs), check, units, note)
    page = Page(f"Dyno report: {Path(path).name}", facts,
                sheet.document(facts.title, meta.get("run", {}).get("operator") or "dyno"))
    _header(page, meta, events, model)
    if table:
        page.paragraph(f"The sheet's velocity table: force at {how} (also velocity.csv). {note}".rstrip())
    _appendix(page, ch, events, segs, meta, rows, units, out, figures, curve)
    index = page.write(out)
    pdf = write_pdf(page, out, paper=paper)
    first_page_png(pdf, out / "sheet.png")
    return index, [out / png for _, png in figures] + [out / "sheet.png"]


def _gas_range(ch, events, segs):
    """(lowest, highest) gas force over the stroke [N] of the static test's holds (the mean
    of the force held after each stroke direction), None without one."""
    if "force" not in ch or not any(s.kind == "hold" for s in segs):
        return None
    _, up, down = static_holds(ch, events)
    mean = (np.asarray(up) + np.asarray(down)) / 2
    return (float(np.nanmin(mean)), float(np.nanmax(mean))) if np.isfinite(mean).any() else None


def _appendix(page, ch, events, segs, meta, rows, units, out, figures, curve):
    """What follows the sheet: the peak table, steps, HIL measures and the figures (the
    sheet's curve not again)."""
    sign = sign_problem(ch)
    if sign:
        page.paragraph(f"Sign convention: {sign}. The tables and figures below are in the file's convention, "
                       f"not dyno's.")
    found = [s for s in segs if s.params.get("found") == "import"]
    if found and "x" in ch:
        page.paragraph(f"The program, cut into its tests at import (docs/recording.md): {division(found, ch['x'][0][-1])}.")
        blocks = [s for s in found if s.kind in BLOCK_KINDS]
        if any(s.kind == "sine" for s in found) and blocks:
            figures.append(sines.blocks_figure(ch, blocks, out, units))
    if rows:
        peaks.write_csv(rows, out / "peaks.csv", units)
        page.heading("Peak forces per sine segment (also peaks.csv)")
        page.table(*peaks.table(rows, units))
        _peak_notes(page, rows, units, meta.get("protocol", {}).get("name") != "import")
    steps = step_measures(ch, segs)
    if steps:
        page.heading(f"Step response (settled: within {100 * STEP_BAND:g} % of the step)")
        page.table(("segment", "step [mm]", "rise 10-90 % [ms]", "overshoot [%]", "settling [ms]", "peak force [N]"),
                   [(n, f"{s:+g}", *(f"{v:.{p}f}" if np.isfinite(v) else "-" for v, p in ((r, 1), (o, 1), (st, 0))),
                     f"{F:.0f}") for n, s, r, o, st, F in steps])
    if hil.results(events):
        page.heading("Hardware in the loop: measures against the reference (docs/hil.md)")
        page.table(hil.HEADER, hil.table(events))
        page.paragraph(hil.MEANING)
    replayed = hil.replay_table(events)
    if replayed:
        page.heading("Replay: the error of each iteration (docs/hil.md)")
        page.table(hil.REPLAY_HEADER, replayed)
        page.paragraph(hil.REPLAY_MEANING)
    stopped = [e for e in events if isinstance(e, STOPS)]
    if (stopped or not figures) and {"force", "x"} <= set(ch) and len(ch["force"][0]):
        figures.append(_trace_figure(ch, stopped, out, units))  # what happened up to the trip
    for title, png in figures:
        if curve is None or png != curve[1]:
            page.figure(title, png)
    if not figures:
        page.paragraph("No measured segments to plot.")


def _peak_notes(page, rows, units, ours=True):
    """What the peak table's reader needs said: the cycles averaged, peaks short of or over
    the target speed, and a compression peak's force below zero (the force's zero moved)."""
    if not any(np.isfinite(p.T_c) for p in rows):
        page.paragraph(peaks.NO_TEMPERATURE)
    averaged = sorted({p.cycles for p in rows if p.cycles})
    if averaged:
        page.paragraph(f"Peak speeds are those of a sine and its overtones fitted to the measured displacement; "
                       f"forces are read at those instants from the averaged cycle of the settled cycles "
                       f"({averaged[0]}{'' if len(averaged) == 1 else f' to {averaged[-1]}'} per segment).")
    short = [units.segment(p.segment) for p in rows if p.short_pct > peaks.SHORT_PCT]
    if short:
        page.paragraph(f"Short of the target speed 2 pi f A by more than {peaks.SHORT_PCT:g} %: "
                       f"{', '.join(short)}. Their peaks are at the speed reached (the actuator's flow "
                       "or force limit, or the pre-flight's adaptation).")
    low = [p for p in rows if p.v_comp > 0 and p.F_comp < 0]
    if low:  # compressed, a damper pushes back: its damping, gas force and friction are all positive then
        p = min(low, key=lambda p: p.F_comp)
        page.paragraph(f"At {units.segment(p.segment)}'s compression peak ({fmt(units.show('velocity', p.v_comp), 3)} "
                       f"{units.unit('velocity')}) the force reads {fmt(units.show('force', p.F_comp), 3)} "
                       f"{units.unit('force')}: a damper compressed pushes back, so the force reads low by at "
                       f"least as much: a load cell's offset the file kept (raw volts whose zero was not removed?) "
                       f"or its mean removed by the source. `dyno identify` measures it (a gas force below zero) "
                       f"and gives the --offset to import it with.")
    cranks = [p.crank_ratio for p in rows if np.isfinite(p.crank_ratio)]
    if cranks:  # the source's kinematics, read off its stroke
        r = float(np.median(cranks))
        page.paragraph(f"The stroke is a slider crank's: its displacement carries a second harmonic locked to the "
                       f"first as a crank's (crank-to-rod ratio r/l about {r:.2f}), so its peak speed lies "
                       f"{100 * peaks.crank_over(r):.1f} % above 2 pi f A by its geometry.")
    over = [p for p in rows if p.short_pct < -peaks.SHORT_PCT]
    if over:
        crank = [p for p in over if np.isfinite(p.crank_ratio)
                 and -p.short_pct <= 100 * peaks.crank_over(p.crank_ratio) + peaks.SHORT_PCT]
        names = ", ".join(units.segment(p.segment) for p in over if all(p is not q for q in crank))
        if crank:
            page.paragraph(f"Over the target speed 2 pi f A by more than {peaks.SHORT_PCT:g} % as a slider crank's "
                           f"geometry gives: {', '.join(units.segment(p.segment) for p in crank)}.")
        if names and ours:
            page.paragraph(f"Over the target speed 2 pi f A by more than {peaks.SHORT_PCT:g} %: {names}. The rod "
                           "moved faster than asked: an overshooting actuator.")
        elif names:
            page.paragraph(f"Over the target speed 2 pi f A by more than {peaks.SHORT_PCT:g} %: {names}, a test "
                           "imported with its amplitude and frequency estimated from the file: its source's motion "
                           "is no pure sine (the recording does not say how it was driven).")


def _velocity_table(rows, speeds, units):
    """(velocity table or None, how it was read in words): at the standard speeds or, for a
    slow run, at its own; read from the peaks, along the stroke, or from a random input's
    scatter."""
    if not rows:
        return None, ""
    table = vt.velocity_table(rows, speeds, units)
    at = "standard shaft velocities"
    if not vt.has_rows(table) and speeds is None:  # a slow run: at its own speeds
        table = vt.velocity_table(rows, vt.own_speeds(rows), units, "stroke")
        at = "a quarter, half and three quarters of the top speed (no standard speed was reached)"
    if not vt.has_rows(table):
        return None, ""
    how = ("from the peaks" if vt.method(rows) == "peaks" and at.startswith("standard") else
           "the mean of all samples at each speed (the force-velocity scatter's mid-line)"
           if rows[0].segment == peaks.SCATTER else "read along the stroke, both halves of each cycle averaged")
    return table, f"{at}, {how}"


TRACE_POINTS = 20_000  # samples drawn of a whole run's trace (every n-th)


def _trace_figure(ch, stopped, out, units):
    """(title, PNG) of displacement and force against time over the whole recording, each
    trip or stop marked where it came: a run that ended early is still seen."""
    fig, ax = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True)
    for a, (name, q) in zip(ax, (("x", "length"), ("force", "force"))):
        t, y = ch[name]
        k = max(1, len(t) // TRACE_POINTS)
        a.plot(t[::k], units.show(q, y[::k]), lw=0.6)
        a.set(ylabel=units.label("displacement" if name == "x" else "force", q))
        a.grid(alpha=0.3)
        for e in stopped:
            a.axvline(e.t, color="C3", lw=1.0)
    for e in stopped:
        ax[0].annotate(f"{e.kind.replace('_', ' ')}: {e.message}"[:70], (e.t, 1.0),
                       xycoords=("data", "axes fraction"), ha="right", va="bottom", fontsize=7, color="C3")
    ax[1].set(xlabel="time [s]")
    return ("The whole run against time" + (", to where it was stopped" if stopped else ""),
            save(fig, out / "trace.png"))


def _header(page, meta, events, model):
    """Who ran what on which damper and rig, how it ended, and the model overlaid."""
    proto = meta.get("protocol", {})
    damper = json.loads(meta.get("damper", {}).get("model", "{}") or "{}")
    run = meta.get("run", {})
    shown = {**run, "wall_start": str(run.get("wall_start", ""))[:19].replace("T", " ")}  # to the second
    page.paragraph(" · ".join(f"{label}: {shown[k]}" for k, label in (
        ("wall_start", "started (UTC)"), ("operator", "operator"), ("damper_serial", "damper serial"), ("note", "note"))
        if shown.get(k)))
    setup = {k.removeprefix("setup."): v for k, v in run.items() if k.startswith("setup.")}
    if setup:
        page.paragraph("Setup: " + ", ".join(f"{k} {v}" for k, v in setup.items()))
    if run.get("import_notes"):  # what `dyno import` said of the file, for whoever reads the report later
        page.paragraph("What the import said of the file:")
        page.items(tuple(n.split(": ", 1)) if ": " in n else ("import", n) for n in run["import_notes"].split("\n"))
    page.paragraph(f"Protocol {proto.get('name', '?')}, parameters {_params(proto.get('params', ''))}; damper "
                   f"{damper.get('name', 'not named')}; rig {meta.get('rig', {}).get('name', 'not named')}."
                   + (f" Model overlaid: {model.name}." if model is not None else ""))
    ends = [e for e in events if isinstance(e, (*STOPS, RunEnd, Skipped))]
    moved = {prm["adapted_from"] for _, prm, _, _ in segments(events) if "adapted_from" in prm}
    page.items(("adapted" if isinstance(e, Skipped) and e.segment in moved else e.kind,
                f"{e.segment} {e.message}") for e in ends)
    live = [e for e in events if isinstance(e, Findings) and e.live]
    if live:  # dyno run --diagnose (protocols/live_diagnose.py)
        page.paragraph("Diagnosed while the run went on, each sine segment against the damper's model refitted:")
        page.items((e.segment, " ".join(e.params.get("findings", []))) for e in live)
    rounds = [e for e in events if isinstance(e, (Findings, NextTest, DiscoveryVerdict)) and e not in live]
    if rounds:  # dyno run discover (protocols/discover.py)
        page.paragraph("The dyno's own next tests: after each diagnosis, what it named and was unsure of, what "
                       "the following data settled, and each sine it ran next with why.")
        page.items(_round_item(e) for e in rounds)


def _params(text):
    """A protocol's parameters as a reader writes them: 'amplitudes_mm 12.7, 6.4; freqs_hz 1, 4'."""
    try:
        params = json.loads(text or "{}")
    except ValueError:
        return text
    if not isinstance(params, dict):
        return text
    return "; ".join(f"{k} {', '.join(map(str, v)) if isinstance(v, list) else v}" for k, v in params.items()
                     if v not in ("", [], None))  # an option not given is not a field


def _round_item(e):
    """(label, text) of a discovery event."""
    p = e.params
    if isinstance(e, NextTest):
        return f"round {p.get('round', '?')}: ran {e.segment}", e.message
    if isinstance(e, DiscoveryVerdict):
        return "verdict", e.message
    said = [*(f"unsure: {u}" for u in p.get("unsure", [])), *(f"settled: {s}" for s in p.get("settled", []))]
    return f"round {p.get('round', '?')}: diagnosis", "; ".join([e.message, *said])


STEP_BAND = 0.02  # settled: within 2 % of the step of its target, to stay


def _step_origin(ch, t0):
    """Where the damper was when a step began at t0 [m]; nan when the displacement's record
    begins after it (a wired stream's first frames arrive late)."""
    t, x = ch["x"]
    before = np.nonzero(t < t0)[0]
    if len(before) and t0 - t[before[-1]] < 0.05:
        return float(x[before[-1]])
    after = np.nonzero(t >= t0)[0]
    return float(x[after[0]]) if len(after) and t[after[0]] - t0 < 0.005 else np.nan


def step_measures(ch, segs):
    """[(segment, step [mm], rise 10-90 % [ms], overshoot [%], settling [ms], peak force [N])]
    of the measured step segments: the damper's displacement against its target."""
    rows = []
    for seg in segs:
        name, prm, t0, t1 = seg
        if seg.kind != "step" or "step_mm" not in prm or not {"x", "force"} <= set(ch):
            continue
        t, x = ch["x"]
        k = (t >= t0) & (t <= t1)
        if k.sum() < 10:
            continue
        tk, xk = t[k] - t0, x[k]
        d = prm["step_mm"] / 1e3
        x0 = _step_origin(ch, t0)
        F = peaks.window(ch, ("force",), t0, t1)[1][0]
        peak = float(F[np.argmax(np.abs(F))])
        if not np.isfinite(x0):
            rows.append((name, prm["step_mm"], np.nan, np.nan, np.nan, peak))
            continue
        u = (xk - x0) / d  # 0 at the start, 1 at the target
        up = lambda level: float(tk[np.argmax(u >= level)]) if np.any(u >= level) else float("nan")
        out = np.nonzero(np.abs(u - 1) > STEP_BAND)[0]
        settle = float(tk[out[-1] + 1]) if len(out) and out[-1] + 1 < len(tk) else (0.0 if not len(out) else float("nan"))
        rows.append((name, prm["step_mm"], 1e3 * (up(0.9) - up(0.1)), 100 * max(float(np.max(u)) - 1, 0.0),
                     1e3 * settle, peak))
    return rows


def _step_figures(ch, segs, out, units=Units()):
    """Displacement and force against time from each step's start."""
    steps = [s for s in segs if s.kind == "step" and "step_mm" in s.params]
    if not steps or not {"x", "force"} <= set(ch):
        return []
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    for i, (name, _prm, t0, t1) in enumerate(steps):
        _, (F, x) = peaks.window(ch, ("force", "x"), t0, t1)
        tt = ch["force"][0][(ch["force"][0] >= t0) & (ch["force"][0] <= t1)] - t0
        n = min(len(tt), len(x))
        x0 = _step_origin(ch, t0)
        if np.isfinite(x0):
            ax[0].plot(1e3 * tt[:n], units.show("length", x[:n] - x0), lw=0.9, color=f"C{i % 10}", label=name)
        ax[1].plot(1e3 * tt[:n], units.show("force", F[:n]), lw=0.9, color=f"C{i % 10}", label=name)
    ax[0].set(title="Displacement from the step's start", xlabel="time [ms]",
              ylabel=units.label("displacement", "length"))
    ax[1].set(title="Force", xlabel="time [ms]", ylabel=units.label("force", "force"))
    settled = [r[4] for r in step_measures(ch, steps) if np.isfinite(r[4])]
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
        a.set_xlim(0, max(100.0, 5 * max(settled, default=20.0)))  # the response, not the whole hold
    return [("Step responses (compression positive)", save(fig, out / "steps.png"))]


def _static_figures(ch, events, segs, out, units=Units()):
    """Force at rest after each stroke direction, and the friction, of the static holds."""
    figures = []
    holds = [s for s in segs if s.kind == "hold"]
    if holds and "force" in ch:
        x_at, up, down = static_holds(ch, events)
        xs, up, down = units.show("length", x_at), units.show("force", up), units.show("force", down)
        fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
        ax[0].plot(xs, up, "^-", label="held after a compression stroke")
        ax[0].plot(xs, down, "v-", label="held after an extension stroke")
        ax[0].plot(xs, (up + down) / 2, "k.-", label="gas force (mean)")
        ax[0].set(title="Static test: force at rest", xlabel=units.label("displacement", "length"),
                  ylabel=units.label("force", "force"))
        ax[1].plot(xs, (up - down) / 2, "o-")
        ax[1].set(title="Static friction (half the difference)", xlabel=units.label("displacement", "length"),
                  ylabel=units.label("friction", "force"))
        for a in ax:
            a.grid(alpha=0.3)
        ax[0].legend(fontsize=8)
        figures.append(("Gas force and friction from the static test", save(fig, out / "static.png")))
    return figures


def _low_speed_figures(ch, segs, out, units=Units()):
    """The low-speed loops."""
    figures = []
    slow = [s for s in segs if s.kind == "low-speed"]
    if slow and "force" in ch:
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        for name, _prm, t0, t1 in slow:
            _, (F, x) = peaks.window(ch, ("force", "x"), t0, t1)
            n = len(F)
            ax.plot(units.show("length", x[:n]), units.show("force", F[:n]), lw=0.8, label=name)
        ax.set(title="Low-speed loops: gas force with friction", xlabel=units.label("displacement", "length"),
               ylabel=units.label("force", "force"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        figures.append(("Low-speed test", save(fig, out / "low_speed.png")))
    return figures


def _temperature_figures(ch, segs, out, units=Units()):
    """Force and temperatures over a temperature sweep."""
    figures = []
    if any("target_c" in s[1] for s in segs) and "T_body" in ch:
        fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
        t, F = ch["force"]
        ax[0].plot(t, units.show("force", F), lw=0.3)
        ax[0].set(ylabel=units.label("force", "force"), title="Temperature sweep")
        for key, label in (("T_body", "body"), ("T_reservoir", "reservoir")):
            if key in ch:
                ax[1].plot(ch[key][0], units.show("temperature", ch[key][1]), label=label)
        for _name, prm, t0, t1 in segs:
            if "target_c" in prm:
                ax[1].axvspan(t0, t1, color="C2", alpha=0.3)
        ax[1].set(xlabel="time [s]", ylabel=units.label("temperature", "temperature"))
        for a in ax:
            a.grid(alpha=0.3)
        ax[1].legend(fontsize=8)
        figures.append(("Force and temperature over time (shaded: recorded sines)",
                        save(fig, out / "temperature.png")))
    return figures
