"""`dyno report A.mcap B.mcap [C.mcap ...] --out DIR`: runs side by side (before and after a
re-valve, the dampers of a pair, a damper before and after a durability run). Each run is
named by its damper, serial and note; the composite curve shows the same quantity as a
single report's (damping force where every run's damper model is known, else peak force),
one colour per run; the peak forces of the segments each run shares with the first are
tabled with their difference from it, and written to differences.csv."""
from __future__ import annotations

import csv
import json
import string
from pathlib import Path

import numpy as np

from records.data import SAME_TEST_AMPLITUDE, SAME_TEST_FREQUENCY, SAME_TEST_K, near, segments, sign_problem
from records.reader import load_recording
from views.reports import peaks, qa, sheet
from views.reports import velocity_table as vt
from views.reports.page import Page, save
from views.reports.pdf import first_page_png, write_pdf
from views.reports.sines import SHEET_DPI, SHEET_RC
from views.reports.plots import plt
from protocols.units import TOLERANCE, Units, amplitude, fmt

MARKERS = "os^Dv<>p"  # one per amplitude
COMPOSITE = "compare_composite.png"  # the runs' curves overlaid: the comparison sheet's figure


def _run(path):
    """(peaks, metadata, the fastest sine segment's loop (velocity, displacement, force)
    keyed by segment, the sentence saying it is in the other sign convention or None)."""
    ch, events, meta = load_recording(path, peaks.READS)
    segs = segments(events)
    rows = peaks.peaks(ch, segs, damper=peaks.recorded_damper(meta))
    loops = {}
    for name, _, t0, t1 in peaks.sines(segs):
        _, (F, x, v) = peaks.window(ch, ("force", "x", "v"), t0, t1)
        loops[name] = (v, x, F)
    return rows, meta, loops, sign_problem(ch)


def _gas_charges(runs) -> str | None:
    """gas_force.rising's sentence for runs whose setup gives a gas charge (a key starting with
    gas, a number first: --setup gas_psi=150, gas_bar=10), else None."""
    import re
    from records.data import Test
    from records.gas_force import at_turns, cycle_means, difference, rising
    points, tests = [], {}
    for tag, path, _, meta in runs:
        run = meta.get("run", {})
        key = next((k for k in sorted(run) if k.startswith("setup.gas")), None)
        number = re.match(r"\s*([0-9]+(?:\.[0-9]*)?)", str(run.get(key, ""))) if key else None
        if number:
            ch, events, _ = load_recording(path, ("x", "force"))
            (tx, x), (tF, F) = ch["x"], ch["force"]
            points.append((tag, float(number.group(1)), at_turns(tx, x, np.interp(tx, tF, F))))
            tests[tag] = [(Test.of(s.params), cycle_means(tF, F, s.t0, s.t1, s.params["freq_hz"]))
                          for s in peaks.sines(segments(events))]
    # runs of one damper through one motion: the difference of their mean forces is that of their gas forces
    steps, order = [], [tag for tag, _, _ in sorted(points, key=lambda p: p[1])]
    for a, b in zip(order, order[1:]):
        shared = next(((ca, cb) for ta, ca in tests[a] for tb, cb in tests[b] if ta.same(tb)), None)
        if shared:
            steps.append((a, b, *difference(*shared)))
    return rising(points, steps)


def run_name(meta, path) -> str:
    """What a run is called on the page: its damper, serial and note, else its file."""
    damper = json.loads(meta.get("damper", {}).get("model", "{}") or "{}").get("name")
    run = meta.get("run", {})
    parts = [p for p in (damper, run.get("damper_serial"), run.get("note")) if p]
    return " · ".join(parts) or Path(path).name


def shared(p, rows):
    """The row of `rows` that is the same test as Peak p (Test.same), the nearest in
    frequency when several are; None when none is."""
    same = [q for q in rows if p.test.same(q.test)]
    return min(same, key=lambda q: (abs(q.freq_hz - p.freq_hz), abs(q.amplitude_mm - p.amplitude_mm)), default=None)


def differences(ref, others):
    """[(tag, amplitude, freq, target, F comp ref, F comp, diff %, F reb ref, F reb, diff %)]
    of every test a run shares with the first (positive: stronger than the first), in the
    run's order; a test run several times is compared once, its first run with the first's."""
    out = []
    for tag, rows in others:
        seen = []
        for q in rows:
            p = next((p for p in ref if p.test.same(q.test)), None)
            if p is None or any(p is s for s in seen):
                continue
            seen.append(p)
            out.append((tag, p.amplitude_mm, p.freq_hz, p.target_c, p.F_comp, q.F_comp, _pct(q.F_comp, p.F_comp),
                        p.F_reb, q.F_reb, _pct(-q.F_reb, -p.F_reb)))
    return out


def left_out(runs, diffs) -> list[str]:
    """A sentence for each run after the first that shares no test with it, saying why it is
    not in the table (its tests and the first's)."""
    first_tag, _, first_rows, _ = runs[0]
    tests = lambda rows: ", ".join(dict.fromkeys(str(p.test) for p in rows)) or "no sine test"
    in_table = {d[0] for d in diffs}
    return [f"{tag} is not in the table of peak forces: none of its tests ({tests(rows)}) is one of {first_tag}'s "
            f"({tests(first_rows)}; one test: amplitudes within {100 * SAME_TEST_AMPLITUDE:g} %, frequencies "
            f"within {100 * SAME_TEST_FREQUENCY:g} %, target temperatures within {SAME_TEST_K:g} C)"
            for tag, _, rows, _ in runs[1:] if tag not in in_table]


def _pct(b, a):
    return 100 * (b - a) / abs(a) if a else np.nan


def swept(runs) -> tuple[str, list[float]] | None:
    """(the setting, each run's value) where the runs' declared setups (--setup KEY=VALUE)
    differ in exactly one setting, a number in every run: a sweep made on purpose (a coil
    current, a gas charge, clicks); else None."""
    import re
    setups = [{k.removeprefix("setup."): str(v) for k, v in meta.get("run", {}).items() if k.startswith("setup.")}
              for *_, meta in runs]
    differ = [k for k in sorted(set().union(*setups)) if len({s.get(k) for s in setups}) > 1]
    if len(runs) < 2 or len(differ) != 1:
        return None
    numbers = [re.match(r"\s*([-+]?[0-9]+(?:\.[0-9]*)?)", s.get(differ[0], "")) for s in setups]
    return (differ[0], [float(m.group(1)) for m in numbers]) if all(numbers) else None


def compare(paths, out_dir, units=Units(), against=None, tolerance=None):
    """Write DIR/index.html, report.pdf (page 1 the comparison sheet), sheet.png and
    differences.csv comparing every run with the first; each run's verdict against
    `against` (a run, model or table, as `dyno check` takes it), or each after the first
    against the first within tolerance (units.TOLERANCE when None). Runs that sweep a
    declared setting (swept()) are shown as a sweep, the change per unit of the setting,
    and judged only against `against` or a tolerance given. (index, [PNG paths])."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    runs = [(string.ascii_uppercase[i % 26], path, *_run(path)) for i, path in enumerate(paths)]
    loops = {tag: loop for tag, _, _, _, loop, _ in runs}
    signs = {tag: sign for tag, *_, sign in runs}
    runs = [r[:4] for r in runs]
    title = "Dyno comparison: " + ", ".join(f"{tag} {run_name(meta, path)}" for tag, path, _, meta in runs)
    page = Page(title, meta=sheet.document(title))
    for tag, path, _, meta in runs:
        run = meta.get("run", {})
        page.paragraph(f"{tag}: {run_name(meta, path)}; {Path(path).name}, protocol "
                       f"{meta.get('protocol', {}).get('name', '?')}, started {run.get('wall_start', '?')}"
                       + (f", operator {run['operator']}" if run.get("operator") else "")
                       + (f". Sign convention: {signs[tag]}; its forces below are in the file's convention"
                          if signs[tag] else ""))
    gas = _gas_charges(runs)
    if gas:
        page.paragraph(gas)
    first = runs[0]
    diffs = differences(first[2], [(tag, rows) for tag, _, rows, _ in runs[1:]])
    L, F, T = (lambda si, q=q: units.show(q, si) for q in ("length", "force", "temperature"))
    # in the unit system: amplitude [mm] and target [C] as the Peak holds them, forces [N]
    diffs = [(tag, L(a * 1e-3), fr, T(Tc + 273.15), F(c0), F(c), dc, F(r0), F(r), dr)
             for tag, a, fr, Tc, c0, c, dc, r0, r, dr in diffs]
    pngs, curve = [], None  # curve: (title, PNG) of the runs overlaid, the sheet's figure
    for sentence in left_out(runs, diffs) if any(rows for _, _, rows, _ in runs) else ():
        page.paragraph(sentence)
    if diffs:
        with open(out / "differences.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["run", units.column("amplitude", "length"), "freq_Hz", units.column("target_T", "temperature"),
                        *(units.column(n, "force") for n in ("F_comp_first", "F_comp")), "diff_comp_pct",
                        *(units.column(n, "force") for n in ("F_reb_first", "F_reb")), "diff_reb_pct"])
            w.writerows([d if isinstance(d, str) else "" if not np.isfinite(d) else f"{d:.6g}" for d in row]
                        for row in diffs)
        page.heading(f"Peak forces of the segments each run shares with {first[0]} (difference against {first[0]}; "
                     "also differences.csv)")
        lab = units.label
        page.table(("run", lab("amplitude", "length"), "freq [Hz]", lab("target", "temperature"),
                    lab(f"F comp {first[0]}", "force"), lab("F comp", "force"), "diff comp [%]",
                    lab(f"F reb {first[0]}", "force"), lab("F reb", "force"), "diff reb [%]"),
                   [(tag, fmt(a), f"{fr:g}", fmt(Tt), fmt(c0), fmt(c), f"{dc:+.1f}", fmt(r0), fmt(r), f"{dr:+.1f}")
                    for tag, a, fr, Tt, c0, c, dc, r0, r, dr in diffs])
        curve = ("Composite curves, one colour per run", _composite(runs, out, units))
        drawn = _loops(runs, loops, out, units)
        if drawn:
            pngs.append(out / drawn[1])
            page.figure(*drawn)
    elif any(rows for _, _, rows, _ in runs):  # other tests (another dyno's run): the curves still compare
        page.paragraph(f"No run shares a sine segment with {first[0]} (same amplitude, frequency and target "
                       "temperature): the runs are compared by their velocity tables and curves.")
        curve = ("Composite curves, one colour per run (a one-speed run: its force along the stroke)",
                 _composite(runs, out, units))
    else:
        page.paragraph("No run has a sine segment: nothing to compare.")
    sweep = swept(runs)
    judged = against is not None or tolerance is not None or sweep is None
    verdicts = (_verdicts(runs, against, tolerance or TOLERANCE, units) if judged else
                [(tag, f"SWEEP: {sweep[0]} {value:g}", f"no reference: the runs differ in {sweep[0]} on purpose and are "
                  f"shown as the force's change per unit of it (--against or --tolerance judges them)")
                 for (tag, *_), value in zip(runs, sweep[1])])
    page.sheet = sheet.comparison([(tag, path, meta) for tag, path, _, meta in runs], curve,
                                  _speeds_table(runs, units, sweep), verdicts)
    index = page.write(out)
    first_page_png(write_pdf(page, out), out / "sheet.png")  # report.pdf beside it, as a single run's report has
    return index, [*([out / curve[1]] if curve else []), *pngs, out / "sheet.png"]


def _verdicts(runs, against, tolerance, units):
    """[(tag, verdict sentence, what against)] of each run: against `against`, or each after
    the first against the first. A run the check cannot read says why, as its verdict."""
    out = []
    for i, (tag, path, _, _) in enumerate(runs):
        ref = against or (runs[0][1] if i else None)
        if ref is None:
            out.append((tag, "REFERENCE", "the other runs are checked against this one"))
            continue
        try:
            said, what = qa.said(*qa.checked(path, ref, tolerance, units), units)
        except qa.NotComparable as e:  # this run's own: the others still get theirs
            said, what = f"NO VERDICT: {e}", str(Path(ref).name)
        out.append((tag, said, what if against else f"{runs[0][0]} ({what})"))
    return out


def _speeds_table(runs, units, sweep=None):
    """(how read, header, rows) of every run's velocity table at the speeds all reached, read
    the same way (along the stroke when one of them ran one speed, as `dyno check` reads
    them), with each run's difference from the first [%], or, for a sweep (swept()), the
    force's change per unit of the setting (a straight line through the runs); None when no
    speed is shared."""
    how = vt.method(*(rows for _, _, rows, _ in runs))
    tables = [vt.velocity_table(rows, None, units, how) for _, _, rows, _ in runs]
    keep = [i for i in range(len(tables[0])) if all(np.isfinite(t[i].F_comp_N) and np.isfinite(t[i].F_reb_N)
                                                     for t in tables)]
    if not keep:
        speeds = min((vt.own_speeds(rows) for _, _, rows, _ in runs), key=lambda s: s[-1] if s else 0.0)
        tables, how = [vt.velocity_table(rows, speeds, units, "stroke") for _, _, rows, _ in runs], "stroke"
        keep = [i for i in range(len(speeds)) if all(np.isfinite(t[i].F_comp_N) for t in tables)]
    if not keep:
        return None
    F = lambda si: fmt(units.show("force", si))
    head = [units.label("speed", "velocity")]
    for tag, *_ in runs:
        head += [units.label(f"{tag} comp", "force"), units.label(f"{tag} reb", "force")]
    if sweep:
        head += [units.label(f"comp per {sweep[0]}", "force"), units.label(f"reb per {sweep[0]}", "force")]
    else:
        head += [f"{tag} diff comp/reb [%]" for tag, *_ in runs[1:]]
    rows = []
    for i in keep:
        a = tables[0][i]
        row = [f"{units.show('velocity', a.v_m_s):.4g}"] + [F(v) for t in tables for v in (t[i].F_comp_N, t[i].F_reb_N)]
        if sweep:
            row += [f"{units.show('force', np.polyfit(sweep[1], [t[i].F_comp_N for t in tables], 1)[0]):+.3g}",
                    f"{units.show('force', np.polyfit(sweep[1], [t[i].F_reb_N for t in tables], 1)[0]):+.3g}"]
        else:
            row += [f"{_pct(t[i].F_comp_N, a.F_comp_N):+.1f} / {_pct(-t[i].F_reb_N, -a.F_reb_N):+.1f}"
                    for t in tables[1:]]
        rows.append(row)
    # a run whose test repeats differ is read on its first run of the test: said beside how
    repeats = "".join(f"; {tag}: {note.rstrip('.')}" for tag, _, rows, _ in runs if (note := vt.repeats_note(rows)))
    last = (f"; the last columns: the force's change per unit of {sweep[0]}, a straight line through the runs" if sweep
            else "; differences against the first run")
    return ("from the peaks" if how == "peaks" else "along the stroke") + repeats + last, head, rows


def _composite(runs, out, units):
    """The single report's composite for every run: colour per run, solid compression,
    dashed rebound, a marker per amplitude."""
    with plt.rc_context(SHEET_RC):  # the comparison sheet's figure: its text at 8 pt as printed
        damping = all(np.isfinite(p.Fd_comp) for _, _, rows, _ in runs for p in rows)
        amps = []  # one marker per amplitude: estimates of one amplitude (24.4, 24.5 mm) share it
        for a in sorted({p.amplitude_mm for _, _, rows, _ in runs for p in rows}, reverse=True):
            amps += [] if any(near(a, b, SAME_TEST_AMPLITUDE) for b in amps) else [a]
        V, F = (lambda si, q=q: units.show(q, si) for q in ("velocity", "force"))
        fig, ax = plt.subplots(figsize=(6.4, 4.1))
        for i, (tag, path, rows, meta) in enumerate(runs):
            c = f"C{i % 10}"
            for a in amps:
                ps = sorted((p for p in rows if near(p.amplitude_mm, a, SAME_TEST_AMPLITUDE) and np.isnan(p.target_c)),
                            key=lambda p: p.v_comp)
                if not ps:
                    continue
                m = MARKERS[amps.index(a) % len(MARKERS)]
                ax.plot(V([p.v_comp for p in ps]), F([p.Fd_comp if damping else p.F_comp for p in ps]), m + "-",
                        color=c, ms=4)
                ax.plot(V([-p.v_reb for p in ps]), F([-(p.Fd_reb if damping else p.F_reb) for p in ps]), m + "--",
                        color=c, ms=4, alpha=0.8)
            if vt.method(rows) == "stroke":  # one speed: its force along the stroke, not one point
                for p in rows:
                    comp, reb = p.stroke_v > 0, p.stroke_v < 0
                    ax.plot(V(p.stroke_v[comp]), F(p.stroke_F[comp]), "-", color=c, lw=1)
                    ax.plot(V(-p.stroke_v[reb]), F(-p.stroke_F[reb]), "--", color=c, lw=1, alpha=0.8)
            ax.plot([], [], "-", color=c, label=f"{tag}: {run_name(meta, path)}")
        ax.plot([], [], "k-", label="compression")
        ax.plot([], [], "k--", label="rebound (magnitude)")
        for a in amps:
            ax.plot([], [], MARKERS[amps.index(a) % len(MARKERS)], color="k", label=amplitude(units, a))
        what = "damping force (measured - gas - friction)" if damping else "peak force"
        ax.set(title=f"{what.split(' (')[0].capitalize()} against peak shaft velocity",
               xlabel=units.label("peak shaft velocity", "velocity"),
               ylabel=units.label(what, "force"))
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside the curves, not over them
        return save(fig, out / COMPOSITE, dpi=SHEET_DPI)


def _loops(runs, loops, out, units):
    """(title, PNG) of the loops of the fastest segment every run shares with the first,
    overlaid: force against velocity and against displacement, one colour per run; None
    when no segment is in every run."""
    everywhere = [p for p in runs[0][2] if all(shared(p, rows) for _, _, rows, _ in runs[1:])]
    if not everywhere:
        return None
    first = max(everywhere, key=lambda p: p.v_comp)
    V, X, F = (lambda si, q=q: units.show(q, si) for q in ("velocity", "length", "force"))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for i, (tag, path, rows, meta) in enumerate(runs):
        name = shared(first, rows).segment
        if name not in loops[tag]:
            continue
        v, x, f = loops[tag][name]
        # about each run's own mid-stroke: runs set up at other positions overlay
        for ax, along in zip(axes, (V(v), X(x - 0.5 * (np.max(x) + np.min(x))))):
            ax.plot(along, F(f), lw=0.8, color=f"C{i % 10}", label=f"{tag}: {run_name(meta, path)}")
    for ax, (what, label, q) in zip(axes, (("velocity", "velocity", "velocity"),
                                           ("displacement", "displacement from mid-stroke", "length"))):
        ax.set(title=f"{units.segment(first.segment)}: force vs {what}", xlabel=units.label(label, q),
               ylabel=units.label("force", "force"))
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper left")
    return (f"Loops of {units.segment(first.segment)}, the fastest segment every run shares (compression positive)",
            save(fig, out / "compare_loops.png"))
