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


EFFECT = Effect("compressibility", "compressible oil (entrained air) in series with the valves",
       fixed(P("inv_k_oil", 1e-8, 0.0, 1e-5, "m/N", (0.0, 1e-9, 1e-8, 1e-7, 1e-6))),
       estimate="inv_k_oil", apply=_compressibility, tangent=_compressibility_tangent, acts_on="parts", depends_on=("velocity", "frequency"),
       alters=("Fd",),
       described=lambda dm: (dm.compressibility.beta_inv is None or dm.compressibility.beta_inv < 1e12  # eq 3.32
                             or dm.compressibility.air_fraction > 0),
       say=("The force lags the valve curve at high speed as if the oil were a spring of {v} {u} in "
            "series: compressible oil (entrained air). Bleed the damper or raise the gas charge.",
            "inv_k_oil", None, "kN/mm"),
)
