"""`dyno identify --model spencer --report DIR`: Spencer's MR model against the record it was
fitted to: the held-out stretch's force in time, measured and modelled, with the coil's
command under it; and force against velocity, measured and modelled, per level of the
command (the loops an MR damper is read by), on the held-out stretch."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from views.reports.page import caption, save

LEVELS = 3  # the command's levels drawn apart: its range cut in equal thirds


def write(fitted, t, xd, v, F, judged, folder, name) -> list:
    """The report's PNGs and its page (index.md) in folder; the paths written."""
    folder = Path(folder)
    held = fitted.held
    k = (t >= held.from_s) & judged if held else judged
    fig, (a, b) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, gridspec_kw={"height_ratios": (3, 1)})
    a.plot(t[k], F[k], ".", ms=1.5, color="0.3", label="measured")
    a.plot(t[k], fitted.force[k], ".", ms=1.5, color="tab:red", label="Spencer's model")
    a.set(ylabel="force [N] (compression +)", title=f"{name}: held out from {t[k][0]:.2f} s" if held else name)
    a.legend(fontsize=8, markerscale=6)
    a.grid(alpha=0.3)
    b.plot(t[k], v[k], ".", ms=1.0, color="tab:blue")
    b.set(xlabel="time [s]", ylabel="command [V]")
    b.grid(alpha=0.3)
    out = [folder / save(fig, folder / "mr-heldout.png", dpi=100)]
    lo, hi = float(np.min(v)), float(np.max(v))
    edges = np.linspace(lo, hi, LEVELS + 1)
    fig, axes = plt.subplots(1, LEVELS, figsize=(12, 4), sharey=True)
    for i, ax in enumerate(axes):
        m = k & (v >= edges[i]) & ((v < edges[i + 1]) if i < LEVELS - 1 else (v <= hi))
        ax.plot(xd[m], F[m], ".", ms=1.5, color="0.3", label="measured")
        ax.plot(xd[m], fitted.force[m], ".", ms=1.5, color="tab:red", label="model")
        ax.set(xlabel="velocity [m/s]", title=f"command {edges[i]:.2g}-{edges[i + 1]:.2g} V ({int(m.sum())})")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("force [N]")
    axes[0].legend(fontsize=8, markerscale=6)
    out.append(folder / save(fig, folder / "mr-loops.png", dpi=100))
    page = [f"# Spencer's MR model: {name}", ""]
    if held:
        page += [f"Held out from {held.from_s:.2f} s ({held.samples} samples judged): RMSE {held.rmse:.1f} N, "
                 f"R^2 {held.r2:.4f}; {100 * held.worst_share:.0f} % of the squared error in "
                 f"{held.worst_s[0]:.2f}-{held.worst_s[1]:.2f} s.", ""]
    page += ["| parameter | value | 95 % interval | unit |", "|---|---|---|---|"]
    page += [f"| {e.name} | {e.value:.4g} | " + (f"{e.ci[0]:.4g} .. {e.ci[1]:.4g}" if e.determined else "not determined")
             + f" | {e.unit} |" for e in fitted.estimates]
    for png in out:
        page += ["", f"![{png.name}]({png.name})", "", caption(png)]
    (folder / "index.md").write_text("\n".join(page) + "\n")
    return [*out, folder / "index.md"]
