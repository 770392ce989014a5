"""What a virtual plant is built with: its damper, the physics hidden in it, its parameters
and its seed, as one dataclass the cell factories (protocols/cell.py) take field by field;
and the plain cell of plain.toml that `dyno prove` runs."""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from sim_backend.effects import drives, parse
from sim_backend.plant import plant_params


@dataclass
class PlantOptions:
    damper: str | None = None  # a preset name or JSON path; None: the rig's default (koni)
    effects: dict = field(default_factory=dict)  # hidden physics, {name: VALUE, "forms": {...}} (effects.parse)
    params: dict | None = None  # the plant's parameters, if not sim_backend/plant.toml
    seed: int = 0  # the sensors' noise and the adjuster's wander
    T0: float | None = None  # K: the damper's starting temperature, if not the plant's ambient

    def drives(self) -> dict:
        """{channel: what it is} of the channels the hidden physics makes drive the damper
        (the adjuster's current when the damping follows it)."""
        return drives(self.effects)


def plain_cell():
    """(damper name, plant parameters, prove settings) of sim_backend/plain.toml: the
    virtual rig with nothing the minimal model leaves out."""
    plain = tomllib.loads((Path(__file__).parent / "plain.toml").read_text())
    params = plant_params()
    for section in ("frame", "sensors", "thermal", "actuator"):
        params[section].update(plain.get(section, {}))
    return plain["damper"], params, plain["prove"]


def benchmark(name) -> dict:
    """What `dyno bench NAME` hides in the plain cell (plain.toml's [bench.NAME])."""
    return tomllib.loads((Path(__file__).parent / "plain.toml").read_text())["bench"][name]


def plant_options(damper=None, effects=(), plain=False, seed=0, noise=1.0) -> PlantOptions:
    """The virtual plant's options: effects as ["NAME[:FORM]=VALUE", ...] (EffectError names
    a bad one); plain: the plain cell of plain.toml (its damper unless another than the
    default is given); noise: the sensors' noise times this."""
    fx, params = parse(effects), None
    if plain:
        name, params, _ = plain_cell()
        damper = name if damper in (None, "koni") else damper
    if noise != 1.0:
        params = params or plant_params()
        params["sensors"].update({k: v * noise for k, v in params["sensors"].items() if k.endswith("_noise")})
    return PlantOptions(damper, fx, params, seed)
