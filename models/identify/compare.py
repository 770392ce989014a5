"""An identified damper against a known one (the round trip of the whole chain): each
parameter identified versus true with its relative error, and the peak force-velocity
curves (damping plus friction: the force at peak velocity less the gas force) over
0.02-1 m/s in both directions.

Both dampers are compared in the canonical form of identify.canonical.
"""
from __future__ import annotations

import numpy as np

from models.damper import Damper
from models.physics.friction import breakaway_ratio, static_friction
from models.damper import T_STD
from models.identify.parameters import canonical, parameter_value
from models.physics.simulate import simulate, sine

AMPLITUDE = 0.0127  # m: the sine whose frequency sets each peak velocity
SPEEDS = np.geomspace(0.02, 1.0, 12)  # m/s


def friction_at(d: Damper, x, T=T_STD):
    """Dynamic friction magnitude [N] at x [m] and T [K] (eq 3.3): what the model uses,
    whatever the split between the static table and the breakaway ratio."""
    f = d.friction
    return float(static_friction(x, f.x_table, f.F_table) * breakaway_ratio(T, f.C_sfT, f.C_ifT))


def peak_curve(d: Damper, T, speeds=SPEEDS):
    """(compression, rebound) force at peak velocity less the gas force [N], compressible
    model, sine of AMPLITUDE about mid-stroke, last of three cycles."""
    comp, reb = [], []
    for v in speeds:
        f = v / (2 * np.pi * AMPLITUDE)
        t, x, xd = sine(AMPLITUDE, f, 3, d.mid_stroke, samples_per_cycle=800)
        r = simulate(d, t, x, xd, T=T)
        last = t >= 2 / f
        F = r.force - r.gas
        comp.append(F[last][np.argmax(xd[last])])
        reb.append(F[last][np.argmin(xd[last])])
    return np.array(comp), np.array(reb)


def compare(result, truth: Damper, T):
    """{"parameters": [...], "curve": {...}} comparing result.damper with truth at T [K]."""
    tr = canonical(truth)
    ident = result.damper
    rows = []
    for e in result.estimates:
        tv = _true_value(tr, e.name)
        rel = (e.value - tv) / abs(tv) if tv is not None and np.isfinite(tv) and tv != 0 else None
        rows.append({"name": e.name, "identified": e.value, "truth": tv, "rel_error": rel,
                     "ci_low": e.ci_low, "ci_high": e.ci_high, "unit": e.unit, "identifiable": e.identifiable,
                     "note": e.note})
    x_mid = tr.mid_stroke
    f_id, f_tr = friction_at(ident, x_mid), friction_at(tr, x_mid)
    rows.append({"name": "friction at mid-stroke, 20 C", "identified": f_id, "truth": f_tr,
                 "rel_error": (f_id - f_tr) / f_tr, "ci_low": None, "ci_high": None, "unit": "N",
                 "identifiable": True, "note": "static table x breakaway ratio (eq 3.3)"})
    c_id, r_id = peak_curve(ident, T)
    c_tr, r_tr = peak_curve(tr, T)
    err = np.concatenate([(c_id - c_tr) / np.abs(c_tr), (r_id - r_tr) / np.abs(r_tr)])
    # beyond the fastest stroke of the recording the curve is extrapolated: say so
    segs = result.train + result.test
    tested = [max((float(np.max(sign * s.v[s.score_from:])) for s in segs), default=0.0) for sign in (1, -1)]
    inside = np.concatenate([SPEEDS <= tested[0] * 1.05, SPEEDS <= tested[1] * 1.05])
    curve = {"speeds": SPEEDS.tolist(), "T": T, "compression": {"identified": c_id.tolist(), "truth": c_tr.tolist()},
             "rebound": {"identified": r_id.tolist(), "truth": r_tr.tolist()},
             "max_rel_error": float(np.max(np.abs(err))),
             "tested_speed": {"compression": tested[0], "rebound": tested[1]},
             "max_rel_error_tested": float(np.max(np.abs(err[inside]))) if inside.any() else None}
    return {"parameters": rows, "curve": curve}


def _true_value(tr: Damper, name):
    simple = {"P0": ("gas_spring", "P0"), "V0": ("gas_spring", "V0"), "K_voil": ("gas_spring", "K_voil"),
              "K_voint": ("gas_spring", "K_voint")}
    if name in simple:
        a, b = simple[name]
        return float(getattr(getattr(tr, a), b))
    try:
        v = parameter_value(tr, name)
    except AttributeError:
        return None
    return None if v is None or not np.isfinite(v) else v
