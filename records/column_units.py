"""The units a column of a foreign recording may be in, as dyno and DAQ software write them,
and the unit a column's name carries: what import converts to SI at the edge."""
from __future__ import annotations

import re

import numpy as np

P_ATM = 101_325.0
# unit -> (scale, offset): SI = value * scale + offset
UNITS = {
    "time": {"s": (1, 0), "ms": (1e-3, 0), "us": (1e-6, 0), "min": (60, 0)},
    "displacement": {"m": (1, 0), "mm": (1e-3, 0), "cm": (1e-2, 0), "um": (1e-6, 0), "in": (0.0254, 0)},
    "velocity": {"m/s": (1, 0), "mm/s": (1e-3, 0), "cm/s": (1e-2, 0), "in/s": (0.0254, 0)},
    "force": {"N": (1, 0), "kN": (1e3, 0), "daN": (10, 0), "lbf": (4.4482216, 0), "kgf": (9.80665, 0)},
    "temperature": {"K": (1, 0), "C": (1, 273.15), "degC": (1, 273.15), "F": (5 / 9, 273.15 - 32 * 5 / 9)},
    "pressure": {"Pa": (1, 0), "kPa": (1e3, 0), "mbar": (100, 0), "MPa": (1e6, 0), "bar": (1e5, 0), "psi": (6894.757, 0),
                 "kPag": (1e3, P_ATM), "barg": (1e5, P_ATM), "psig": (6894.757, P_ATM)},
}
# a unit as dyno and DAQ software also write it (matched ignoring case); a force in kg is kgf,
# as older dyno software labels it
SPELLINGS = {"sec": "s", "secs": "s", "second": "s", "seconds": "s", "msec": "ms", "µs": "us", "μs": "us",
             "usec": "us", "µm": "um", "μm": "um", "inch": "in", "inches": "in", "mm/sec": "mm/s", "m/sec": "m/s",
             "cm/sec": "cm/s", "in/sec": "in/s", "ips": "in/s", "lb": "lbf", "lbs": "lbf", "kg": "kgf", "°c": "C",
             "ºc": "C", "degc": "C", "deg c": "C", "°f": "F", "ºf": "F", "degf": "F", "deg f": "F", "psia": "psi"}
UNIT_NAMES = {u.lower() for q in UNITS.values() for u in q} | set(SPELLINGS)  # a row of units under the names
BRACKETED = re.compile(r"[\[(]\s*([^\[\]()]+?)\s*[\])]")
SI = {"time": "s", "displacement": "m", "velocity": "m/s", "force": "N", "temperature": "K", "pressure": "Pa"}


def unit(channel: str, text: str) -> str | None:
    """The unit of a standard channel as text spells it (any case, or one of SPELLINGS), or None."""
    t = SPELLINGS.get(text.strip().lower(), text.strip()).lower()
    return next((u for u in UNITS[channel] if u.lower() == t), None)


def unit_in_name(name: str, channel: str | None = None) -> str | None:
    """The unit a column's name carries (`Force [kN]`, `Force (lbs)`, `force_kN`, `Force: kN`),
    as import spells it: one of channel's, or of any standard channel's; None if it says none."""
    said = BRACKETED.findall(name) + [name.rpartition(sep)[2] for sep in ("_", ":") if sep in name]
    return next((u for text in said for ch in ([channel] if channel else UNITS) if (u := unit(ch, text))), None)


VOLT_UNITS = {"v", "mv", "volt", "volts"}
DAQ_CHANNEL = re.compile(r"^(channel|chan|ch|ai|ain|analog ?in(put)?|voltage|dev\d+/ai)[ _]?\d+$", re.I)
DAQ_RANGE_V = 10.5  # V: a DAQ's +-10 V input and a little over


def volts(name: str, values: np.ndarray) -> str:
    """Why a column reads volts (its name says V, or a DAQ's channel name whose every value
    lies within its +-10 V range), else "": a raw channel no gain has made a quantity."""
    said = [t for t in BRACKETED.findall(name) + [name.rpartition("_")[2]] * ("_" in name)
            if t.strip().lower() in VOLT_UNITS]
    if said:
        return f"its name says {said[0].strip()}"
    finite = values[np.isfinite(values)]
    if DAQ_CHANNEL.match(name.strip()) and len(finite) and float(np.abs(finite).max()) <= DAQ_RANGE_V:
        return f"a DAQ's channel, every value within +-10 V ({finite.min():.4g} to {finite.max():.4g})"
    return ""
