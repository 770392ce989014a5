"""Parameters by dotted name (`valves.piston.rebound.m`, `gas_spring.gamma`, ...), the
scale each is fitted on, and the canonical form in which identified and known dampers
are compared (module docstring of models.identify)."""
from __future__ import annotations

import copy
import dataclasses

import numpy as np

from models.damper import Branch, Damper, Line
from models.identify import valves as identify_valves

UNITS = {"C_seatw": "N s/m", "dP_seat_Aw": "N", "C_ifT": "-", "C_sfT": "1/K", "a": "N s^2/m^2", "b": "N s/m", "m": "N s/m", "c": "N", "m2": "N s/m", "c2": "N", "K_effoil": "1/K",
         "gamma": "-", "x_stick": "m", "beta_inv": "Pa", "C_ibeta": "Pa", "C_sbeta": "-", "beta_min_inv": "Pa"}


def is_slope(name):
    """A temperature coefficient [1/K]: K_effoil (eq 4.17) or the friction's C_sfT (eq 4.1)."""
    return name.endswith("K_effoil") or name.endswith("C_sfT")


def is_log(name):
    """Positive quantities are fitted as logs (a step of 1e-3 is 0.1 %); temperature
    coefficients in units of 1e-3 /K, gamma as it is."""
    return not (is_slope(name) or name.endswith("gamma") or name.endswith("dP_seat_Aw"))


def to_value(name, z):
    if is_log(name):
        with np.errstate(over="ignore"):  # the bound of an interval that has none
            return float(np.exp(z))
    return float(z) * (1e-3 if is_slope(name) else 1.0)


def to_z(name, value):
    if is_log(name):
        with np.errstate(divide="ignore"):
            return float(np.log(value))
    return float(value) * (1e3 if is_slope(name) else 1.0)


# a valve magnitude's field in the damper (valves.direction): its declared range bounds the fit
MAGNITUDE_FIELD = {"a": (Branch, "C_orrpw"), "b": (Branch, "C_linpw"), "m": (Line, "C_linw"),
                   "c": (Line, "C_ilinw"), "m2": (Line, "C_linw"), "c2": (Line, "C_ilinw")}


def declared_range(d: Damper, name: str) -> tuple[float, float]:
    """The physical range damper.py declares for a parameter (models.damper.q)."""
    parts = name.split(".")
    if parts[0] == "valves" and parts[1] != "bypass":
        cls, field = MAGNITUDE_FIELD[parts[-1]]
    else:
        obj = d
        for p in parts[:-1]:
            obj = getattr(obj, p)
        cls, field = type(obj), parts[-1]
    return next(f for f in dataclasses.fields(cls) if f.name == field).metadata["range"]


def z_bounds(d: Damper, name: str) -> tuple[float, float]:
    """Bounds of a fitted z: the declared range, where a parameter the data cannot see
    would otherwise drift until the damper check refuses it."""
    lo, hi = declared_range(d, name)
    if is_log(name):
        return (np.log(lo) if lo > 0 else -np.inf), np.log(abs(hi))
    return to_z(name, lo), to_z(name, hi)


def determined(name, z, sd):
    """Identifiable: an interval narrower than a factor e (logs) or than the value."""
    return bool(np.isfinite(sd) and 1.96 * sd < (1.0 if is_log(name) else abs(z)))


def set_parameter(d: Damper, structures, name: str, value: float):
    """Inverse of `parameter_value`; a valve coefficient goes into its structure's
    magnitudes (structures: (path, direction) -> (structure, magnitudes, ...)), which the
    caller turns into the damper's valves."""
    parts = name.split(".")
    if parts[0] == "valves" and parts[1] == "bypass":
        setattr(d.valves.bypass, parts[2], value)
    elif parts[0] == "valves":
        structures[(parts[1], parts[2])][1][parts[3]] = value
    else:
        obj = d
        for p in parts[:-1]:
            obj = getattr(obj, p)
        setattr(obj, parts[-1], value)


def parameter_value(d: Damper, name: str) -> float:
    """A parameter by its dotted name; valve coefficients by magnitude (a, b, m, c, m2, c2)."""
    parts = name.split(".")
    if parts[0] == "valves" and parts[1] == "bypass":
        return float(getattr(d.valves.bypass, parts[2])) if d.valves.bypass is not None else np.nan
    if parts[0] == "valves":
        _, path, tag, k = parts
        sign = 1.0 if tag == "compression" else -1.0
        return identify_valves.magnitudes(getattr(getattr(d.valves, path), tag), sign).get(k, np.nan)
    obj = d
    for p in parts:
        obj = getattr(obj, p)
    return float(obj) if obj is not None else np.nan


def canonical(d: Damper) -> Damper:
    """The equivalent damper with K_voint = 0 and C_fd = 0 (module docstring)."""
    d = copy.deepcopy(d)
    g = d.gas_spring
    V0 = g.V0 - g.K_voint
    g.P0, g.V0, g.K_voint = g.P0 * g.V0 / V0, V0, 0.0
    for tag in ("compression", "rebound"):
        tc = getattr(d.temperature, tag)
        s = 1.0 + tc.C_fd
        tc.K_effoil, tc.C_fd = tc.K_effoil / s, 0.0
        for path in (d.valves.piston, d.valves.head):
            if path is None:
                continue
            dr = getattr(path, tag)
            dr.low.C_orrpw, dr.low.C_linpw, dr.low.C_ipw = (c / s for c in (dr.low.C_orrpw, dr.low.C_linpw,
                                                                             dr.low.C_ipw))
            for line in (dr.mid, dr.high):
                if line is not None:
                    line.C_linw, line.C_ilinw = line.C_linw / s, line.C_ilinw / s
        if d.valves.bypass is not None and tag == "compression":
            # its seating force compares the force itself: unchanged. Not exact in rebound,
            # where the same seat coefficient meets the rebound C_fd (within 1e-4 of the peak)
            d.valves.bypass.C_seatw /= s
    return d


AT_BOUND = 1e-3  # of the bound's size (of the range when it is 0): a value this close sits on it


def at_bounds(obj, path=""):
    """[(dotted name, value, (lo, hi), unit, "lower" | "upper")] of the fields of a damper
    (or any part of it) that sit on an end of their declared range (models.damper.q): a fit
    that ran into its bound, a value held there, not measured."""
    out = []
    if dataclasses.is_dataclass(obj):
        for f in dataclasses.fields(obj):
            v, name = getattr(obj, f.name), f"{path}.{f.name}".lstrip(".")
            lo_hi = f.metadata.get("range")
            if lo_hi and isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v):
                # a lower end of 0 is the physics' "none" (no air, no pre-sliding): not a bound hit
                for end, b in (("lower", lo_hi[0]), ("upper", lo_hi[1])):
                    if (end == "upper" or b != 0) and abs(v - b) <= AT_BOUND * (abs(b) or lo_hi[1] - lo_hi[0]):
                        out.append((name, float(v), lo_hi, f.metadata.get("unit", ""), end))
            else:
                out += at_bounds(v, name)
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            out += at_bounds(v, f"{path}[{i}]")
    elif isinstance(obj, dict):
        for k, v in obj.items():
            out += at_bounds(v, f"{path}.{k}")
    return out


def bound_sentence(b):
    """An at_bound entry {parameter, value, range, unit, bound} in words."""
    return (f"at its {b['bound']} bound, held there, not measured: {b['parameter']} = {b['value']:.6g} {b['unit']} "
            f"(range {b['range'][0]:g} .. {b['range'][1]:g})")
