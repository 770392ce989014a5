"""The catalogue: the physics (and the cell's faults) the minimal baseline may have left
out, one module per effect, each an `Effect` (models/diagnose/spec.py) that owns its
parameters, its force, its derivatives and its words. Adding one: a module here and its
line below (docs/architecture.md)."""

from __future__ import annotations

from models.diagnose.effects import (
    aux_channel,
    bouc_wen,
    breakaway_friction,
    cavitation,
    compressibility,
    damping_temperature,
    fluid_inertia,
    free_play,
    gain_drift,
    gas_temperature,
    position_friction,
    presliding_friction,
    timing,
)

# in the order the rounds try them
CATALOGUE = {
    e.name: e
    for e in (
        *timing.EFFECTS,
        free_play.EFFECT,
        compressibility.EFFECT,
        breakaway_friction.EFFECT,
        position_friction.EFFECT,
        gas_temperature.EFFECT,
        damping_temperature.EFFECT,
        fluid_inertia.EFFECT,
        cavitation.EFFECT,
        presliding_friction.EFFECT,
        bouc_wen.EFFECT,
        aux_channel.EFFECT,
        gain_drift.EFFECT,
    )
}
