"""Physics the virtual rig can hide in a run (`--effect NAME[:FORM]=VALUE`), so the
diagnosis (models/diagnose/) is tested against effects it was not told about.

One module per effect: what its VALUE means, its forms, and its physics with its own state
(base.Hidden: the plant's hooks). Each is built in a form different from the one the
diagnosis fits: a first-order filter against a pure delay, a mount whose rod floats across
the gap against a stationary one, a Stribeck seal against a breakaway that decays with
travel, and so on. The plant does not read the diagnosis's catalogue: the names are the
same, the knowledge is each side's own. Adding one: a module here, a line in HIDDEN_ORDER, a
calibrated value in plain.toml ([prove.concealed], `dyno prove --calibrate`).
"""
from __future__ import annotations

from sim_backend.effects.aux_channel import AuxChannel
from sim_backend.effects.base import Hidden
from sim_backend.effects.bouc_wen import BoucWen
from sim_backend.effects.breakaway_friction import BreakawayFriction
from sim_backend.effects.cavitation import Cavitation
from sim_backend.effects.compressibility import Compressibility
from sim_backend.effects.damping_temperature import DampingTemperature
from sim_backend.effects.fluid_inertia import FluidInertia
from sim_backend.effects.free_play import FreePlay
from sim_backend.effects.gain_drift import GainDrift
from sim_backend.effects.gas_temperature import GasTemperature
from sim_backend.effects.position_friction import PositionFriction
from sim_backend.effects.presliding_friction import PreslidingFriction
from sim_backend.effects.sensor_delay import SensorDelay

# the order of the prove tables; each effect's state starts in it (free play places the rod first)
HIDDEN_ORDER: tuple[type[Hidden], ...] = (
    SensorDelay, FreePlay, Compressibility, BreakawayFriction, PositionFriction, GasTemperature,
    DampingTemperature, FluidInertia, Cavitation, PreslidingFriction, BoucWen, AuxChannel, GainDrift)
HIDDEN = {E.name: E for E in HIDDEN_ORDER}
# the other forms, in the plant's words (VALUE keeps its meaning and unit in each)
FORMS = {f"{name}:{form}": what for name, E in HIDDEN.items() for form, what in E.forms.items()}


def scaled(name, value, s):
    """The VALUE that makes effect `name` s times as strong as at `value` (its `grows`)."""
    return HIDDEN[name].scaled(value, s)


def build(fx: dict) -> list[Hidden]:
    """The hidden effects of {name: VALUE, "forms": {name: form}} (parse's), in HIDDEN_ORDER."""
    forms = fx.get("forms", {})
    return [E(fx[E.name], forms.get(E.name)) for E in HIDDEN_ORDER if E.name in fx]


def drives(fx: dict) -> dict:
    """{channel: what it is} of the channels the hidden effects make drive the damper."""
    return {ch: what for E in HIDDEN_ORDER if fx.get(E.name) for ch, what in E.drives.items()}


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
        if name not in HIDDEN:
            raise EffectError(f"--effect {s}: unknown effect {name!r} (known, with the unit of VALUE: "
                              f"{', '.join(f'{n} [{h.unit}]' for n, h in HIDDEN.items())}, extra:EXPR)")
        if form:
            if form not in HIDDEN[name].forms:
                known = ", ".join(HIDDEN[name].forms) or "none"
                raise EffectError(f"--effect {s}: {name} has no form {form!r} (other forms: {known})")
            out.setdefault("forms", {})[name] = form
        try:
            out[name] = float(value) if sep else float("nan")
        except ValueError:
            out[name] = float("nan")
        v, h = out[name], HIDDEN[name]
        if not h.lo <= v <= h.hi:
            raise EffectError(f"--effect {s}: VALUE must be a number from {h.lo:g} to {h.hi:g} {h.unit}")
    return out

