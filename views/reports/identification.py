"""`dyno identify --report DIR`: an HTML page with measured-versus-model loops for every
segment (held-out ones marked), the held-out errors, the parameter table and, with
--truth, the peak force-velocity curves of the identified and the true damper."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from models.identify import simulate_segment
from models.identify.parameters import bound_sentence
from models.statistics import nrmse
from views.reports.plots import plt
from views.reports.page import Page, number, save


def _loops(res, segs, title, path):
    n = len(segs)
    cols = min(n, 4)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.2 * rows), squeeze=False)
    for ax, s in zip(axes.flat, segs):
        F = simulate_segment(res.damper, s)
        v = s.v[s.score_from:][:len(F)]
        Fm = s.F[s.score_from:][:len(F)]
        ax.plot(v, Fm, lw=0.7, color="0.5", label="measured")
        ax.plot(v, F, lw=1.0, color="C3", label="model")
        ax.set_title(f"{s.name} ({s.T - 273.15:.0f} C): NRMSE {100 * nrmse(F, Fm):.1f} %", fontsize=8)
        ax.set_xlabel("velocity [m/s]", fontsize=8)
        ax.set_ylabel("force [N]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.flat[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title)
    return save(fig, path)


def _curve(doc, path):
    c = doc["curve"]
    v = np.array(c["speeds"])
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for tag, mk, sign in (("compression", "o", 1), ("rebound", "s", -1)):
        ax.plot(v, sign * np.array(c[tag]["truth"]), mk + "-", color="0.4", label=f"{tag}: true damper")
        ax.plot(v, sign * np.array(c[tag]["identified"]), mk + "--", color="C3", label=f"{tag}: identified")
    for (tag, vt), ls in zip(c.get("tested_speed", {}).items(), (":", "-.")):
        ax.axvline(vt, color="0.6", ls=ls, lw=1, label=f"fastest {tag} recorded ({vt:.2f} m/s)")
    ax.set(xscale="log", xlabel="peak velocity [m/s]", ylabel="force less gas force, magnitude [N]",
           title=f"Peak force-velocity at {c['T'] - 273.15:.0f} C: largest error {100 * c['max_rel_error']:.1f} %")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return save(fig, path)


def write(res, doc, out_dir):
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = []
    if res.test:
        figs.append(("Held-out segments (never used for fitting)",
                     _loops(res, res.test, "held-out: measured vs model", out / "heldout.png")))
    if res.train:
        figs.append(("Training segments", _loops(res, res.train, "training: measured vs model", out / "training.png")))
    if "curve" in doc:
        figs.append(("Identified against the true damper", _curve(doc, out / "curve.png")))
    page = Page(f"Identified model: {res.damper.name}")
    page.paragraph(f"Held-out loop NRMSE {100 * doc['heldout_nrmse']:.2f} % over {len(doc['heldout'])} segments.")
    page.heading("Steps")
    page.items(doc["steps"].items())
    rows = doc.get("parameters") or [{"name": e["name"], "identified": e["value"], "truth": None, "rel_error": None,
                                      "ci_low": e["ci_low"], "ci_high": e["ci_high"], "identifiable": e["identifiable"],
                                      "note": e["note"]} for e in doc["estimates"]]
    page.heading("Parameters")
    page.table(("parameter", "identified", "95 % interval", "truth", "error", "note"), [
        (r["name"], number(r["identified"]),
         f"{number(r['ci_low'])} .. {number(r['ci_high'])}" if r["identifiable"] else "not identifiable",
         number(r["truth"]) if r["truth"] is not None else "",
         "" if r["rel_error"] is None else f"{100 * r['rel_error']:+.1f} %", r.get("note") or "") for r in rows])
    for b in doc.get("at_bound", []):  # a fit that ran into its range: said, not shown as measured
        page.paragraph(bound_sentence(b)[0].upper() + bound_sentence(b)[1:] + ".")
    if doc["correlated"]:
        page.paragraph("Strongly correlated: " + ", ".join(f"{c['a']} / {c['b']} ({c['rho']:+.2f})"
                                                          for c in doc["correlated"]))
    for title, png in figs:
        page.figure(title, png)
    return page.write(out)
