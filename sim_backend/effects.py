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
    "free_play": Hidden("m", "clearance in the damper's lower mount, in the load path (rigid contact)", 2e-5,
                        ("contact", "hertz")),
    "compressibility": Hidden("Pa", "effective bulk modulus of the oil (entrained air), constant", 2e10,
                              ("pressure", "air")),
    "breakaway_friction": Hidden("-", "Stribeck seal (Gaussian, 5 mm/s): friction at rest over sliding friction",
                                 1.1, ("exponential", "lorentzian", "power", "slow")),
    "position_friction": Hidden("-", "a tight spot in the bore: extra friction at its peak over the table's", 0.1,
                                ("narrow", "step")),
    "gas_temperature": Hidden("-", "share of the body's temperature rise the gas charge takes on", 0.1,
                              ("reservoir", "lagged")),
    "damping_temperature": Hidden("1/K", "K_effoil of eq 4.17 in both directions (oil density with temperature)",
                                  1e-4, ("compression", "rebound")),
    "fluid_inertia": Hidden("kg", "mass of the oil column accelerated through the valves (1 ms lag)", 0.5,
                            ("resonant", "direction")),
    "cavitation": Hidden("Pa", "absolute pressure below which the oil releases air: chambers cannot go lower", 3e5,
                         ("lingering", "soft")),
    "presliding_friction": Hidden("m", "the seal's pre-sliding travel (the plant's Dahl law, stepped with the frame)",
                                  1e-5, ("jenkins", "iwan")),
    "bouc_wen": Hidden("N", "force at yield of a hysteretic element in the load path, Bouc-Wen with exponent "
                            "n = 1 over BW_YIELD of travel (the diagnosis fits n = 2)", 1.0, ("elastoplastic", "wide")),
    "aux_channel": Hidden("1/A", "damping change per ampere of the adjuster current aux.valve_current (20 ms "
                                 "solenoid lag)", 0.01, ("fast", "quadratic")),
}
# the other forms, in the plant's words (VALUE keeps its meaning and unit in each)
FORMS = {
    "sensor_delay:transport": "a pure transport delay of VALUE in the LVDT/LVT signal",
    "sensor_delay:second_order": "two first-order filters of VALUE / 2 in series (critically damped)",
    "free_play:contact": "the clearance closes onto a linear contact stiffness that gives way VALUE more "
                         "under CONTACT_F (a worn elastomer bush)",
    "free_play:hertz": "the clearance closes onto a Hertzian contact, deflection (F / CONTACT_F)^(2/3) VALUE "
                       "(a worn ball joint)",
    "compressibility:pressure": "bulk modulus rising with chamber pressure (eq 3.32): VALUE / 4 at zero, "
                                "VALUE at 2 MPa, at most 4 VALUE (from 10 MPa)",
    "compressibility:air": "free air entrained in the oil, compressed isothermally: effective modulus VALUE "
                           "at 2 MPa, softer below, stiffer above",
    "breakaway_friction:exponential": "Stribeck seal, exp(-|v| / 2 mm/s)",
    "breakaway_friction:lorentzian": "Stribeck seal, 1 / (1 + (v / 10 mm/s)^2)",
    "breakaway_friction:power": "Stribeck seal, a power law (1 + |v| / 20 mm/s)^-2",
    "breakaway_friction:slow": "Stribeck seal, Gaussian at 1 mm/s",
    "position_friction:narrow": "a tight spot 1.5 mm wide, 3 mm below mid-stroke",
    "position_friction:step": "friction VALUE higher over the bore above mid-stroke + 2 mm (a worn lower bore), "
                              "the step over 0.5 mm",
    "gas_temperature:reservoir": "share of the reservoir's temperature rise (it lags the body by its 60 s)",
    "gas_temperature:lagged": "share of the body's temperature rise through a 10 s lag (heat through the "
                              "floating piston)",
    "damping_temperature:compression": "K_effoil of twice VALUE in compression only",
    "damping_temperature:rebound": "K_effoil of twice VALUE in rebound only",
    "fluid_inertia:resonant": "the oil column on the oil's spring: its force through a 150 Hz resonance, "
                              "damping ratio 0.3",
    "fluid_inertia:direction": "1.5 VALUE while oil flows in compression, 0.5 VALUE in rebound (longer path)",
    "cavitation:lingering": "the air released below VALUE redissolves over CAV_REDISSOLVE_S: the lost push "
                            "recovers with that lag",
    "cavitation:soft": "air comes out of solution from twice VALUE down: the chamber approaches VALUE "
                       "exponentially",
    "presliding_friction:jenkins": "friction builds linearly over VALUE of travel, then slides (elasto-plastic)",
    "presliding_friction:iwan": "four elasto-plastic elements of 0.25, 0.75, 1.25 and 1.75 VALUE in parallel",
    "bouc_wen:elastoplastic": "elasto-plastic: linear up to VALUE over BW_YIELD of travel, then yields",
    "bouc_wen:wide": "the default element over five times BW_YIELD",
    "aux_channel:fast": "the solenoid follows the current within 2 ms",
    "aux_channel:quadratic": "damping change VALUE (i^2 - 1) / 2: the solenoid's force goes with the current "
                             "squared (VALUE per ampere at 1 A)",
}
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
            raise EffectError(f"--effect {s}: unknown effect {name!r} (known: {', '.join(EFFECTS)}, extra:EXPR)")
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
