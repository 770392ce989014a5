"""`dyno report A.mcap B.mcap --out DIR`: two runs side by side (before and after a
re-valve, two dampers of a pair, a damper before and after a durability run): both
composites on one plot and the peak forces of the segments both ran, with B's difference."""
from __future__ import annotations

from pathlib import Path


from models.recording import segments
from protocols.io.reader import load_recording
from protocols.reports import peaks
from protocols.reports.page import Page, save
from protocols.reports.plots import plt


def _rows(path):
    ch, events, meta = load_recording(path)
    return peaks.peaks(ch, segments(events), damper=peaks.recorded_damper(meta)), meta


def compare(path_a, path_b, out_dir):
    """Write DIR/index.html comparing B with A; (index, [PNG paths])."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (a, meta_a), (b, meta_b) = _rows(path_a), _rows(path_b)
    page = Page(f"Dyno comparison: {Path(path_a).name} (A) and {Path(path_b).name} (B)")
    for tag, path, meta in (("A", path_a, meta_a), ("B", path_b, meta_b)):
        run = meta.get("run", {})
        page.paragraph(f"{tag}: {Path(path).name}, protocol {meta.get('protocol', {}).get('name', '?')}, started "
                       f"{run.get('wall_start', '?')}" + "".join(f", {k.replace('_', ' ')} {run[k]}"
                                                                   for k in ("operator", "damper_serial", "note")
                                                                   if run.get(k)))
    head, rows = peaks.compare(a, b)
    pngs = []
    if rows:
        page.heading("Peak forces of the segments both ran (difference: B against A)")
        page.table(head, rows)
        fig, ax = plt.subplots(figsize=(7, 5))
        for tag, ps, style in (("A", a, "-"), ("B", b, "--")):
            group = (lambda p: (p.key[0], p.key[2]))  # amplitude, target temperature or None
            for i, (amp, T) in enumerate(sorted({group(p) for p in ps}, key=lambda g: (-g[0], g[1] or 0.0))):
                q = sorted((p for p in ps if group(p) == (amp, T)), key=lambda p: p.v_comp)
                c, name = f"C{i % 10}", f"{tag} {amp:g} mm" + ("" if T is None else f" {T:g} C")
                ax.plot([p.v_comp for p in q], [p.F_comp for p in q], "o" + style, color=c, label=f"{name} compression")
                ax.plot([-p.v_reb for p in q], [-p.F_reb for p in q], "s" + style, color=c, alpha=0.6,
                        label=f"{name} rebound")
        ax.set(title="Composite peak force: A solid, B dashed", xlabel="peak velocity [m/s]",
               ylabel="peak force [N], rebound as magnitude")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        png = save(fig, out / "compare_composite.png")
        page.figure("Composite peak force vs peak velocity, A and B", png)
        pngs.append(out / png)
    else:
        page.paragraph("The two recordings ran no sine segment in common (same amplitude, frequency and "
                       "target temperature): nothing to compare.")
    return page.write(out), pngs
