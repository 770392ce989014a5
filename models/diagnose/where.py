"""Where a residual lives (regions of the motion, judged against the force level) and
what an accepted effect is (its size, region, elastic or dissipative, nature)."""
from __future__ import annotations

import numpy as np

from models.diagnose.candidates import EFFECTS
from models.diagnose.data import Data
from models.diagnose.spec import Needs

GAIN_ERROR = 0.02  # a load cell's and a valve curve's proportional misfit: the share of the force a residual is judged against


CHARACTER = 2.0  # one part's variance over the other's for an effect to be said elastic or dissipative
REGION_SHARE = 0.25  # where an effect lives: where its RMS is above this share of its largest


def _segment_peak(d: Data, y):
    """Each sample's segment's largest y (0 for a segment none of d's samples are in: the
    samples taken may leave a segment out)."""
    peak = np.zeros(len(d.segments))
    np.maximum.at(peak, d.segment, y)
    return peak[d.segment]


def locate(d: Data, r: np.ndarray, sigma: float = 0.0) -> list[dict]:
    """[{where, energy_share, sample_share, mean_residual}] of regions holding more than
    their share of the residual energy, strongest concentration first. The residual is
    judged against the force level (each sample's square weighed by 1 / (sigma^2 +
    (GAIN_ERROR F)^2)), so that a proportional misfit does not point at the high-force
    bins, and over single variables and pairs (stroke band x direction, speed x direction)."""
    E = r ** 2 / np.maximum(sigma ** 2 + (GAIN_ERROR * d.F) ** 2, 1e-30)
    tot = max(E.sum(), 1e-30)
    vpk, apk = _segment_peak(d, np.abs(d.v)), _segment_peak(d, np.abs(d.a))
    Fr = np.ptp(d.F)
    regions = {
        "in compression (v > 0)": d.v > 0,
        "in rebound (v < 0)": d.v < 0,
        "near velocity reversal (|v| < 5 % of the segment's peak)": np.abs(d.v) < 0.05 * vpk,
        "at high speed (|v| > 80 % of the segment's peak)": np.abs(d.v) > 0.8 * vpk,
        "near force zero-crossing (|F| < 5 % of its range)": np.abs(d.F) < 0.05 * Fr,
        "at high acceleration (|a| > 80 % of the segment's peak)":
            np.abs(d.a) > 0.8 * apk,
    }
    lo, hi = np.percentile(d.x, [20, 80])
    regions[f"at the compressed end (x > {hi * 1e3:.1f} mm)"] = d.x > hi
    regions[f"at the extended end (x < {lo * 1e3:.1f} mm)"] = d.x < lo
    mid = (d.x > np.percentile(d.x, 40)) & (d.x < np.percentile(d.x, 60))
    regions[f"mid-stroke ({np.percentile(d.x, 40) * 1e3:.1f}-{np.percentile(d.x, 60) * 1e3:.1f} mm)"] = mid
    for s, (name, _f) in enumerate(d.segments):
        regions[f"in segment {name}"] = d.segment == s
    bands = np.linspace(d.x.min(), d.x.max(), 6)
    for a, b in zip(bands[:-1], bands[1:]):
        band = (d.x >= a) & (d.x <= b)
        for word, side in (("compression", d.v > 0), ("rebound", d.v < 0)):
            regions[f"at displacement {a * 1e3:.1f}-{b * 1e3:.1f} mm in {word}"] = band & side
    for word, side in (("compression", d.v > 0), ("rebound", d.v < 0)):
        regions[f"at low speed in {word} (|v| < 30 % of the segment's peak)"] = side & (np.abs(d.v) < 0.3 * vpk)
        regions[f"at high speed in {word} (|v| > 70 % of the segment's peak)"] = side & (np.abs(d.v) > 0.7 * vpk)
    if d.T is not None:
        Tq = np.percentile(d.T, 75)
        regions[f"when hottest (T > {Tq - 273.15:.1f} C)"] = d.T > Tq
    out = []
    for where, k in regions.items():
        n = k.mean()
        if n < 0.01 or n > 0.9:
            continue
        share = E[k].sum() / tot
        out.append({"where": where, "energy_share": float(share), "sample_share": float(n),
                    "mean_residual": float(np.mean(r[k])), "concentration": float(share / n)})
    out.sort(key=lambda o: -o["concentration"])
    lag = best_lag(d, r)
    if lag is not None:
        out.append(lag)
    return out


def best_lag(d: Data, r: np.ndarray) -> dict | None:
    """The residual against the force's rate of change: what timing it leans to beyond the
    model's own (Diagnosis.channel_timing, the recording's one timing figure). A force later than
    the model's by lag leaves residual = -lag dF/dt; lag_s is in the timing's sign (negative:
    the force later)."""
    dF = np.gradient(d.F, d.t)
    same = np.r_[True, np.diff(d.cycle) == 0]
    k = same & np.isfinite(dF)
    denom = float(np.sum(dF[k] ** 2))
    if denom <= 0:
        return None
    lag = -float(np.sum(r[k] * dF[k]) / denom)
    share = float(np.sum((lag * dF[k]) ** 2) / max(np.sum(r[k] ** 2), 1e-30))
    return {"where": f"a further timing of {-1e3 * lag:+.3f} ms beyond the model's (negative: the force later)",
            "energy_share": share, "sample_share": 1.0, "mean_residual": 0.0, "concentration": share,
            "lag_s": -lag}


def describe(d: Data, effect: str, change: np.ndarray, k: np.ndarray) -> dict:
    """What an accepted effect is, from what accepting it changed in the held-out
    prediction (`change` [N], its force and the refit of the rest, over the samples k): its
    size (RMS and peak [N]), where it lives (the band of the variable it depends on where
    its RMS is above REGION_SHARE of its largest, and the directions that hold a quarter of its energy or
    more), whether it stores or dissipates energy (_character), what it depends on and what kind of thing it
    is (spec.NATURES)."""
    spec = EFFECTS[effect.split(":")[0]]
    c = change[k]
    x, v, t = d.x[k], d.v[k], d.t[k]
    E = c * c
    comp = float(E[v > 0].sum() / max(E.sum(), 1e-30))
    dirs = ("both directions" if 0.25 <= comp <= 0.75 else "in compression" if comp > 0.75 else "in rebound")
    moving = bool({"displacement", "velocity", "direction"} & set(spec.depends_on))
    shape = c
    if "displacement" in spec.depends_on:
        var, scale, unit, name = x, 1e3, "mm", "displacement"
        # less what a straight line in x carries: where a term takes over, the baseline's gas
        # spring gives back the stiffness it had bent to, which is no place of the effect
        A = np.column_stack([np.ones_like(x), x])
        shape = c - A @ np.linalg.lstsq(A, c, rcond=None)[0]
    elif "velocity" in spec.depends_on:
        var, scale, unit, name = np.abs(v), 1.0, "m/s", "speed"
    elif "time" in spec.depends_on:
        var, scale, unit, name = t, 1.0, "s", "time"
    else:
        var = None
    region = dirs if moving else "whatever the motion"
    if var is not None and np.ptp(var) > 0:
        edges = np.linspace(var.min(), var.max(), 13)
        i = np.clip(np.digitize(var, edges) - 1, 0, 11)
        rms = np.sqrt(np.bincount(i, weights=shape ** 2, minlength=12) / np.maximum(np.bincount(i, minlength=12), 1))
        big = np.nonzero(rms >= REGION_SHARE * rms.max())[0]
        region = (f"{name} {edges[big.min()] * scale:.3g}-{edges[big.max() + 1] * scale:.3g} {unit}"
                  + (f", {dirs}" if moving else ""))
    dep = set(spec.depends_on)
    character = ("independent of the motion" if dep <= {"time", "temperature", "aux"}
                 # a force set by the velocity alone stores nothing; one set by the stroke alone, all
                 else "dissipative" if "displacement" not in dep else "elastic" if not dep & {"velocity", "direction"}
                 else _character(c, x, v))
    return {"depends_on": list(spec.depends_on), "nature": spec.nature, "region": region, "character": character,
            "size_rms_n": float(np.sqrt(np.mean(E))), "size_peak_n": float(np.max(np.abs(c))),
            **({"tone_hz": d.tone_hz} if spec.needs == Needs.TONE else {})}


def _character(c, x, v):
    """"elastic", "dissipative" or both: how much of the force c [N] is a function of the
    stroke alone, alike both ways (it stores energy: a spring), against how much turns
    with the direction of travel at the same stroke (it takes work from the rod over a
    cycle: damping, friction, hysteresis), each the variance of its bin means over 12
    stroke bands; one is said when it is at least CHARACTER times the other."""
    i = np.clip(np.digitize(x, np.linspace(x.min(), x.max(), 13)) - 1, 0, 11)
    j = i * 2 + (v > 0)
    mean = (lambda g, n: np.bincount(g, weights=c, minlength=n) / np.maximum(np.bincount(g, minlength=n), 1))
    along = mean(i, 12)[i]
    turning = mean(j, 24)[j] - along
    e, o = float(np.var(along)), float(np.var(turning))
    return "elastic" if e >= CHARACTER * o else "dissipative" if o >= CHARACTER * e else "both elastic and dissipative"
