"""The unit systems outputs are shown in (`--units si|metric|us`, units.toml): SI inside,
converted only here, at the edge. A quantity's value in SI goes to the chosen system by
`shown = SI x scale + offset`."""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SYSTEMS_FILE = Path(__file__).with_name("units.toml")
_MM = re.compile(r"(\d+(?:\.\d+)?) mm\b")  # a length in a recorded segment name (protocols name them in mm)
with open(SYSTEMS_FILE, "rb") as _f:
    SYSTEMS = tomllib.load(_f)


@dataclass(frozen=True)
class Units:
    system: str = "metric"

    def __post_init__(self):
        if self.system not in SYSTEMS:
            raise ValueError(f"unknown unit system {self.system!r} (one of {', '.join(SYSTEMS)})")

    def unit(self, quantity: str) -> str:
        return SYSTEMS[self.system][quantity][0]

    def show(self, quantity: str, si):
        """SI value(s) in this system's unit."""
        _, scale, offset = SYSTEMS[self.system][quantity]
        return np.asarray(si, float) * scale + offset if np.ndim(si) else float(si) * scale + offset

    def to_si(self, quantity: str, shown):
        _, scale, offset = SYSTEMS[self.system][quantity]
        return (np.asarray(shown, float) - offset) / scale if np.ndim(shown) else (float(shown) - offset) / scale

    def label(self, name: str, quantity: str) -> str:
        """A column or axis name with its unit: 'F comp [lbf]'."""
        return f"{name} [{self.unit(quantity)}]"

    def segment(self, name: str) -> str:
        """A segment's recorded name in this system: 'sine 12.7 mm 4 Hz' -> 'sine 0.5 in 4 Hz'."""
        if self.unit("length") == "mm":
            return name
        return _MM.sub(lambda m: f"{self.show('length', float(m.group(1)) * 1e-3):.3g} {self.unit('length')}", name)

    def column(self, name: str, quantity: str) -> str:
        """A CSV column name with its unit, as pandas users like them: 'F_comp_lbf'."""
        return f"{name}_{self.unit(quantity).replace('/', '_')}"


TOLERANCE = "5%"  # the band a run is checked in (dyno check, a report's verdict) when none is given


def parse_with_unit(quantity: str, text: str) -> float:
    """'5lbf', '20 N', '500mm/s' -> the SI value; the unit any system names for the
    quantity. ValueError names the units accepted when there is none or another."""
    names = {u: (scale, offset) for s in SYSTEMS.values() for u, scale, offset in [s[quantity]]}
    t = text.replace(" ", "")
    unit = max((u for u in names if t.endswith(u)), key=len, default=None)
    number = t[:-len(unit)] if unit else t
    try:
        value = float(number)
    except ValueError:
        value = None
    if unit is None or value is None or not np.isfinite(value):
        raise ValueError(f"{text!r} is not a {quantity} with its unit (one of {', '.join(names)}, e.g. "
                         f"{ {'force': '5N', 'velocity': '0.5m/s'}.get(quantity, '1' + next(iter(names)))})")
    scale, offset = names[unit]
    return (value - offset) / scale


def quantity_of(si_unit: str) -> str | None:
    """The quantity an SI unit measures ('N' -> 'force'), or None (a recording's channels
    carry SI unit names)."""
    return next((q for q, (u, _, _) in SYSTEMS["si"].items() if u == si_unit), None)


def fmt(x, digits=4) -> str:
    """A value to `digits` significant digits in fixed point ('-' for none): 1403, 12.68, 0.3170."""
    if x is None or not np.isfinite(x):
        return "-"
    if x == 0:
        return "0"
    return f"{x:.{max(0, digits - 1 - int(np.floor(np.log10(abs(x)))))}f}"


def amplitude(units: Units, mm: float) -> str:
    """A plan's amplitude [mm] as shown: '12.7 mm', '0.5 in', '0.0127 m'."""
    return f"{units.show('length', mm * 1e-3):.3g} {units.unit('length')}"
