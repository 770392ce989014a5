"""The catalogue: the physics (and the cell's faults) the minimal baseline may have left
out, one module per effect, each an `Effect` (models/diagnose/spec.py) that owns its
parameters, its force, its derivatives, its words and its place among the others
(`listed`). A module here is found by its being here: adding an effect is one module
(docs/architecture.md, "Adding an effect")."""

from __future__ import annotations

import importlib
import pkgutil


def _found():
    """Every Effect of this package's modules (EFFECT, or EFFECTS for a module of several),
    in the order they are listed; two at one place are a ValueError at import."""
    out = []
    for m in pkgutil.iter_modules(__path__):
        module = importlib.import_module(f"{__name__}.{m.name}")
        out += getattr(module, "EFFECTS", None) or [module.EFFECT]
    places = [e.listed for e in out]
    if len(set(places)) < len(places) or min(places) <= 0:
        twice = sorted(e.name for e in out if places.count(e.listed) > 1 or e.listed <= 0)
        raise ValueError(f"effects without a place of their own in the catalogue (Effect.listed): {', '.join(twice)}")
    return sorted(out, key=lambda e: e.listed)


# in the order the rounds try them
CATALOGUE = {e.name: e for e in _found()}
