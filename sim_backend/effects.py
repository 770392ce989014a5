"""Physics the virtual rig can hide in a run (`--effect NAME=VALUE`), so the diagnosis
(models/diagnose.py) is tested against effects it was not told about.

Each is built into the plant's physics (sim_backend/plant.py), in a form different from
the one the diagnosis fits (models/candidates.py): a first-order filter against a pure
delay, a mount whose rod floats across the gap against a stationary one, a Stribeck seal
against a breakaway that decays with travel, and so on.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from models.damper import Compressibility, Damper, TempCoeff, TemperatureSensitivity

# name: (unit, what VALUE sets)
EFFECTS = {
    "sensor_delay": ("s", "time constant of a first-order filter in the LVDT/LVT conditioning"),
    "free_play": ("m", "clearance in the damper's lower mount, in the load path"),
    "compressibility": ("Pa", "effective bulk modulus of the oil (entrained air), constant"),
    "breakaway_friction": ("-", "Stribeck seal: friction at rest over sliding friction"),
    "position_friction": ("-", "a tight spot in the bore: extra friction at its peak over the table's"),
    "gas_temperature": ("-", "share of the body's temperature rise the gas charge takes on"),
    "damping_temperature": ("1/K", "K_effoil of eq 4.17 in both directions (oil density with temperature)"),
    "fluid_inertia": ("kg", "mass of the oil column accelerated through the valves"),
    "cavitation": ("Pa", "absolute pressure below which the oil releases air: chambers cannot go lower"),
    "aux_channel": ("1/A", "damping change per ampere of the adjuster current aux.valve_current"),
}
STRIBECK_V = 0.005  # m/s: a seal's Stribeck velocity (a choice; seals run 1-10 mm/s)
TIGHT_SPOT = (0.006, 0.004)  # m: the tight spot's centre above mid-stroke and its half-width


class EffectError(ValueError):
    pass


def parse(specs) -> dict:
    """{name: value} from ["NAME=VALUE", ...]; EffectError names a bad one."""
    out = {}
    for s in specs or ():
        name, sep, value = s.partition("=")
        if name not in EFFECTS:
            raise EffectError(f"--effect {s}: unknown effect {name!r} (known: {', '.join(EFFECTS)})")
        try:
            out[name] = float(value) if sep else float("nan")
        except ValueError:
            out[name] = float("nan")
        v = out[name]
        if not np.isfinite(v) or v < 0 or (name == "compressibility" and v == 0):
            raise EffectError(f"--effect {s}: VALUE must be a {'positive' if name == 'compressibility' else 'non-negative'} "
                              f"number in {EFFECTS[name][0]}")
    return out


def damper_with(d: Damper, fx: dict) -> Damper:
    """The damper with the effects that live in its description: oil bulk modulus, damping
    temperature coefficients, friction along the bore."""
    if "compressibility" in fx:
        d = dataclasses.replace(d, compressibility=Compressibility(beta_inv=fx["compressibility"]))
    if "damping_temperature" in fx:
        k = TempCoeff(K_effoil=fx["damping_temperature"], C_fd=0.0)
        d = dataclasses.replace(d, temperature=TemperatureSensitivity(d.temperature.T_ref, k, k))
    if fx.get("position_friction"):
        f = d.friction
        x = np.linspace(0.0, d.geometry.stroke, 61)
        c, w = d.mid_stroke + TIGHT_SPOT[0], TIGHT_SPOT[1]
        F = np.interp(x, f.x_table, f.F_table) * (1 + fx["position_friction"] * np.exp(-((x - c) / w) ** 2))
        d = dataclasses.replace(d, friction=dataclasses.replace(f, x_table=list(x), F_table=list(F)))
    return d


def plain_cell():
    """(damper name, plant parameters, prove settings) of sim_backend/plain.toml: the
    virtual rig with nothing the minimal model leaves out."""
    import tomllib
    from pathlib import Path

    from sim_backend.plant import PARAMS
    plain = tomllib.loads((Path(__file__).parent / "plain.toml").read_text())
    params = tomllib.loads(PARAMS.read_text())
    for section in ("frame", "sensors", "thermal", "actuator"):
        params[section].update(plain.get(section, {}))
    return plain["damper"], params, plain["prove"]
