"""The diagnosis's models: the minimal baseline and the catalogue of physics it may have
left out, each a small model with bounded parameters (arrays in, force out, N).

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

from models.diagnose import kernels, terms
from models.diagnose.valves import VALVES, damping_grad, slope, slope_grad, damping
from models.diagnose.spec import V_EPS, Effect, P
from models.diagnose.terms import TERMS

GAMMA = 1.38  # thesis section 4.1.2
# the force channel's averaging time, in sample periods: a first-order anti-alias filter at Nyquist
# averages over about 0.6 of one (a choice; the data cannot tell it from a short clearance crossing's size)
W_FORCE = 0.5
FRICTION_KNOTS = 8  # basis functions of position_friction over the stroke


@kernels.recent
def _gas(x, x_m, G0, L):
    return G0 * (L / np.maximum(L - (x - x_m), 1e-3 * L)) ** GAMMA


def gas(x, x_m, p):
    """Gas force [N]: polytropic about x_m (eq 3.19)."""
    return _gas(x, x_m, p["G0"], p["L"])


def baseline_params(d):
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


@kernels.recent
def soft_sign(v):
    """A friction's direction, softened over V_EPS [m/s]."""
    return np.tanh(v / V_EPS)


@kernels.recent
def shift(y, t, tau):
    """y [any unit] at t - tau [s] (linear between samples)."""
    return np.interp(t - tau, t, y)


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

    def slope_columns(self, f):
        """{parameter: the damping slope's derivative} along the Forces' motion."""
        return dict(zip(VALVES, slope_grad(f.v, f.p)))

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
        difference; so is every one an effect without a tangent changes."""
        cols = {"Fd": {}, "Fg": {}, "Ff": {}}
        if hasattr(self.base, "columns"):
            for part, c in self.base.columns(f).items():
                cols[part] = dict(c)
        for c, e, before in f.trace:
            if c.acts_on == "total" and "F" not in cols:
                cols["F"] = _summed(cols)
            if c.tangent is not None:
                c.tangent(self, f.data, f.p, f, e, cols, before)
            else:  # what it changes is left to differences
                for part in c.alters or ("F",):
                    cols[part] = {}
        F = cols.get("F") or _summed(cols)
        return {k: f.data.through_source(np.broadcast_to(c, f.F.shape)) for k, c in F.items()}

    def forces(self, d, p):
        """Model.force's Forces, every stage's result in it."""
        f = Forces(d)
        f.p = p
        staged = sorted(((EFFECTS[e.split(":")[0]], e) for e in self.effects), key=lambda ce: ORDER.index(ce[0].name))
        for c, e in staged:
            if c.acts_on == "motion":
                c.apply(self, d, p, f, e)
        f.Fd, f.Fg, f.Ff, f.slope = self.base.parts(d, p, f.x, f.v, f.tau)
        for c, e in staged:
            if c.acts_on == "parts":
                f.trace.append((c, e, f.state()))
                c.apply(self, d, p, f, e)
        f.F = f.Fd + f.Fg + f.Ff
        for c, e in staged:
            if c.acts_on == "total":
                f.trace.append((c, e, f.state()))
                c.apply(self, d, p, f, e)
        f.F = d.through_source(f.F)  # as the file's force was written (models/source_filter.py)
        return f


def _summed(cols):
    """The total's columns: each parameter's in the parts summed."""
    out = {}
    for part in ("Fd", "Fg", "Ff"):
        for k, c in cols[part].items():
            out[k] = out[k] + c if k in out else c
    return out


def _scaled(cols, part, g):
    """The part multiplied by g: its columns too."""
    cols[part] = {k: c * g for k, c in cols[part].items()}


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


_bouc_wen, _dahl = kernels.recent(kernels.bouc_wen), kernels.recent(kernels.dahl)


# the forms of the catalogue's effects: (model, data, values, Forces, effect id) -> None
def _timing(name):
    """A timing offset's force: the motion shifted by the parameter `name` [s]."""
    def apply(m, d, p, f, e):
        f.tau = p[name]
        if f.tau:  # the force answers the motion tau earlier than stamped
            f.x, f.v, f.a = shift(f.x, f.t, -f.tau), shift(f.v, f.t, -f.tau), shift(f.a, f.t, -f.tau)
    return apply


# the channels' alignment fitted with the baseline, within this share of a sample period
# either way: a cell in good order (docs/diagnosis.md: wider, it takes a compressible oil's lag)
ALIGNMENT = 0.1


def _alignment_params(d, e):
    h = float(np.median(d.h))
    return [P("tau_0", 0.0, -ALIGNMENT * h, ALIGNMENT * h, "s")]


def _damping_temperature(m, d, p, f, e):
    f.Fd = f.Fd * (1 + p["k_dT"] * (d.T - m.T_m))


def _damping_temperature_tangent(m, d, p, f, e, cols, before):
    dT = d.T - m.T_m
    _scaled(cols, "Fd", 1 + p["k_dT"] * dT)
    cols["Fd"]["k_dT"] = before["Fd"] * dT


def _compressibility(m, d, p, f, e):  # the valve in series with the oil's spring
    f.Fd = kernels.lag(f.Fd, f.slope() * p["inv_k_oil"], d.h)


def _compressibility_tangent(m, d, p, f, e, cols, before):
    # the lag's time constant is the slope times the compliance: both move it
    S, inv_k = f.slope(), p["inv_k_oil"]
    dS = m.base.slope_columns(f) if hasattr(m.base, "slope_columns") else {}
    names = list(dict.fromkeys([*cols["Fd"], *dS, "inv_k_oil"]))
    zero = np.zeros(len(S))
    dF = np.array([cols["Fd"].get(k, zero) for k in names])
    dtau = np.array([S if k == "inv_k_oil" else inv_k * dS[k] if k in dS else zero for k in names])
    out = kernels.lag_tangent(before["Fd"], S * inv_k, d.h, f.Fd, dF, dtau)
    cols["Fd"] = dict(zip(names, out))


def _gas_temperature(m, d, p, f, e):
    f.Fg = f.Fg * (1 + p["k_gT"] * (d.T - m.T_m))


def _gas_temperature_tangent(m, d, p, f, e, cols, before):
    dT = d.T - m.T_m
    _scaled(cols, "Fg", 1 + p["k_gT"] * dT)
    cols["Fg"]["k_gT"] = before["Fg"] * dT


def _position_friction(m, d, p, f, e):
    # extra friction along the stroke, sgn(v) B(x) [N]: a smooth basis over the recorded
    # stroke rather than a law, since a tight spot, a worn band or a step in the bore each
    # have their own shape (the thesis's friction is a constant, eq 3.3)
    B = terms.cached(m, d, e, lambda ref, dd: terms.x_basis(ref, dd, FRICTION_KNOTS))
    f.Ff = f.Ff + (B @ np.array([p[f"pf{i}"] for i in range(B.shape[1])])) * soft_sign(f.v)


def _position_friction_tangent(m, d, p, f, e, cols, before):
    B = terms.cached(m, d, e, lambda ref, dd: terms.x_basis(ref, dd, FRICTION_KNOTS))
    ss = soft_sign(f.v)
    cols["Ff"].update({f"pf{i}": B[:, i] * ss for i in range(B.shape[1])})


def _breakaway_friction(m, d, p, f, e):
    # the seal grips harder near rest, falling to sliding friction with speed (the
    # thesis's friction falls with velocity, section 3.2.1); Stribeck's curve with its
    # exponent free: 1 exponential, 2 Gaussian, between and beyond as the seal shows
    f.Ff = f.Ff * (1 + (p["r_break"] - 1) * np.exp(-(np.abs(f.v) / p["v_break"]) ** p["d_break"]))


def _breakaway_friction_tangent(m, d, p, f, e, cols, before):
    r, vb, n = p["r_break"], p["v_break"], p["d_break"]
    u = np.abs(f.v) / vb
    un = u ** n
    E = np.exp(-un)
    _scaled(cols, "Ff", 1 + (r - 1) * E)
    Ff = before["Ff"]
    cols["Ff"].update({"r_break": Ff * E, "v_break": Ff * (r - 1) * E * n * un / vb,
                       "d_break": -Ff * (r - 1) * E * un * np.log(np.where(u > 0, u, 1.0))})


def _presliding_friction(m, d, p, f, e):
    # the seal deforms before it slides: its friction builds over x_stick of travel after
    # each reversal (Dahl), where the baseline's Coulomb law switches at once (eq 3.3)
    f.Ff = m.base.friction_level(p) * _dahl(f.x, d.t, d.h, p["x_stick"])


def _presliding_friction_tangent(m, d, p, f, e, cols, before):
    # the friction is replaced: its level's derivative times the state, and the state's in x_stick
    xs = p["x_stick"]
    travel = np.abs(np.diff(f.x, prepend=f.x[:1]))
    decay = np.exp(-travel / xs)
    z = _dahl(f.x, d.t, d.h, xs)
    level = m.base.friction_columns(p) if hasattr(m.base, "friction_columns") else {}
    cols["Ff"] = {k: z * g for k, g in level.items()}
    dz = kernels.dahl_tangent(f.x, d.t, d.h, decay, z, decay * travel / xs ** 2)
    cols["Ff"]["x_stick"] = m.base.friction_level(p) * dz


def _bouc_wen_force(m, d, p, f, e):
    # Spencer's phenomenological MR model: a Bouc-Wen element in parallel with the
    # baseline's viscous (valve) and stiffness (gas) terms; with an aux channel, its size
    # follows that channel through a first-order lag (the coil's current behind its voltage)
    alpha = p["alpha_bw"]
    if ":" in e:
        n = e.split(":", 1)[1]
        u = kernels.lag(d.aux[n], np.full(len(d.t), p[f"eta:{n}"]), d.h) - m.aux_m[n]
        alpha = alpha + p[f"alpha_u:{n}"] * u
    f.F = f.F + alpha * _bouc_wen(f.x, d.t, d.h, p["x_y"], p["gamma_bw"])


def _bouc_wen_tangent(m, d, p, f, e, cols, before):
    # its size's derivatives; the yield's shape (x_y, gamma_bw) and a coil's lag are left to differences
    z = _bouc_wen(f.x, d.t, d.h, p["x_y"], p["gamma_bw"])
    cols["F"]["alpha_bw"] = z
    if ":" in e:
        n = e.split(":", 1)[1]
        u = kernels.lag(d.aux[n], np.full(len(d.t), p[f"eta:{n}"]), d.h) - m.aux_m[n]
        cols["F"][f"alpha_u:{n}"] = u * z


def _fluid_inertia(m, d, p, f, e):
    f.F = f.F + p["m_oil"] * f.a


def _fluid_inertia_tangent(m, d, p, f, e, cols, before):
    cols["F"]["m_oil"] = f.a


def _aux_channel(m, d, p, f, e):
    name = e.split(":", 1)[1]
    u = shift(d.aux[name], f.t, p[f"lag:{name}"]) - m.aux_m[name]
    f.F = f.F + (p[f"b0:{name}"] + p[f"b1:{name}"] * f.Fd) * u


def _aux_channel_tangent(m, d, p, f, e, cols, before):
    # the channel's lag is left to differences
    name = e.split(":", 1)[1]
    u = shift(d.aux[name], f.t, p[f"lag:{name}"]) - m.aux_m[name]
    b1u = p[f"b1:{name}"] * u
    for k, c in cols["Fd"].items():
        cols["F"][k] = cols["F"].get(k, 0.0) + b1u * c
    cols["F"].update({f"b0:{name}": u, f"b1:{name}": f.Fd * u})


def _cavitation(m, d, p, f, e):
    # the force cannot rise past what the chambers hold; in compression that is the gas
    # pressure on the piston less the floor on the annulus, so the cap follows the gas
    # force (times about A_p / A_r)
    cap = p["Fcav_c"] + p["kcav"] * (f.Fg - m.Fg_m)
    f.F = np.where(f.v > 0, np.minimum(f.F, cap), np.maximum(f.F, -p["Fcav_r"]))


def _cavitation_tangent(m, d, p, f, e, cols, before):
    F, kcav = before["F"], p["kcav"]
    cap = p["Fcav_c"] + kcav * (f.Fg - m.Fg_m)
    up, down = (f.v > 0) & (cap < F), (f.v <= 0) & (F < -p["Fcav_r"])  # where a cap holds the force
    free = ~(up | down)
    out = {k: np.where(free, c, 0.0) for k, c in cols["F"].items()}
    for k, c in cols["Fg"].items():
        out[k] = out.get(k, 0.0) + np.where(up, kcav * c, 0.0)
    out.update({"Fcav_c": up * 1.0, "kcav": np.where(up, f.Fg - m.Fg_m, 0.0), "Fcav_r": -1.0 * down})
    cols["F"] = out


def _free_play(m, d, p, f, e):
    f.F = kernels.plateau(f.F, f.slope(), f.t, p["c_play"], W_FORCE * m.h)


def _free_play_tangent(m, d, p, f, e, cols, before):
    S = f.slope()
    dS = m.base.slope_columns(f) if hasattr(m.base, "slope_columns") else {}
    names = list(dict.fromkeys([*cols["F"], "c_play"]))
    zero = np.zeros(len(S))
    out = kernels.plateau_tangent(before["F"], S, f.t, p["c_play"], W_FORCE * m.h,
                                  np.array([cols["F"].get(k, zero) for k in names]),
                                  np.array([dS.get(k, zero) for k in names]),
                                  np.array([1.0 if k == "c_play" else 0.0 for k in names]))
    cols["F"] = dict(zip(names, out))


def _p(*ps):
    return lambda d, e: list(ps)


def _aux_params(d, e):
    n = e.split(":", 1)[1]
    s = float(np.std(d.aux[n])) or 1.0
    Fs = float(np.std(d.F)) or 1.0
    return [P(f"b0:{n}", 0.0, -10 * Fs / s, 10 * Fs / s, "N per unit"), P(f"b1:{n}", 0.0, -1 / s, 1 / s, "per unit"),
            P(f"lag:{n}", 0.0, 0.0, 0.2, "s", (0.0, 1e-3, 3e-3, 0.01, 0.03, 0.1))]


def _bw_params(d, e):
    Fmax = float(np.percentile(np.abs(d.F), 99)) or 1.0
    ps = [P("alpha_bw", 0.0, -Fmax, 2 * Fmax, "N", tuple(Fmax * np.r_[0.03, 0.1, 0.3])),
          P("x_y", 1e-3, 1e-7, 1e-2, "m", tuple(np.geomspace(1e-6, 3e-3, 8))),
          P("gamma_bw", 0.5, 0.0, 1.0, "-")]
    if ":" in e:
        n = e.split(":", 1)[1]
        s = float(np.std(d.aux[n])) or 1.0
        ps += [P(f"alpha_u:{n}", 0.0, -3 * Fmax / s, 3 * Fmax / s, "N per unit"),
               P(f"eta:{n}", 0.005, 2e-5, 0.05, "s", (2e-4, 2e-3, 1e-2, 3e-2))]
    return ps


def _cav_params(d, e):
    Fmax = float(np.max(np.abs(d.F)))
    fc, fr = float(np.max(d.F)), float(-np.min(d.F))
    return [P("Fcav_c", 1.5 * Fmax, 0.2 * Fmax, 3 * Fmax, "N", tuple(fc * np.r_[0.9, 0.95, 0.98, 0.99, 1.5])),
            P("Fcav_r", 1.5 * Fmax, 0.2 * Fmax, 3 * Fmax, "N", tuple(fr * np.r_[0.9, 0.95, 0.98, 0.99, 1.5])),
            P("kcav", 0.0, 0.0, 30.0, "-", (0.0, 5.0, 10.0))]


CATALOGUE = {e.name: e for e in (
    Effect("alignment", "the channels' alignment within half a sample",
           _alignment_params, estimate="tau_0", apply=_timing("tau_0"), acts_on="motion", depends_on=("time",),
           nature="cell", needs="baseline",
           say=("The {late} by {v} {u}: a timing offset of the cell (a filter or transport lag in a sensor's "
                "signal chain, or the channels' clocks), not the damper.", "tau_0", 1e3, "ms"),
    ),
    Effect("sensor_delay", "a timing offset between the displacement and force channels",
           _p(P("tau", 0.0, -0.05, 0.05, "s", (-2e-2, -2e-3, -2e-4, -2e-5, 0.0, 2e-5, 2e-4, 2e-3, 2e-2))),
           estimate="tau", apply=_timing("tau"), acts_on="motion", depends_on=("time",), nature="cell",
           supersedes="alignment",
           say=("The {late} by {v} {u}: a timing offset of the cell (a filter or transport lag in a sensor's "
                "signal chain, or the channels' clocks), not the damper. Align the channels (or fix the "
                "conditioning) before fitting valves.", "tau", 1e3, "ms"),
    ),
    Effect("free_play", "clearance (free play) in the damper's mounts",
           _p(P("c_play", 2e-5, 0.0, 5e-3, "m", (0.0, 1e-7, 3e-7, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3))),
           estimate="c_play", alters=("F",), apply=_free_play, tangent=_free_play_tangent, acts_on="total", depends_on=("velocity", "direction"),
           say=("The force sits at zero while the mount travels {v} {u} (relative to the rod, which floats "
                "meanwhile where the damper's own force on it is zero) each time it changes sign: "
                "clearance in the damper's mounts or bearings. Check the rod-end and eye bushes.",
                "c_play", 1e3, "mm"),
    ),
    Effect("compressibility", "compressible oil (entrained air) in series with the valves",
           _p(P("inv_k_oil", 1e-8, 0.0, 1e-5, "m/N", (0.0, 1e-9, 1e-8, 1e-7, 1e-6))),
           estimate="inv_k_oil", apply=_compressibility, tangent=_compressibility_tangent, acts_on="parts", depends_on=("velocity", "frequency"),
           alters=("Fd",),
           described=lambda dm: (dm.compressibility.beta_inv is None or dm.compressibility.beta_inv < 1e12  # eq 3.32
                                 or dm.compressibility.air_fraction > 0),
           say=("The force lags the valve curve at high speed as if the oil were a spring of {v} {u} in "
                "series: compressible oil (entrained air). Bleed the damper or raise the gas charge.",
                "inv_k_oil", None, "kN/mm"),
    ),
    Effect("breakaway_friction", "seal friction higher at breakaway than when sliding",
           _p(P("r_break", 1.2, 1.0, 5.0, "-"),
              P("v_break", 5e-3, 2e-4, 0.1, "m/s", tuple(np.geomspace(5e-4, 5e-2, 7))),
              P("d_break", 1.0, 0.5, 3.0, "-", (1.0, 2.0))),
           estimate="r_break", apply=_breakaway_friction, tangent=_breakaway_friction_tangent, acts_on="parts", depends_on=("velocity", "direction"),
           alters=("Ff",),
           say=("Friction is higher just after each velocity reversal, static/dynamic ratio {v}: "
                "seal breakaway. It sets the force near zero velocity; check seal and rod finish.",
                "r_break", 1.0, ""),
    ),
    Effect("position_friction", "seal friction varying along the bore",
           lambda d, e: terms.coefficients("pf", FRICTION_KNOTS, terms.force_bound(d)),
           estimate=None, apply=_position_friction, tangent=_position_friction_tangent, acts_on="parts", depends_on=("displacement", "direction"),
           linear=True,
           say=("Friction changes along the stroke ({region}; {size}): a tight spot or wear in the bore or "
                "seal. Inspect the bore and rod.", None, 1.0, "N"),
    ),
    Effect("gas_temperature", "gas-spring force rising with temperature",
           _p(P("k_gT", 0.0, -0.05, 0.05, "1/K")),
           estimate="k_gT", alters=("Fg",), apply=_gas_temperature, tangent=_gas_temperature_tangent, acts_on="parts", needs="T",
           described=lambda dm: True,  # every damper's gas follows its temperature (eq 3.19)
           depends_on=("temperature", "displacement"), referee="drift",
           say=("The static (gas) force grows {v} {u} per kelvin as the damper warms: the gas charge "
                "is heating. Compare tests at the same temperature or correct the bias.", "k_gT", 100.0, "%"),
    ),
    Effect("damping_temperature", "damping changing with oil temperature",
           _p(P("k_dT", 0.0, -0.05, 0.05, "1/K")),
           estimate="k_dT", alters=("Fd",), apply=_damping_temperature, tangent=_damping_temperature_tangent, acts_on="parts", needs="T",
           depends_on=("temperature", "velocity", "direction"), referee="damping_drift",
           say=("Damping changes {v} {u} per kelvin as the oil warms: oil viscosity/density. Test at "
                "a controlled temperature or use the temperature-corrected model.", "k_dT", 100.0, "%"),
    ),
    Effect("fluid_inertia", "inertia of the oil column accelerated through the valves",
           _p(P("m_oil", 0.0, -20.0, 200.0, "kg", floor=0.0)),
           estimate="m_oil", apply=_fluid_inertia, tangent=_fluid_inertia_tangent, acts_on="total", depends_on=("acceleration",),
           say=("The force carries an acceleration term of {v} {u}: oil column inertia in the valves "
                "(or unsupported mass in the load path). It matters in step and high-frequency tests.",
                "m_oil", 1.0, "kg"),
    ),
    Effect("cavitation", "a chamber cavitating: force capped at high speed", _cav_params,
           estimate="Fcav_c", apply=_cavitation, tangent=_cavitation_tangent, acts_on="total", depends_on=("velocity", "direction", "displacement"),
           alters=("F", "Fg"),
           say=("The force stops rising above {v} {u} at high speed: a chamber cavitates. Raise the gas "
                "charge or check for air.", None, 1.0, "N"),
    ),
    Effect("presliding_friction", "seal friction that builds over a little travel after each reversal (Dahl)",
           _p(P("x_stick", 1e-4, 1e-9, 2e-3, "m", tuple(np.geomspace(1e-8, 1e-3, 11)))),
           estimate="x_stick", apply=_presliding_friction, tangent=_presliding_friction_tangent, acts_on="parts", depends_on=("displacement", "direction"),
           alters=("Ff",),
           say=("Friction builds over {v} {u} of travel after each reversal before the seal slides "
                "(pre-sliding, Dahl): the seal and bushes deform elastically first. It rounds the "
                "corners of small-amplitude loops; keep it in the model when tuning low-speed valving.",
                "x_stick", 1e3, "mm"),
    ),
    Effect("bouc_wen", "a hysteretic force that yields over a little travel (Bouc-Wen, Spencer's MR model)",
           _bw_params, estimate="alpha_bw", apply=_bouc_wen_force, tangent=_bouc_wen_tangent, acts_on="total", needs="aux?",
           depends_on=("displacement", "direction"),
           # {aux}: what it is (words.sentence): an MR fluid only when a channel drives its size
           say=("The force carries a hysteretic part of {v} N that yields over {xy} mm of travel (a Bouc-Wen "
                "element){aux} Model the damper with the hysteretic element (its parameters are in the JSON).",
                "alpha_bw", 1.0, "N"),
    ),
    Effect("aux_channel", "an auxiliary channel changing the force", _aux_params,
           estimate="b1:aux.valve_current", apply=_aux_channel, tangent=_aux_channel_tangent, acts_on="total", needs="aux", depends_on=("aux",),
           alters=("Fd",),
           say=("The force follows {ch} (lag {v} {u}): something that channel measures changes the damping. "
                "Hold it constant or include it in the model.", "lag", 1e3, "ms"),
    ),
)}
# the catalogue and the open terms (models/diagnose/terms.py), which compete in every round
EFFECTS = {**CATALOGUE, **TERMS}
# the cell's part of every model the diagnosis fits, from the baseline on (needs="baseline")
WITH_BASELINE = [n for n, e in EFFECTS.items() if e.needs == "baseline"]
# the order the effects act in, whatever order they were accepted in: multiplications
# of one part, the total's sum, then its caps and the free play's zero-force crossings
ORDER = ("alignment", "sensor_delay", "valve_form", "stroke_damping", "damping_drift", "frequency_damping",
         "damping_temperature", "compressibility", "gas_temperature", "elastic_stroke", "presliding_friction",
         "position_friction", "breakaway_friction", "fluid_inertia", "bouc_wen", "aux_channel", "drift",
         "interference", "temperature_force", "loop_surface", "cavitation", "free_play")
