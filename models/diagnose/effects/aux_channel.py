"""An auxiliary channel changing the force: an offset and a damping gain in proportion
to it, behind a lag."""

from __future__ import annotations

import numpy as np

from models.diagnose.forms import shift
from models.diagnose.spec import Effect, P


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


def _aux_params(d, e):
    n = e.split(":", 1)[1]
    s = float(np.std(d.aux[n])) or 1.0
    Fs = float(np.std(d.F)) or 1.0
    return [
        P(f"b0:{n}", 0.0, -10 * Fs / s, 10 * Fs / s, "N per unit"),
        P(f"b1:{n}", 0.0, -1 / s, 1 / s, "per unit"),
        P(f"lag:{n}", 0.0, 0.0, 0.2, "s", (0.0, 1e-3, 3e-3, 0.01, 0.03, 0.1)),
    ]


def _words(step, sample_s):
    text, _, factor, unit = EFFECT.say
    ch = step.effect.split(":", 1)[1]
    return text.format(ch=ch, v=f"{step.parameters[f'lag:{ch}'] * factor:.1f}", u=unit)


EFFECT = Effect(
    "aux_channel",
    "an auxiliary channel changing the force",
    params=_aux_params,
    estimate="b1:aux.valve_current",
    apply=_aux_channel,
    tangent=_aux_channel_tangent,
    acts_on="total",
    needs="aux",
    depends_on=("aux",),
    words=_words,
    listed=130,
    order=160,
    say=(
        "The force follows {ch} (lag {v} {u}): something that channel measures changes the damping. Hold it "
        "constant or include it in the model.",
        "lag",
        1000.0,
        "ms",
    ),
)
