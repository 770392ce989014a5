"""The gas force rising with temperature (eq 3.19: the charge's pressure follows it)."""

from __future__ import annotations

from models.diagnose.forms import fixed, scaled
from models.diagnose.spec import Effect, P


def _gas_temperature(m, d, p, f, e):
    f.Fg = f.Fg * (1 + p["k_gT"] * (d.T - m.T_m))


def _gas_temperature_tangent(m, d, p, f, e, cols, before):
    dT = d.T - m.T_m
    scaled(cols, "Fg", 1 + p["k_gT"] * dT)
    cols["Fg"]["k_gT"] = before["Fg"] * dT


EFFECT = Effect(
    "gas_temperature",
    "gas-spring force rising with temperature",
    params=fixed(P("k_gT", 0.0, -0.05, 0.05, "1/K")),
    estimate="k_gT",
    apply=_gas_temperature,
    tangent=_gas_temperature_tangent,
    acts_on="parts",
    needs="T",
    depends_on=("temperature", "displacement"),
    alters=("Fg",),
    referee="drift",
    described=lambda dm: True,  # every damper's gas follows its temperature (eq 3.19)
    order=90,
    say=(
        "The static (gas) force grows {v} {u} per kelvin as the damper warms: the gas charge is heating. "
        "Compare tests at the same temperature or correct the bias.",
        "k_gT",
        100.0,
        "%",
    ),
)
