"""The diagnosis's models: the minimal baseline, and the model that composes it with the
catalogue's effects (models/diagnose/effects/) and the open terms (terms.py), each a small
model with bounded parameters (arrays in, force out, N), with its exact derivatives.

Baseline `minimal` (thesis chapter 3, reduced):
  damping   two-stage asymmetric valve curve, low- and mid-speed paths in parallel
            (eq 3.30): v = v_L(F) + v_M(F), v_L from F = c1 v + c2 v^2 (eq 3.26, the
            polynomial low-speed valve), v_M = (F - F_cr)/C_lin above the mid valve's
            cracking force (eq 3.27 with its constant); incompressible, per direction
  gas       polytropic about the mean position at constant temperature (eq 3.19):
            F_G = G0 (L / (L - (x - x_m)))^gamma, gamma = 1.38 (thesis 4.1.2)
  friction  Coulomb (eq 3.3), sgn(v) softened over V_EPS
"""
from __future__ import annotations

import numpy as np

from models.diagnose import kernels
from models.diagnose.data import Data
from models.diagnose.effects import CATALOGUE
from models.diagnose.forms import soft_sign
from models.diagnose.spec import ActsOn, Effect, Nature, Needs, P, Variable
from models.diagnose.terms import TERMS
from models.diagnose.valves import VALVES, damping, damping_grad, slope, slope_grad

GAMMA = 1.38  # thesis section 4.1.2


@kernels.recent
def _gas(x, x_m, G0, L):
    return G0 * (L / np.maximum(L - (x - x_m), 1e-3 * L)) ** GAMMA


def gas(x: np.ndarray, x_m: float, p: dict) -> np.ndarray:
    """Gas force [N]: polytropic about x_m (eq 3.19)."""
    return _gas(x, x_m, p["G0"], p["L"])


def baseline_params(d: Data) -> list[P]:
    """Start values and bounds of the minimal model from the data's ranges."""
    Fmax = max(np.percentile(np.abs(d.F), 99), 10.0)
    vmax = max(np.percentile(np.abs(d.v), 99), 1e-3)
    c0 = Fmax / vmax
    Fg = float(np.median(d.F))
    return [P("c1_c", c0, 0.0, 50 * c0, "N s/m"), P("c2_c", c0 / vmax * 0.3, 0.0, 100 * c0 / vmax, "N s^2/m^2"),
            P("C_c", c0, 0.01 * c0, 100 * c0, "N s/m"), P("Fcr_c", 0.5 * Fmax, 0.0, 3 * Fmax, "N"),
            P("c1_r", c0, 0.0, 50 * c0, "N s/m"), P("c2_r", c0 / vmax * 0.3, 0.0, 100 * c0 / vmax, "N s^2/m^2"),
            P("C_r", c0, 0.01 * c0, 100 * c0, "N s/m"), P("Fcr_r", 0.5 * Fmax, 0.0, 3 * Fmax, "N"),
            P("G0", Fg, -Fmax, Fmax, "N", floor=0.0), P("L", 0.3, 0.005, 20.0, "m"),
            P("F_c", 0.03 * Fmax, 0.0, 0.5 * Fmax, "N")]






class Minimal:
    """Baseline `minimal` (see the module's docstring), fitted whole."""
    name = "minimal"

    def __init__(self, d, x_m=None):  # x_m [m]: the gas force's reference, by default the data's mean
        self.x_m = float(np.mean(d.x)) if x_m is None else x_m

    def params(self, d):
        return baseline_params(d)

    def friction_level(self, p):
        """Sliding friction [N]."""
        return p["F_c"]

    def columns(self, f):
        """{part: {parameter: its exact derivative [N per unit]}} of the parts along the
        Forces' (shifted) motion: the valves' in the damping (damping_grad), the gas force's
        G0 and L (eq 3.19), the friction's F_c (eq 3.3)."""
        p, x, v = f.p, f.x, f.v
        dx = x - self.x_m
        room = p["L"] - dx
        free = room > 1e-3 * p["L"]
        R = np.where(free, p["L"] / np.maximum(room, 1e-3 * p["L"]), 1e3)
        return {"Fd": dict(zip(VALVES, damping_grad(v, *(p[k] for k in VALVES)))),
                "Fg": {"G0": R ** GAMMA, "L": np.where(free, p["G0"] * GAMMA * R ** (GAMMA - 1) * -dx / room ** 2, 0.0)},
                "Ff": {"F_c": soft_sign(v)}}

    def slope_columns(self, f, at=None):
        """{parameter: the damping slope's derivative} along the Forces' motion, at the
        samples `at` only when given (each sample's is its own)."""
        return dict(zip(VALVES, slope_grad(f.v if at is None else f.v[at], f.p)))

    def friction_columns(self, p):
        """{parameter: the sliding friction's derivative} (friction_level's)."""
        return {"F_c": 1.0}

    def parts(self, d, p, x, v, tau):
        """(damping, gas, friction [N], a callable giving the damping's slope dF/dv [N s/m])
        along motion x, v (already shifted by the sensor delay tau)."""
        return damping(v, p), gas(x, self.x_m, p), p["F_c"] * soft_sign(v), lambda: slope(v, p)


class Model:
    """Baseline plus accepted effects, evaluated on Data: force(d, values) [N]."""

    def __init__(self, d, effects=(), base=None):
        self.base = base or Minimal(d)
        self.data = d  # what the model is built on: its bases' knots come from it (terms.cached)
        self.x_m = float(np.mean(d.x))
        self.params = self.base.params(d)
        # an effect that supersedes another takes its place (a lag beyond the alignment)
        gone = {EFFECTS[e.split(":")[0]].supersedes for e in effects}
        self.effects = [e for e in effects if e not in gone]
        self.cache = {}  # bases the open terms build once (terms.py)
        self.own = {}  # each effect's parameter names, in order
        for e in self.effects:
            own = EFFECTS[e.split(":")[0]].params(d, e)
            self.own[e] = [q.name for q in own]
            self.params += own
        # means the effects refer to (fixed from the data, not fitted)
        self.T_m = float(np.mean(d.T)) if d.T is not None else 0.0
        self.aux_m = {n: float(np.mean(a)) for n, a in d.aux.items()}
        self.h = float(np.median(d.h))  # s, the sample period
        x0 = {p.name: p.x0 for p in self.params}
        self.Fg_m = float(np.mean(self.base.parts(d, x0, d.x, d.v, 0.0)[1]))

    def force(self, d, p, parts=False):
        """The baseline with the effects, each applied in its place: on the motion, on the
        baseline's damping, gas or friction, or on the total (Effect.acts_on, in ORDER)."""
        f = self.forces(d, p)
        return (f.F, f.Fd, f.Fg, f.Ff) if parts else f.F

    def columns(self, f):
        """{parameter: the force's derivative in it [N per unit]} from one evaluation's
        Forces: the baseline's (Minimal.columns) carried through each effect after it by
        that effect's tangent, which adds its own parameters' (Effect.tangent). A parameter
        missing (a timing offset's, a shape no closed form follows) is left to a finite
        difference; every one is where an effect has no tangent."""
        cols = {"Fd": {}, "Fg": {}, "Ff": {}}
        if hasattr(self.base, "columns"):
            for part, c in self.base.columns(f).items():
                cols[part] = dict(c)
        for c, e, before in f.trace:
            if c.acts_on == ActsOn.TOTAL and "F" not in cols:
                cols["F"] = _summed(cols)
            if c.tangent is None:  # an effect without derivatives: every column is differenced
                return {}
            c.tangent(self, f.data, f.p, f, e, cols, before)
        F = cols["F"] if "F" in cols else _summed(cols)
        return {k: f.data.through_source(c) for k, c in F.items()}

    def forces(self, d, p):
        """Model.force's Forces, every stage's result in it."""
        f = Forces(d)
        f.p = p
        staged = sorted(((EFFECTS[e.split(":")[0]], e) for e in self.effects), key=lambda ce: ORDER.index(ce[0].name))
        for c, e in staged:
            if c.acts_on == ActsOn.MOTION:
                c.apply(self, d, p, f, e)
        f.Fd, f.Fg, f.Ff, f.slope = self.base.parts(d, p, f.x, f.v, f.tau)
        for c, e in staged:
            if c.acts_on == ActsOn.PARTS:
                f.trace.append((c, e, f.state()))
                c.apply(self, d, p, f, e)
        f.F = f.Fd + f.Fg + f.Ff
        for c, e in staged:
            if c.acts_on == ActsOn.TOTAL:
                f.trace.append((c, e, f.state()))
                c.apply(self, d, p, f, e)
        f.F = d.through_source(f.F)  # as the file's force was written (records/source_filter.py)
        return f


def _summed(cols):
    """The total's columns: each parameter's in the parts summed."""
    out = {}
    for part in ("Fd", "Fg", "Ff"):
        for k, c in cols[part].items():
            out[k] = out[k] + c if k in out else c
    return out




class Forces:
    """What Model.force builds, stage by stage: the motion the force answers, the
    baseline's parts (damping, gas, friction, the damping slope) and the total [N]."""

    def __init__(self, d):
        self.data = d
        self.x, self.v, self.a, self.t, self.tau = d.x, d.v, d.a, d.t, 0.0
        self.Fd = self.Fg = self.Ff = self.F = self.slope = None
        self.bases = {}  # {term: (the part it adds to, its basis)} (terms.add)
        self.trace = []  # [(Effect, effect id, the parts before it acted)]: what Model.columns walks

    def state(self):
        return {"Fd": self.Fd, "Fg": self.Fg, "Ff": self.Ff, "F": self.F}


def refereed(effects: dict[str, Effect]) -> dict[str, Effect]:
    """effects, each referee checked: a named referee is a term of them, and an effect of
    the damper that follows the temperature names one in time (while the temperature only
    rises, the recording cannot tell the two apart): one without it fails here, at import,
    instead of being named without facing a stand-in."""
    in_time = sorted(n for n, e in effects.items() if e.nature == Nature.OPEN and Variable.TIME in e.depends_on)
    for n, e in effects.items():
        if e.referee and e.referee not in effects:
            raise ValueError(f"effect {n!r}: its referee {e.referee!r} is no effect or term")
        if (Variable.TEMPERATURE in e.depends_on and e.nature in (Nature.PHYSICS, Nature.OPEN)
                and e.referee not in in_time):
            raise ValueError(f"effect {n!r} follows the temperature: its referee must be the same shape in time, "
                             f"one of {', '.join(in_time)}")
    return effects


# the catalogue and the open terms (models/diagnose/terms.py), which compete in every round
EFFECTS = refereed({**CATALOGUE, **TERMS})
# the cell's part of every model the diagnosis fits, from the baseline on (needs="baseline")
WITH_BASELINE = [n for n, e in EFFECTS.items() if e.needs == Needs.BASELINE]
# the order the effects act in (Effect.order)
ORDER = tuple(sorted(EFFECTS, key=lambda n: EFFECTS[n].order))
