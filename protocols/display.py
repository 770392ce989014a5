"""The operator's units at the edges: SI inside, temperatures in C, pressures in bar,
motion in mm, where a person reads them (rig check, progress lines)."""
from __future__ import annotations

# SI unit -> (operator's unit, scale, offset): shown = value * scale + offset
OPERATOR = {"K": ("C", 1.0, -273.15), "Pa": ("bar", 1e-5, 0.0), "m": ("mm", 1e3, 0.0), "m/s": ("mm/s", 1e3, 0.0)}


def shown(value, unit):
    """(value, unit) in the operator's unit; other units unchanged."""
    to, scale, offset = OPERATOR.get(unit, (unit, 1.0, 0.0))
    return value * scale + offset, to
