"""The load cell's gain drifting over the run (its bridge's excitation, its amplifier, the
cell warming): the force read is the damper's times 1 + k_gain u(t), u the time from the
middle of the fitted stretch over its length (-1/2 to 1/2), so k_gain [-] is the change
over that stretch. A fault of the cell, not the damper: zero drift's multiplicative twin
(the open term `drift` adds; this scales everything the load cell reads)."""

from __future__ import annotations


from models.diagnose import terms
from models.diagnose.forms import fixed, scaled
from models.diagnose.spec import Effect, P


def _u(m, d, e):
    """u(t) [-] on d's samples, over the span of the data the model was built on."""

    def make(ref, dd):
        lo, hi = terms.t_span(ref)
        return (dd.t - 0.5 * (lo + hi)) / max(hi - lo, 1e-9)

    return terms.cached(m, d, e, make)


def _gain_drift(m, d, p, f, e):
    f.F = f.F * (1.0 + p["k_gain"] * _u(m, d, e))


def _gain_drift_tangent(m, d, p, f, e, cols, before):
    u = _u(m, d, e)
    scaled(cols, "F", 1.0 + p["k_gain"] * u)
    cols["F"]["k_gain"] = before["F"] * u


EFFECT = Effect(
    "gain_drift",
    "the load cell's gain drifting over the run",
    params=fixed(P("k_gain", 0.0, -0.5, 0.5, "-", (-0.05, 0.0, 0.05))),
    estimate="k_gain",
    apply=_gain_drift,
    tangent=_gain_drift_tangent,
    acts_on="total",
    depends_on=("time",),
    nature="cell",
    listed=140,
    order=230,
    say=(
        "The force's scale changes {v} {u} over the run, the same at every speed and stroke: the load cell's"
        " gain drifting (its bridge excitation, its amplifier, the cell warming), not the damper. Check the "
        "load cell's calibration before and after a run.",
        "k_gain",
        100.0,
        "%",
    ),
)
