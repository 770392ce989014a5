"""A chamber cavitating: the force capped at high speed, the compression cap following the
gas force."""

from __future__ import annotations

import numpy as np

from models.diagnose.spec import Effect, P


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


def _cav_params(d, e):
    Fmax = float(np.max(np.abs(d.F)))
    fc, fr = float(np.max(d.F)), float(-np.min(d.F))
    return [
        P("Fcav_c", 1.5 * Fmax, 0.2 * Fmax, 3 * Fmax, "N", tuple(fc * np.r_[0.9, 0.95, 0.98, 0.99, 1.5])),
        P("Fcav_r", 1.5 * Fmax, 0.2 * Fmax, 3 * Fmax, "N", tuple(fr * np.r_[0.9, 0.95, 0.98, 0.99, 1.5])),
        P("kcav", 0.0, 0.0, 30.0, "-", (0.0, 5.0, 10.0)),
    ]


def _words(step, sample_s):
    text, _, _, unit = EFFECT.say
    return text.format(v=f"{min(step.parameters['Fcav_c'], step.parameters['Fcav_r']):.0f}", u=unit)


EFFECT = Effect(
    "cavitation",
    "a chamber cavitating: force capped at high speed",
    params=_cav_params,
    estimate="Fcav_c",
    apply=_cavitation,
    tangent=_cavitation_tangent,
    acts_on="total",
    depends_on=("velocity", "direction", "displacement"),
    words=_words,
    listed=100,
    order=210,
    say=(
        "The force stops rising above {v} {u} at high speed: a chamber cavitates. Raise the gas charge or "
        "check for air.",
        None,
        1.0,
        "N",
    ),
)
