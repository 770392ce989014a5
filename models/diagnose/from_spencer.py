"""Baseline from Spencer's MR model (`dyno diagnose --baseline spencer --holdout tail:F`):
what the diagnosis then names is physics beyond Spencer's (docs/mr-damper.md)."""
from __future__ import annotations

import numpy as np

from models.diagnose.data import DiagnoseError
from models.diagnose.forms import shift
from models.diagnose.spec import P

NAME = "spencer"
DV = 1e-3  # m/s: the velocity step of the MR force's slope


class FromSpencer:
    """Spencer's model (models/mr/) identified on the diagnosis's training samples only (a
    time split: it is fitted once, so two folds that each held out the other's cycles would
    both have seen them), then simulated along the recorded motion and the coil's command.
    Refitted where the data allows, as FromModel refits a damper's: a gain on the MR force,
    and the accumulator's force (k1 x + f0) as a level and a gain on its slope with stroke.
    The states run through the recording's gaps (a few samples' settling after each)."""

    def __init__(self, d, folds, progress=lambda s: None):
        from models.mr.identify import identify
        from models.mr.spencer import force
        if len(folds) != 1:
            raise DiagnoseError("--baseline spencer is identified once, on the past of a time split: give "
                                "--holdout tail:F")
        if len(d.aux) != 1:
            raise DiagnoseError(f"--baseline spencer needs one coil command among the aux channels the recording "
                                f"says drive the damper (found: {', '.join(d.aux) or 'none'})")
        self.name = NAME
        coil = next(iter(d.aux.values()))
        progress("identifying Spencer's MR model on the training samples")
        fitted = identify(d.t, d.x, d.v, coil, d.F, holdout=0.0, judged=folds[0][0])
        m, h = fitted.model, float(np.median(d.h))
        self.model = m
        accumulator = m.k1 * d.x + m.f0  # eq 4's k1 (x - x0)
        self.Fd = fitted.force - accumulator
        self.Fg = accumulator
        self.Fg_m = float(np.mean(accumulator))
        up, dn = force(m, d.x, d.v + DV, coil, h), force(m, d.x, d.v - DV, coil, h)
        self.slope = np.abs(up - dn) / (2 * DV)

    def params(self, d):
        Fmax = max(np.percentile(np.abs(d.F), 99), 10.0)
        return [P("k_mr", 1.0, 0.0, 5.0, "-"), P("G0", self.Fg_m, -Fmax, Fmax, "N"), P("k_gas", 1.0, 0.0, 5.0, "-")]

    def friction_level(self, p):
        return 0.0  # Spencer's model has none apart: its yield is the Bouc-Wen element's

    def parts(self, d, p, x, v, tau):
        s = (lambda y: shift(y, d.t, -tau)) if tau else (lambda y: y)
        return (p["k_mr"] * s(self.Fd), p["G0"] + p["k_gas"] * (s(self.Fg) - self.Fg_m), np.zeros(len(d.t)),
                lambda: p["k_mr"] * s(self.slope))
