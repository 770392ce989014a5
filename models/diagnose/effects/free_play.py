"""Clearance (free play) in the damper's mounts: the load cell reads zero while the mount
crosses it (kernels.plateau), with its exact tangent."""

from __future__ import annotations

import numpy as np

from models.diagnose import kernels
from models.diagnose.forms import fixed
from models.diagnose.spec import Effect, P


# the force channel's averaging time, in sample periods: a first-order anti-alias filter at Nyquist
# averages over about 0.6 of one (a choice; the data cannot tell it from a short clearance crossing's size)
W_FORCE = 0.5


def _free_play(m, d, p, f, e):
    f.F = kernels.plateau(f.F, f.slope(), f.t, p["c_play"], W_FORCE * m.h)


def _free_play_tangent(m, d, p, f, e, cols, before):
    # the clearance changes the derivatives only about each crossing (plateau_reach): they are
    # worked out there, from the slope's derivatives there, and copied elsewhere
    S, c, W = f.slope(), p["c_play"], W_FORCE * m.h
    reach = kernels.plateau_reach(before["F"], S, f.t, c, W)
    at = reach[0]
    dS = m.base.slope_columns(f, at) if hasattr(m.base, "slope_columns") else {}
    names = list(dict.fromkeys([*cols["F"], "c_play"]))
    zero = np.zeros(len(at))
    near = kernels.plateau_tangent(
        before["F"],
        S,
        f.t,
        W,
        reach,
        np.array([cols["F"][k][at] if k in cols["F"] else zero for k in names]),
        np.array([dS.get(k, zero) for k in names]),
        np.array([1.0 if k == "c_play" else 0.0 for k in names]),
    )
    out = {}
    for k, row in zip(names, near):
        out[k] = np.array(cols["F"][k]) if k in cols["F"] else np.zeros(len(S))
        out[k][at] = row
    cols["F"] = out


def _words(step, sample_s):
    """Under a micrometre: crossed within a sample, its size uncertain; else the general sentence."""
    c = step.parameters["c_play"]
    if c >= 1e-6:
        return None
    return (f"The force dips towards zero for less than a sample each time it changes sign: a clearance of "
            f"roughly {c * 1e6:.2g} um crossed that fast (at this sample rate its size is uncertain by a "
            f"factor of two or three), in the damper's mounts or bearings. Check the rod-end and eye bushes.")


EFFECT = Effect(
    "free_play",
    "clearance (free play) in the damper's mounts",
    params=fixed(
        P("c_play", 2e-05, 0.0, 0.005, "m", (0.0, 1e-07, 3e-07, 1e-06, 3e-06, 1e-05, 3e-05, 0.0001, 0.0003, 0.001))
    ),
    estimate="c_play",
    apply=_free_play,
    tangent=_free_play_tangent,
    acts_on="total",
    depends_on=("velocity", "direction"),
    words=_words,
    listed=30,
    order=220,
    say=(
        "The force sits at zero while the mount travels {v} {u} (relative to the rod, which floats meanwhile"
        " where the damper's own force on it is zero) each time it changes sign: clearance in the damper's "
        "mounts or bearings. Check the rod-end and eye bushes.",
        "c_play",
        1000.0,
        "mm",
    ),
)
