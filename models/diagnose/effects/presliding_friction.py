"""Pre-sliding friction (Dahl): the seal's friction builds over a little travel after each
reversal, where the baseline's Coulomb law (eq 3.3) switches at once."""

from __future__ import annotations

import numpy as np

from models.diagnose import kernels
from models.diagnose.forms import fixed
from models.diagnose.spec import Effect, P


_dahl = kernels.recent(kernels.dahl)


def _presliding_friction(m, d, p, f, e):
    # the seal deforms before it slides: its friction builds over x_stick of travel after
    # each reversal (Dahl), where the baseline's Coulomb law switches at once (eq 3.3)
    f.Ff = m.base.friction_level(p) * _dahl(f.x, d.t, d.h, p["x_stick"])


def _presliding_friction_tangent(m, d, p, f, e, cols, before):
    # the friction is replaced: its level's derivative times the state, and the state's in x_stick
    xs = p["x_stick"]
    travel = np.abs(np.diff(f.x, prepend=f.x[:1]))
    decay = np.exp(-travel / xs)
    z = _dahl(f.x, d.t, d.h, xs)
    level = m.base.friction_columns(p) if hasattr(m.base, "friction_columns") else {}
    cols["Ff"] = {k: z * g for k, g in level.items()}
    dz = kernels.dahl_tangent(f.x, d.t, d.h, decay, z, decay * travel / xs**2)
    cols["Ff"]["x_stick"] = m.base.friction_level(p) * dz


def _resolved(d, params, ci):
    """A pre-sliding travel is resolved when it is longer than the rod moves in the first
    sample after a reversal: half the reversal's acceleration times the sample period
    squared (the median over segments)."""
    a = [np.max(np.abs(d.a[d.segment == s])) for s in np.unique(d.segment)]
    return params["x_stick"] >= 0.5 * float(np.median(a)) * float(np.median(d.h)) ** 2


EFFECT = Effect(
    "presliding_friction",
    "seal friction that builds over a little travel after each reversal (Dahl)",
    params=fixed(P("x_stick", 0.0001, 1e-09, 0.002, "m", tuple(np.geomspace(1e-08, 0.001, 11)))),
    estimate="x_stick",
    apply=_presliding_friction,
    tangent=_presliding_friction_tangent,
    acts_on="parts",
    depends_on=("displacement", "direction"),
    resolved=_resolved,
    short="pre-sliding friction",
    listed=110,
    order=110,
    say=(
        "Friction builds over {v} {u} of travel after each reversal before the seal slides (pre-sliding, "
        "Dahl): the seal and bushes deform elastically first. It rounds the corners of small-amplitude "
        "loops; keep it in the model when tuning low-speed valving.",
        "x_stick",
        1000.0,
        "mm",
    ),
)
