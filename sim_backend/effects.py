"""Physics the virtual rig can hide in a run (`--effect NAME=VALUE`), so the diagnosis
(models/diagnose/) is tested against effects it was not told about.

Each is built into the plant's physics (sim_backend/plant/), in a form different from the
one the diagnosis fits, and declared in sim_backend/hidden.toml: a first-order filter
against a pure delay, a mount whose rod floats across the gap against a stationary one, a
Stribeck seal against a breakaway that decays with travel, and so on. The plant does not
read the diagnosis's catalogue: the names are the same, the knowledge is each side's own.
"""
from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from models.damper import Compressibility, Damper, TempCoeff, TemperatureSensitivity


@dataclass(frozen=True)
class Hidden:
    """How the virtual plant hides an effect (an entry of hidden.toml)."""
    unit: str  # of VALUE
    form: str  # what VALUE sets, in the plant's default form
    guess: float  # a VALUE of roughly noise size: where `dyno prove --calibrate` starts
    grows: str  # how VALUE makes it stronger (scaled)
    forms: dict = field(default_factory=dict)  # {other form: what VALUE sets in it}
    hi: float = float("inf")  # VALUE's range: what a damper or cell could have; beyond it, a typing mistake
    lo: float = 0.0


EFFECTS = {name: Hidden(**h) for name, h in tomllib.loads((Path(__file__).parent / "hidden.toml").read_text()).items()}
# the other forms, in the plant's words (VALUE keeps its meaning and unit in each)
FORMS = {f"{name}:{form}": what for name, h in EFFECTS.items() for form, what in h.forms.items()}
# Stribeck curve per form: (shape, Stribeck velocity [m/s]); seals run 1-20 mm/s (a choice)
STRIBECK = {None: ("gaussian", 0.005), "exponential": ("exponential", 0.002), "lorentzian": ("lorentzian", 0.01),
            "power": ("power", 0.02), "slow": ("gaussian", 0.001)}
BW_YIELD = 2e-4  # m: the hidden hysteretic element's yield travel (a choice: MR dampers yield over 0.1-1 mm)
TIGHT_SPOT = (0.006, 0.004)  # m: the tight spot's centre above mid-stroke and its half-width
NARROW_SPOT = (-0.003, 0.00075)  # m: the narrow form's
CONTACT_F = 5000.0  # N: the load under which a free play's contact gives way one clearance more (a choice:
# about the cell's force range, so the clearance, not the contact's spring, dominates)
CAV_REDISSOLVE_S = 0.005  # s: how fast released air goes back into solution (a choice)
P_REF_AIR = 2e6  # Pa: where the air form's effective modulus is VALUE (the pressure form's reference)


def scaled(name, value, s):
    """The VALUE that makes effect `name` s times as strong as at `value` (its `grows`)."""
    grows = EFFECTS[name].grows
    if grows == "inversely":  # a bulk modulus
        return value / s
    if grows == "in its excess over 1":  # a ratio of frictions
        return 1 + (value - 1) * s
    return value * s


class EffectError(ValueError):
    pass


def parse(specs) -> dict:
    """{name: value} from ["NAME[:FORM]=VALUE", ...], with {"forms": {name: form}} when a
    form other than the default is named; EffectError names a bad one."""
    out = {}
    for s in specs or ():
        if s.startswith("extra:"):  # a force the user writes (sim_backend/extra.py)
            from sim_backend.extra import ExtraError, compile_extra
            try:
                compile_extra(s[len("extra:"):])
            except ExtraError as e:
                raise EffectError(f"--effect {e}") from None
            out["extra"] = s[len("extra:"):]
            continue
        name, sep, value = s.partition("=")
        name, _, form = name.partition(":")
        if name not in EFFECTS:
            raise EffectError(f"--effect {s}: unknown effect {name!r} (known, with the unit of VALUE: "
                              f"{', '.join(f'{n} [{h.unit}]' for n, h in EFFECTS.items())}, extra:EXPR)")
        if form:
            if form not in EFFECTS[name].forms:
                known = ", ".join(EFFECTS[name].forms) or "none"
                raise EffectError(f"--effect {s}: {name} has no form {form!r} (other forms: {known})")
            out.setdefault("forms", {})[name] = form
        try:
            out[name] = float(value) if sep else float("nan")
        except ValueError:
            out[name] = float("nan")
        v, h = out[name], EFFECTS[name]
        if not h.lo <= v <= h.hi:
            raise EffectError(f"--effect {s}: VALUE must be a number from {h.lo:g} to {h.hi:g} {h.unit}")
    return out


def damper_with(d: Damper, fx: dict) -> Damper:
    """The damper with the effects that live in its description: oil bulk modulus, damping
    temperature coefficients, friction along the bore."""
    forms = fx.get("forms", {})
    if "compressibility" in fx:
        K, form = fx["compressibility"], forms.get("compressibility")
        if form == "pressure":
            c = Compressibility(C_ibeta=K / 4, C_sbeta=0.75 * K / P_REF_AIR, beta_min_inv=4 * K)
        elif form == "air":  # 1/K = 1/K_oil + A/P^2 at P_REF_AIR (models/physics/compressibility.py)
            K_oil = d.compressibility.beta_inv or 1.37e9  # pure oil, thesis 3.3.2
            A = max(P_REF_AIR ** 2 * (1 / K - 1 / K_oil), 0.0)
            c = Compressibility(beta_inv=K_oil, air_fraction=A / 101325.0)
        else:
            c = Compressibility(beta_inv=K)
        d = dataclasses.replace(d, compressibility=c)
    if "damping_temperature" in fx:
        k, form = fx["damping_temperature"], forms.get("damping_temperature")
        kc = TempCoeff(K_effoil=2 * k if form == "compression" else 0.0 if form == "rebound" else k, C_fd=0.0)
        kr = TempCoeff(K_effoil=2 * k if form == "rebound" else 0.0 if form == "compression" else k, C_fd=0.0)
        d = dataclasses.replace(d, temperature=TemperatureSensitivity(d.temperature.T_ref, kc, kr))
    if fx.get("position_friction"):
        f, form = d.friction, forms.get("position_friction")
        x = np.linspace(0.0, d.geometry.stroke, 241)
        if form == "step":
            shape = 0.5 * (1 + np.tanh((x - d.mid_stroke - 0.002) / 0.00025))
        else:
            c, w = NARROW_SPOT if form == "narrow" else TIGHT_SPOT
            shape = np.exp(-((x - d.mid_stroke - c) / w) ** 2)
        F = np.interp(x, f.x_table, f.F_table) * (1 + fx["position_friction"] * shape)
        d = dataclasses.replace(d, friction=dataclasses.replace(f, x_table=list(x), F_table=list(F)))
    return d
