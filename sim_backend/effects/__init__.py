"""Physics the virtual rig can hide in a run (`--effect NAME[:FORM]=VALUE`), so the
diagnosis (models/diagnose/) is tested against effects it was not told about.

One module per effect: what its VALUE means, its forms, and its physics with its own state
(base.Hidden: the plant's hooks). Each is built in a form different from the one the
diagnosis fits: a first-order filter against a pure delay, a mount whose rod floats across
the gap against a stationary one, a Stribeck seal against a breakaway that decays with
travel, and so on. The plant does not read the diagnosis's catalogue: the names are the
same, the knowledge is each side's own. Adding one: a module here (found by its being here), a
calibrated value in plain.toml ([prove.concealed], `dyno prove --calibrate`).
"""
from __future__ import annotations

import importlib
import pkgutil

from sim_backend.effects.base import Hidden


def _found() -> tuple[type[Hidden], ...]:
    """The Hidden class each module of this package defines, in the order listed
    (Hidden.listed); two at one place are a ValueError at import."""
    out = []
    for m in pkgutil.iter_modules(__path__):
        module = importlib.import_module(f"{__name__}.{m.name}")
        out += [c for c in vars(module).values()
                if isinstance(c, type) and issubclass(c, Hidden) and c is not Hidden and c.__module__ == module.__name__]
    places = [c.listed for c in out]
    if len(set(places)) < len(places) or min(places) <= 0:
        twice = sorted(c.name for c in out if places.count(c.listed) > 1 or c.listed <= 0)
        raise ValueError(f"hidden effects without a place of their own (Hidden.listed): {', '.join(twice)}")
    return tuple(sorted(out, key=lambda c: c.listed))


# the order of the prove tables; each effect's state starts in it (free play places the rod first)
HIDDEN = {E.name: E for E in _found()}
# the other forms, in the plant's words (VALUE keeps its meaning and unit in each)
FORMS = {f"{name}:{form}": what for name, E in HIDDEN.items() for form, what in E.forms.items()}


def scaled(name, value, s):
    """The VALUE that makes effect `name` s times as strong as at `value` (its `grows`)."""
    return HIDDEN[name].scaled(value, s)


def build(fx: dict) -> list[Hidden]:
    """The hidden effects of {name: VALUE, "forms": {name: form}} (parse's), in their order."""
    forms = fx.get("forms", {})
    return [E(fx[E.name], forms.get(E.name)) for E in HIDDEN.values() if E.name in fx]


def drives(fx: dict) -> dict:
    """{channel: what it is} of the channels the hidden effects make drive the damper."""
    return {ch: what for E in HIDDEN.values() if fx.get(E.name) for ch, what in E.drives.items()}


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

