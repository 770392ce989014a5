"""`dyno identify --report DIR`: an HTML page with measured-versus-model loops for every
segment (held-out ones marked), the held-out errors, the parameter table and, with
--truth, the peak force-velocity curves of the identified and the true damper."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from models.identify import _simulate, nrmse
from models.plots import plt
from protocols.identification import _num
from protocols.report import _save


def _loops(res, segs, title, path):
    n = len(segs)
    cols = min(n, 4)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.2 * rows), squeeze=False)
    for ax, s in zip(axes.flat, segs):
        F = _simulate(res.damper, s)
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
    return _save(fig, path)


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
    return _save(fig, path)


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
    page = ["<!doctype html><meta charset='utf-8'><title>dyno identify</title>",
            "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto}img{max-width:100%}"
            "td,th{padding:2px 8px;text-align:right}td:first-child{text-align:left}</style>",
            f"<h1>Identified model: {html.escape(res.damper.name)}</h1>",
            f"<p>Held-out loop NRMSE {100 * doc['heldout_nrmse']:.2f} % over {len(doc['heldout'])} segments.</p>",
            "<h2>Steps</h2><ul>" + "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>"
                                           for k, v in doc["steps"].items()) + "</ul>"]
    rows = doc.get("parameters") or [{"name": e["name"], "identified": e["value"], "truth": None, "rel_error": None,
                                      "ci_low": e["ci_low"], "ci_high": e["ci_high"], "identifiable": e["identifiable"],
                                      "note": e["note"]} for e in doc["estimates"]]
    page.append("<h2>Parameters</h2><table><tr><th>parameter</th><th>identified</th><th>95 % interval</th>"
                "<th>truth</th><th>error</th><th>note</th></tr>")
    for r in rows:
        ci = "not identifiable" if not r["identifiable"] else f"{_num(r['ci_low'])} .. {_num(r['ci_high'])}"
        err = "" if r["rel_error"] is None else f"{100 * r['rel_error']:+.1f} %"
        page.append(f"<tr><td>{html.escape(r['name'])}</td><td>{_num(r['identified'])}</td><td>{ci}</td>"
                    f"<td>{_num(r['truth']) if r['truth'] is not None else ''}</td><td>{err}</td>"
                    f"<td>{html.escape(r.get('note') or '')}</td></tr>")
    page.append("</table>")
    if doc["correlated"]:
        page.append("<p>Strongly correlated: " + ", ".join(f"{html.escape(c['a'])} / {html.escape(c['b'])} "
                                                          f"({c['rho']:+.2f})" for c in doc["correlated"]) + "</p>")
    for title, png in figs:
        page.append(f"<h2>{html.escape(title)}</h2><img src='{png}' alt='{html.escape(title)}'>")
    index = out / "index.html"
    index.write_text("\n".join(page))
    return index
