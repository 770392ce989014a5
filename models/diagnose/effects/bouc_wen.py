"""A hysteretic force that yields over a little travel: Spencer's MR model's Bouc-Wen
element, its size following an aux channel through a lag where one drives it."""

from __future__ import annotations

import numpy as np

from models.diagnose import kernels
from models.diagnose.spec import Effect, P


_bouc_wen = kernels.recent(kernels.bouc_wen)


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


def _bw_params(d, e):
    Fmax = float(np.percentile(np.abs(d.F), 99)) or 1.0
    ps = [
        P("alpha_bw", 0.0, -Fmax, 2 * Fmax, "N", tuple(Fmax * np.r_[0.03, 0.1, 0.3])),
        P("x_y", 1e-3, 1e-7, 1e-2, "m", tuple(np.geomspace(1e-6, 3e-3, 8))),
        P("gamma_bw", 0.5, 0.0, 1.0, "-"),
    ]
    if ":" in e:
        n = e.split(":", 1)[1]
        s = float(np.std(d.aux[n])) or 1.0
        ps += [
            P(f"alpha_u:{n}", 0.0, -3 * Fmax / s, 3 * Fmax / s, "N per unit"),
            P(f"eta:{n}", 0.005, 2e-5, 0.05, "s", (2e-4, 2e-3, 1e-2, 3e-2)),
        ]
    return ps


def _words(step, sample_s):
    p, e = step.parameters, step.effect
    if ":" in e:  # a channel scales it: the MR story (Spencer's phenomenological model)
        ch = e.split(":", 1)[1]
        aux = (f", as in Spencer's magnetorheological damper model: a yield-stress fluid whose yield force "
               f"follows {ch}, {p[f'alpha_u:{ch}']:.3g} N per unit, through a first-order lag of "
               f"{1e3 * p[f'eta:{ch}']:.3g} ms, as an MR damper's follows its coil current, which lags the "
               f"driver's voltage.")
    else:  # no channel drives it: what gives way in any damper, not an MR story
        aux = (": something stiff that gives way at each reversal, which a valve curve cannot follow around the "
               "loops (a seal or bush that deforms before it slides, trapped air; a yield-stress fluid only in "
               "a damper that has one).")
    return EFFECT.say[0].format(v=f"{p['alpha_bw']:.3g}", xy=f"{1e3 * p['x_y']:.3g}", aux=aux)


EFFECT = Effect(
    "bouc_wen",
    "a hysteretic force that yields over a little travel (Bouc-Wen, Spencer's MR model)",
    params=_bw_params,
    estimate="alpha_bw",
    apply=_bouc_wen_force,
    tangent=_bouc_wen_tangent,
    acts_on="total",
    needs="aux?",
    depends_on=("displacement", "direction"),
    short="hysteresis (Bouc-Wen)",
    words=_words,
    listed=120,
    order=150,
    # {aux}: what it is (words.sentence): an MR fluid only when a channel drives its size
    say=(
        "The force carries a hysteretic part of {v} N that yields over {xy} mm of travel (a Bouc-Wen "
        "element){aux} Model the damper with the hysteretic element (its parameters are in the JSON).",
        "alpha_bw",
        1.0,
        "N",
    ),
)
