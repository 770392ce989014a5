"""Compressible oil (entrained air) in series with the valves: the damping force through a
first-order lag whose time constant is the valve's slope times the oil's compliance
(eq 3.32's spring in series)."""

from __future__ import annotations

import numpy as np

from models.diagnose import kernels
from models.diagnose.forms import fixed
from models.diagnose.spec import Effect, P


def _compressibility(m, d, p, f, e):  # the valve in series with the oil's spring
    f.Fd = kernels.lag(f.Fd, f.slope() * p["inv_k_oil"], d.h)


def _compressibility_tangent(m, d, p, f, e, cols, before):
    # the lag's time constant is the slope times the compliance: both move it
    S, inv_k = f.slope(), p["inv_k_oil"]
    dS = m.base.slope_columns(f) if hasattr(m.base, "slope_columns") else {}
    names = list(dict.fromkeys([*cols["Fd"], *dS, "inv_k_oil"]))
    zero = np.zeros(len(S))
    dF = np.array([cols["Fd"].get(k, zero) for k in names])
    dtau = np.array([S if k == "inv_k_oil" else inv_k * dS[k] if k in dS else zero for k in names])
    out = kernels.lag_tangent(before["Fd"], S * inv_k, d.h, f.Fd, dF, dtau)
    cols["Fd"] = dict(zip(names, out))


def _words(step, sample_s):
    """The oil's stiffness [kN/mm], its interval the compliance's inverted."""
    text, name, _, unit = EFFECT.say
    k = 1.0 / max(step.parameters[name], 1e-30)
    lo, hi = (1.0 / max(c, 1e-30) for c in step.ci[name][::-1])
    return text.format(v=f"{k / 1e6:.3g} ({max(lo, 0) / 1e6:.3g} to {hi / 1e6:.3g})", u=unit)


EFFECT = Effect(
    "compressibility",
    "compressible oil (entrained air) in series with the valves",
    params=fixed(P("inv_k_oil", 1e-08, 0.0, 1e-05, "m/N", (0.0, 1e-09, 1e-08, 1e-07, 1e-06))),
    estimate="inv_k_oil",
    apply=_compressibility,
    tangent=_compressibility_tangent,
    acts_on="parts",
    depends_on=("velocity", "frequency"),
    # a damper described with compressible oil or air in it (eq 3.32)
    described=lambda dm: (
        dm.compressibility.beta_inv is None or dm.compressibility.beta_inv < 1e12 or dm.compressibility.air_fraction > 0
    ),
    words=_words,
    listed=40,
    order=80,
    say=(
        "The force lags the valve curve at high speed as if the oil were a spring of {v} {u} in series: "
        "compressible oil (entrained air). Bleed the damper or raise the gas charge.",
        "inv_k_oil",
        None,
        "kN/mm",
    ),
)
