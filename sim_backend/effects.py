"""Physics the virtual rig can hide in a run (`--effect NAME=VALUE`), so the diagnosis
(models/diagnose/) is tested against effects it was not told about.

Each is built into the plant's physics (sim_backend/plant/), in a form different from
the one the diagnosis fits (models/diagnose/candidates.py): a first-order filter against a pure
delay, a mount whose rod floats across the gap against a stationary one, a Stribeck seal
against a breakaway that decays with travel, and so on.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from models.damper import Compressibility, Damper, TempCoeff, TemperatureSensitivity


@dataclass(frozen=True)
class Hidden:
    """How the plant hides an effect of the diagnosis's catalogue
    (models/diagnose/candidates.py CATALOGUE, same names: tests/test_effects.py)."""
    unit: str  # of VALUE
    form: str  # what VALUE sets, in the plant's own form
    guess: float  # a VALUE of roughly noise size: where `dyno prove --calibrate` starts
    forms: tuple = ()  # other forms the plant can hide it in (--effect NAME:FORM=VALUE); `form` is the default


EFFECTS = {
    "sensor_delay": Hidden("s", "time constant of a first-order filter in the LVDT/LVT conditioning", 1e-4,
                           ("transport", "second_order")),
    "free_play": Hidden("m", "clearance in the damper's lower mount, in the load path", 2e-5),
    "compressibility": Hidden("Pa", "effective bulk modulus of the oil (entrained air), constant", 2e10,
                              ("pressure",)),
    "breakaway_friction": Hidden("-", "Stribeck seal (Gaussian): friction at rest over sliding friction", 1.1,
                                 ("exponential", "lorentzian")),
    "position_friction": Hidden("-", "a tight spot in the bore: extra friction at its peak over the table's", 0.1),
    "gas_temperature": Hidden("-", "share of the body's temperature rise the gas charge takes on", 0.1),
    "damping_temperature": Hidden("1/K", "K_effoil of eq 4.17 in both directions (oil density with temperature)",
                                  1e-4),
    "fluid_inertia": Hidden("kg", "mass of the oil column accelerated through the valves", 0.5),
    "cavitation": Hidden("Pa", "absolute pressure below which the oil releases air: chambers cannot go lower", 3e5),
    "presliding_friction": Hidden("m", "the seal's pre-sliding travel (the plant's Dahl law, stepped with the frame)",
                                  1e-5),
    "bouc_wen": Hidden("N", "force at yield of a hysteretic element in the load path, Bouc-Wen with exponent "
                            "n = 1 over BW_YIELD of travel (the diagnosis fits n = 2)", 1.0),
    "aux_channel": Hidden("1/A", "damping change per ampere of the adjuster current aux.valve_current", 0.01),
}
# the other forms, in the plant's words (VALUE keeps its meaning and unit in each)
FORMS = {
    "sensor_delay:transport": "a pure transport delay of VALUE in the LVDT/LVT signal",
    "sensor_delay:second_order": "two first-order filters of VALUE / 2 in series (critically damped)",
    "compressibility:pressure": "bulk modulus rising with chamber pressure (eq 3.32): VALUE / 4 at zero, "
                                "VALUE at 2 MPa, at least VALUE / 10",
    "breakaway_friction:exponential": "Stribeck seal, exp(-|v| / STRIBECK_V)",
    "breakaway_friction:lorentzian": "Stribeck seal, 1 / (1 + (v / STRIBECK_V)^2)",
}
STRIBECK_V = 0.005  # m/s: a seal's Stribeck velocity (a choice; seals run 1-10 mm/s)
BW_YIELD = 2e-4  # m: the hidden hysteretic element's yield travel (a choice: MR dampers yield over 0.1-1 mm)
TIGHT_SPOT = (0.006, 0.004)  # m: the tight spot's centre above mid-stroke and its half-width


def scaled(name, value, s):
    """The VALUE that makes effect `name` s times as strong as at `value`: a bulk modulus
    falls (value / s), a breakaway ratio's excess grows (1 + (value - 1) s), the rest grow
    in proportion."""
    if name == "compressibility":
        return value / s
    if name == "breakaway_friction":
        return 1 + (value - 1) * s
    return value * s


class EffectError(ValueError):
    pass


def parse(specs) -> dict:
    """{name: value} from ["NAME[:FORM]=VALUE", ...], with {"forms": {name: form}} when a
    form other than the default is named; EffectError names a bad one."""
    out = {}
    for s in specs or ():
        name, sep, value = s.partition("=")
        name, _, form = name.partition(":")
        if name not in EFFECTS:
            raise EffectError(f"--effect {s}: unknown effect {name!r} (known: {', '.join(EFFECTS)})")
        if form:
            if form not in EFFECTS[name].forms:
                known = ", ".join(EFFECTS[name].forms) or "none"
                raise EffectError(f"--effect {s}: {name} has no form {form!r} (other forms: {known})")
            out.setdefault("forms", {})[name] = form
        try:
            out[name] = float(value) if sep else float("nan")
        except ValueError:
            out[name] = float("nan")
        v = out[name]
        if not np.isfinite(v) or v < 0 or (name == "compressibility" and v == 0):
            raise EffectError(f"--effect {s}: VALUE must be a {'positive' if name == 'compressibility' else 'non-negative'} "
                              f"number in {EFFECTS[name].unit}")
    return out


def damper_with(d: Damper, fx: dict) -> Damper:
    """The damper with the effects that live in its description: oil bulk modulus, damping
    temperature coefficients, friction along the bore."""
    if "compressibility" in fx:
        K = fx["compressibility"]
        c = (Compressibility(C_ibeta=K / 4, C_sbeta=0.75 * K / 2e6, beta_min_inv=K / 10)
             if fx.get("forms", {}).get("compressibility") == "pressure" else Compressibility(beta_inv=K))
        d = dataclasses.replace(d, compressibility=c)
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

    from sim_backend.plant import plant_params
    plain = tomllib.loads((Path(__file__).parent / "plain.toml").read_text())
    params = plant_params()
    for section in ("frame", "sensors", "thermal", "actuator"):
        params[section].update(plain.get(section, {}))
    return plain["damper"], params, plain["prove"]
