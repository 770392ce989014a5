"""Damping changing with the oil's temperature (its viscosity and density)."""

from __future__ import annotations

from models.diagnose.forms import fixed, scaled
from models.diagnose.spec import Effect, P


def _damping_temperature(m, d, p, f, e):
    f.Fd = f.Fd * (1 + p["k_dT"] * (d.T - m.T_m))


def _damping_temperature_tangent(m, d, p, f, e, cols, before):
    dT = d.T - m.T_m
    scaled(cols, "Fd", 1 + p["k_dT"] * dT)
    cols["Fd"]["k_dT"] = before["Fd"] * dT


EFFECT = Effect(
    "damping_temperature",
    "damping changing with oil temperature",
    params=fixed(P("k_dT", 0.0, -0.05, 0.05, "1/K")),
    estimate="k_dT",
    apply=_damping_temperature,
    tangent=_damping_temperature_tangent,
    acts_on="parts",
    needs="T",
    depends_on=("temperature", "velocity", "direction"),
    alters=("Fd",),
    referee="damping_drift",
    order=70,
    say=(
        "Damping changes {v} {u} per kelvin as the oil warms: oil viscosity/density. Test at a controlled "
        "temperature or use the temperature-corrected model.",
        "k_dT",
        100.0,
        "%",
    ),
)
