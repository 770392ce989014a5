"""A damper's force at one shaft speed over its runs (`dyno runs trend`, the browser view's
trends): the run index's points as a figure."""
from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path

import matplotlib.dates as mdates
import numpy as np

from views.reports.page import save
from views.reports.plots import plt
from protocols.units import Units


FORMATS = ("png", "svg", "pdf")


BAND_PCT = 5.0  # the band drawn about the runs' mean: dyno check's default tolerance


def figure(points, serial, quantity, path, units=Units(), fmt=None):
    """points: [(started ISO, force [N], run id, setup text)]; the PNG (or fmt, one of
    FORMATS) at path (its name). Each point is labelled with its run and setup; the band is
    the runs' mean +- BAND_PCT. Where a run's start is unknown (None: a lab's file without a
    date) the runs stand in the run index's order, never at a made-up date."""
    fig, ax = plt.subplots(figsize=(8, 4.2))
    dated = all(s is not None for s, *_ in points)
    ok = [(datetime.fromisoformat(s) if dated else k + 1, units.show("force", F), i, setup)
          for k, (s, F, i, setup) in enumerate(points) if np.isfinite(F)]
    ax.plot([p[0] for p in ok], [p[1] for p in ok], "o-")
    if ok:
        mean = float(np.mean([p[1] for p in ok]))
        ax.axhspan(mean * (1 - BAND_PCT / 100), mean * (1 + BAND_PCT / 100), color="C2", alpha=0.15,
                   label=f"mean +- {BAND_PCT:g} % (dyno check's default band)")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    for k, (when, F, i, setup) in enumerate(ok):  # staggered: runs minutes apart would overprint
        ax.annotate(f"#{i} {setup}".strip(), (when, F), textcoords="offset points", xytext=(3, 5 + 9 * (k % 3)),
                    fontsize=6)
    if dated and ok and (ok[-1][0] - ok[0][0]).total_seconds() < 600:  # runs of one session: an hour about them
        mid = ok[0][0] + (ok[-1][0] - ok[0][0]) / 2
        ax.set_xlim(mid - timedelta(minutes=30), mid + timedelta(minutes=30))
    if dated:
        locator = mdates.AutoDateLocator(maxticks=6)
        ax.xaxis.set_major_locator(locator)
        ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))
    else:
        ax.xaxis.set_major_locator(plt.MaxNLocator(integer=True))
    ax.margins(x=0.15, y=0.2)
    ax.tick_params(axis="x", labelsize=8)
    ax.set_title(f"{serial}: {quantity}")
    ax.set_ylabel(units.label("force", "force"))
    ax.set_xlabel("run started (UTC)" if dated else "run, in the order indexed (not every run's date is known)")
    ax.grid(alpha=0.3)
    return save(fig, Path(path), fmt=fmt)
