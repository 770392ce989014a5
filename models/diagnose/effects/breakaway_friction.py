"""Seal friction higher at breakaway than when sliding (Stribeck's curve, section 3.2.1)."""

from __future__ import annotations

import numpy as np

from models.diagnose.forms import fixed, scaled
from models.diagnose.spec import Effect, P


def _breakaway_friction(m, d, p, f, e):
    # the seal grips harder near rest, falling to sliding friction with speed (the
    # thesis's friction falls with velocity, section 3.2.1); Stribeck's curve with its
    # exponent free: 1 exponential, 2 Gaussian, between and beyond as the seal shows
    f.Ff = f.Ff * (1 + (p["r_break"] - 1) * np.exp(-((np.abs(f.v) / p["v_break"]) ** p["d_break"])))


def _breakaway_friction_tangent(m, d, p, f, e, cols, before):
    r, vb, n = p["r_break"], p["v_break"], p["d_break"]
    u = np.abs(f.v) / vb
    un = u**n
    E = np.exp(-un)
    scaled(cols, "Ff", 1 + (r - 1) * E)
    Ff = before["Ff"]
    cols["Ff"].update(
        {
            "r_break": Ff * E,
            "v_break": Ff * (r - 1) * E * n * un / vb,
            "d_break": -Ff * (r - 1) * E * un * np.log(np.where(u > 0, u, 1.0)),
        }
    )


EFFECT = Effect(
    "breakaway_friction",
    "seal friction higher at breakaway than when sliding",
    params=fixed(
        P("r_break", 1.2, 1.0, 5.0, "-"),
        P("v_break", 0.005, 0.0002, 0.1, "m/s", tuple(np.geomspace(0.0005, 0.05, 7))),
        P("d_break", 1.0, 0.5, 3.0, "-", (1.0, 2.0)),
    ),
    estimate="r_break",
    apply=_breakaway_friction,
    tangent=_breakaway_friction_tangent,
    acts_on="parts",
    depends_on=("velocity", "direction"),
    listed=50,
    order=130,
    say=(
        "Friction is higher just after each velocity reversal, static/dynamic ratio {v}: seal breakaway. It "
        "sets the force near zero velocity; check seal and rod finish.",
        "r_break",
        1.0,
        "",
    ),
)
