"""The cell's timing: the channels' alignment within a share of a sample, fitted with the
baseline, and a sensor delay beyond it. Both shift the motion the force answers (s);
their parameters are left to finite differences (a shift moves samples, not a closed form)."""

from __future__ import annotations

import numpy as np

from models.diagnose.forms import fixed, shift_motion
from models.diagnose.result import Step
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
            f.x, f.v, f.a = shift_motion(f.x, f.v, f.a, f.t, -f.tau)

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


def lag_words(step: Step, sample_s: float | None = None) -> str:
    """A timing offset between the channels in words (its values and 95 % interval); under
    one sample period sample_s [s], said as unresolved, never as channels to re-align."""
    text, pname, factor, unit = next(e for e in EFFECTS if e.name == step.effect).say
    v = step.parameters[pname] * factor
    lo, hi = (c * factor for c in step.ci[pname])
    late = "force reading lags the displacement" if v < 0 else "displacement reading lags the force"
    # the size of the lag; an interval across zero starts at zero
    v, lo, hi = abs(v), (0.0 if lo * hi < 0 else min(abs(lo), abs(hi))), max(abs(lo), abs(hi))
    if sample_s and v < sample_s * factor:
        return (f"The {late} by {v:.2g} {unit} ({v / (sample_s * factor):.2g} of a sample period): below one "
                f"sample, unresolved at this rate and no reason to re-align the channels; it may stand for anything "
                f"that shifts the loop a little in time.")
    return text.format(v=f"{v:.3g} ({lo:.3g} to {hi:.3g})", u=unit, late=late)


EFFECTS = (
    Effect(
        "alignment",
        "the channels' alignment within half a sample",
        params=_alignment_params,
        estimate="tau_0",
        apply=_timing("tau_0"),
        acts_on="motion",
        needs="baseline",
        depends_on=("time",),
        nature="cell",
        resolved=_resolved("tau_0"),
        short="the channels' alignment",
        words=lag_words,
        listed=10,
        order=10,
        say=(
            "The {late} by {v} {u}: a timing offset of the cell (a filter or transport lag in a sensor's signal "
            "chain, or the channels' clocks), not the damper.",
            "tau_0",
            1000.0,
            "ms",
        ),
    ),
    Effect(
        "sensor_delay",
        "a timing offset between the displacement and force channels",
        params=fixed(
            P("tau", 0.0, -0.05, 0.05, "s", (-0.02, -0.002, -0.0002, -2e-05, 0.0, 2e-05, 0.0002, 0.002, 0.02))
        ),
        estimate="tau",
        apply=_timing("tau"),
        acts_on="motion",
        depends_on=("time",),
        nature="cell",
        supersedes="alignment",
        resolved=_resolved("tau"),
        short="a timing offset of the cell",
        words=lag_words,
        listed=20,
        order=20,
        say=(
            "The {late} by {v} {u}: a timing offset of the cell (a filter or transport lag in a sensor's signal "
            "chain, or the channels' clocks), not the damper. Align the channels (or fix the conditioning) "
            "before fitting valves.",
            "tau",
            1000.0,
            "ms",
        ),
    ),
)
