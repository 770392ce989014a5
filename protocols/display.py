"""Readings where a person reads them (rig check, rig zero, progress lines, the live view):
SI inside, shown in the output's unit system (protocols/units.toml; metric by default)."""
from __future__ import annotations

from protocols.units import Units, quantity_of


def shown(value, unit, units=Units()):
    """(value, unit) in the unit system; a unit that is no quantity of it (A, V) unchanged."""
    quantity = quantity_of(unit)
    if quantity is None:
        return value, unit
    return units.show(quantity, value), units.unit(quantity)
