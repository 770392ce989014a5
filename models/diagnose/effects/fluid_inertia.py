"""The oil column's inertia: a force in proportion to the acceleration (kg)."""

from __future__ import annotations

from models.diagnose.forms import fixed
from models.diagnose.spec import Effect, P


def _fluid_inertia(m, d, p, f, e):
    f.F = f.F + p["m_oil"] * f.a


def _fluid_inertia_tangent(m, d, p, f, e, cols, before):
    cols["F"]["m_oil"] = f.a


EFFECT = Effect(
    "fluid_inertia",
    "inertia of the oil column accelerated through the valves",
    params=fixed(P("m_oil", 0.0, -20.0, 200.0, "kg", floor=0.0)),
    estimate="m_oil",
    apply=_fluid_inertia,
    tangent=_fluid_inertia_tangent,
    acts_on="total",
    depends_on=("acceleration",),
    listed=90,
    order=140,
    say=(
        "The force carries an acceleration term of {v} {u}: oil column inertia in the valves (or unsupported"
        " mass in the load path). It matters in step and high-frequency tests.",
        "m_oil",
        1.0,
        "kg",
    ),
)
