"""A damper's force at one shaft speed over its runs (`dyno runs trend`, the browser view's
trends): the catalogue's points as a figure."""
from __future__ import annotations

from datetime import datetime
from pathlib import Path

import matplotlib.dates as mdates
import numpy as np

from protocols.reports.page import save
from protocols.reports.plots import plt
from protocols.units import Units


FORMATS = ("png", "svg", "pdf")


def figure(points, serial, quantity, path, units=Units(), fmt=None):
    """points: [(started ISO, force [N], run id)]; the PNG (or fmt, one of FORMATS) at path
    (its name)."""
    fig, ax = plt.subplots(figsize=(7, 3.8))
    ok = [(datetime.fromisoformat(s), F) for s, F, _ in points if np.isfinite(F)]
    ax.plot([s for s, _ in ok], [units.show("force", F) for _, F in ok], "o-")
    locator = mdates.AutoDateLocator()
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))
    ax.margins(x=0.1)
    ax.tick_params(axis="x", labelsize=7)
    ax.set_title(f"{serial}: {quantity}")
    ax.set_ylabel(units.label("force", "force"))
    ax.set_xlabel("run started (UTC)")
    ax.grid(alpha=0.3)
    return save(fig, Path(path), fmt=fmt)
