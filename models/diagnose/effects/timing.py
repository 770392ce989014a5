"""The cell's timing: the channels' alignment within a share of a sample, fitted with the
baseline, and a sensor delay beyond it. Both shift the motion the force answers (s);
their parameters are left to finite differences (a shift moves samples, not a closed form)."""
from __future__ import annotations

import numpy as np

from models.diagnose.forms import fixed, shift
from models.diagnose.spec import Effect, P


# the channels' alignment fitted with the baseline, within this share of a sample period
# either way: a cell in good order (docs/diagnosis.md: wider, it takes a compressible oil's lag)
ALIGNMENT = 0.1
LAG_RESOLVED = 0.02  # of a sample period: a lag shorter than this, its interval reaching zero, is not resolved


# the forms of the catalogue's effects: (model, data, values, Forces, effect id) -> None
def _timing(name):
    """A timing offset's force: the motion shifted by the parameter `name` [s]."""
    def apply(m, d, p, f, e):
        f.tau = p[name]
        if f.tau:  # the force answers the motion tau earlier than stamped
            f.x, f.v, f.a = shift(f.x, f.t, -f.tau), shift(f.v, f.t, -f.tau), shift(f.a, f.t, -f.tau)
    return apply


def _resolved(name):
    """A lag is resolved at LAG_RESOLVED of a sample period or more, or where its interval
    excludes zero."""
    def resolved(d, params, ci):
        lo, hi = ci[name]
        return abs(params[name]) >= LAG_RESOLVED * float(np.median(d.h)) or lo * hi > 0
    return resolved


def _alignment_params(d, e):
    h = float(np.median(d.h))
    return [P("tau_0", 0.0, -ALIGNMENT * h, ALIGNMENT * h, "s")]


EFFECTS = (
    Effect("alignment", "the channels' alignment within half a sample",
           _alignment_params, estimate="tau_0", apply=_timing("tau_0"), resolved=_resolved("tau_0"), acts_on="motion", depends_on=("time",),
           nature="cell", needs="baseline",
           say=("The {late} by {v} {u}: a timing offset of the cell (a filter or transport lag in a sensor's "
                "signal chain, or the channels' clocks), not the damper.", "tau_0", 1e3, "ms"),
    ),
    Effect("sensor_delay", "a timing offset between the displacement and force channels",
           fixed(P("tau", 0.0, -0.05, 0.05, "s", (-2e-2, -2e-3, -2e-4, -2e-5, 0.0, 2e-5, 2e-4, 2e-3, 2e-2))),
           estimate="tau", apply=_timing("tau"), resolved=_resolved("tau"), acts_on="motion", depends_on=("time",), nature="cell",
           supersedes="alignment",
           say=("The {late} by {v} {u}: a timing offset of the cell (a filter or transport lag in a sensor's "
                "signal chain, or the channels' clocks), not the damper. Align the channels (or fix the "
                "conditioning) before fitting valves.", "tau", 1e3, "ms"),
    ),
)
