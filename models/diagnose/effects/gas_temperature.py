"""The gas force rising with temperature (eq 3.19: the charge's pressure follows it)."""

from __future__ import annotations

from models.diagnose.forms import fixed, temperature_gain
from models.diagnose.spec import Effect, P


# eq 3.19: the charge's pressure, so its force, in proportion to its temperature
_apply, _tangent = temperature_gain("Fg", "k_gT")


EFFECT = Effect(
    "gas_temperature",
    "gas-spring force rising with temperature",
    params=fixed(P("k_gT", 0.0, -0.05, 0.05, "1/K")),
    estimate="k_gT",
    apply=_apply,
    tangent=_tangent,
    acts_on="parts",
    needs="T",
    depends_on=("temperature", "displacement"),
    referee="drift",
    described=lambda dm: True,  # every damper's gas follows its temperature (eq 3.19)
    listed=70,
    order=90,
    say=(
        "The static (gas) force grows {v} {u} per kelvin as the damper warms: the gas charge is heating. "
        "Compare tests at the same temperature or correct the bias.",
        "k_gT",
        100.0,
        "%",
    ),
)
