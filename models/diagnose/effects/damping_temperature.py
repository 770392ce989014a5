"""Damping changing with the oil's temperature (its viscosity and density)."""

from __future__ import annotations

from models.diagnose.forms import fixed, temperature_gain
from models.diagnose.spec import Effect, P


# the oil's viscosity and density with temperature, linearised about the run's mean
_apply, _tangent = temperature_gain("Fd", "k_dT")


EFFECT = Effect(
    "damping_temperature",
    "damping changing with oil temperature",
    params=fixed(P("k_dT", 0.0, -0.05, 0.05, "1/K")),
    estimate="k_dT",
    apply=_apply,
    tangent=_tangent,
    acts_on="parts",
    needs="T",
    depends_on=("temperature", "velocity", "direction"),
    referee="damping_drift",
    listed=80,
    order=70,
    say=(
        "Damping changes {v} {u} per kelvin as the oil warms: oil viscosity/density. Test at a controlled "
        "temperature or use the temperature-corrected model.",
        "k_dT",
        100.0,
        "%",
    ),
)
