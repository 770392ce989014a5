"""Which fitted values are measurements: a parameter the recording does not determine
(no influence, at a bound, below physics' floor), a friction that reads below zero where
the rod slides."""
from __future__ import annotations

import re

import numpy as np

from models.diagnose.candidates import Model
from models.diagnose.data import Data
from models.diagnose.spec import P

AT_BOUND = 1e-3  # a value within this share of its range from a bound sits at the bound


def undetermined(params: list[P], values: dict, sd: dict) -> dict:
    """{parameter: why the recording could not determine it}: no influence on the fit (an
    infinite deviation in sd; a parameter sd lacks is not judged so), at a bound of its
    range (held there, not measured), or below the floor physics sets (P.floor) by more
    than its range's AT_BOUND and twice its deviation where it has one (it takes up
    something else)."""
    unknown = {}
    for p in params:
        span = p.hi - p.lo
        v, s = values[p.name], sd.get(p.name, 0.0)
        if not np.isfinite(s):
            unknown[p.name] = "no influence on the fit: the recording does not determine it"
        elif min(v - p.lo, p.hi - v) <= AT_BOUND * span:
            bound = "lower" if v - p.lo <= AT_BOUND * span else "upper"
            unknown[p.name] = f"at the {bound} bound of its range ({p.lo:g}..{p.hi:g} {p.unit}): held, not measured"
        elif p.floor is not None and v < p.floor - max(AT_BOUND * span, 2 * (s or 0.0)):
            unknown[p.name] = (f"below {p.floor:g} {p.unit}, where physics puts none: it takes up something else, "
                               "not measured")
    return unknown


SLIDING = 0.2  # of the top speed: above it the seal slides, and its friction opposes the motion


def friction_outside_physics(model: Model, d: Data, values: dict) -> dict:
    """{parameter: why} for the friction's parameters (F_c, position friction's pf...) when
    the model's friction reads below zero where the rod slides (above SLIDING of the top
    speed) by more than 1 % of the force range: a seal cannot push the rod along, so these
    take up something else (an MR fluid's yield against its valve curve) and are no
    measurement of a friction."""
    f = model.forces(d, values)
    sliding = np.abs(f.v) > SLIDING * np.max(np.abs(f.v))
    if not np.any(sliding):
        return {}
    level = f.Ff[sliding] * np.sign(f.v[sliding])
    i = int(np.argmin(level))
    if level[i] >= -0.01 * float(np.ptp(d.F)):
        return {}
    why = (f"the friction it gives reads {level[i]:.0f} N at {1e3 * f.x[sliding][i]:.1f} mm, below zero, which a "
           "seal cannot give: it takes up something else, not measured")
    return {p.name: why for p in model.params if p.name == "F_c" or re.fullmatch(r"pf\d+", p.name)}
