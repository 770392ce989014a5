"""Effects hidden in a copy of a real recording (`dyno prove --on`): the proof on a file
that carries its own unmodelled physics, filters and noise, and what a diagnosis of that
file can and cannot see. What is hidden, how it is sized and what counts as finding it are
data (hiding.toml); here, the force each adds and the bisection that sizes it.

An effect of the catalogue adds its own force along the recorded motion: the minimal
baseline fitted to the untouched file (its values from that file's diagnosis) with the
effect, less the baseline alone, through the source's filter as the file was written. A
cell fault changes the force channel: delayed (a lag), a zero or a gain drifting linearly
over the run, a causal 2nd-order Butterworth low-pass. Temperature effects need a body
temperature: a file without one gets the heat-gun run's, rising linearly from
HEAT_RAMP_K[0] to [1] over the file, in the copy and in an untouched copy alike.
SI units inside: N, m, s, K.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from models.diagnose.candidates import WITH_BASELINE, Model
from models.diagnose.data import Data
from records.data import Channels

HEAT_RAMP_K = (301.15, 333.15)  # K: 28 to 60 C, a body heated with a heat gun over the run (the run)
BISECTIONS = 30  # halvings of the value's range: a size within 1e-9 of its range (log or linear)
T_CHANNEL = "T_body"


@dataclass(frozen=True)
class HiddenInFile:
    """One thing hidden: a catalogue effect ("effect") or a fault of the cell ("cell")."""
    name: str
    kind: str
    param: str  # the value that sizes it (an effect's parameter; a fault's own)
    unit: str  # as shown: value x factor (or its inverse: a filter's cut-off)
    factor: float
    off: float  # the value at which nothing is hidden
    far: float  # the largest value tried
    scale: str  # "log" or "linear" between off and far
    found: tuple  # diagnosis names that count as finding it
    dependence: tuple = ()  # what it depends on, said by another finding
    fixed: dict = field(default_factory=dict)  # the effect's other parameters
    shape: tuple = ()  # coefficients a basis effect's value multiplies
    temperature: bool = False  # needs a body temperature
    inverse: bool = False
    what: str = ""
    fault: str = ""  # a cell fault's form: delay, offset, scale or lowpass (hiding.toml)
    below_peak: str = ""  # a cap: this parameter set to (1 - value) times the force's compression peak
    peaks: dict = field(default_factory=dict)  # parameters set to these multiples of the largest |force|

    def shown(self, value: float) -> float:
        """The value in the unit shown."""
        return (1.0 / value if value else float("inf")) if self.inverse else value * self.factor


def catalogue() -> dict[str, HiddenInFile]:
    """{name: Hidden} of hiding.toml, effects then the cell's faults."""
    doc = tomllib.loads((Path(__file__).with_name("hiding.toml")).read_text())
    out = {}
    for kind in ("effect", "cell"):
        for name, e in doc[kind].items():
            out[name] = HiddenInFile(name, kind, e.get("param", name), e["unit"], e["factor"], e["off"], e["far"],
                               e["scale"], tuple(e["found"]), tuple(e.get("dependence", ())), e.get("fixed", {}),
                               tuple(e.get("shape", ())), e.get("temperature", False), e.get("inverse", False),
                               e.get("what", ""), e.get("fault", ""), e.get("below_peak", ""),
                               e.get("peaks", {}))
    return out


def with_heat(channels: Channels) -> Channels:
    """The channels with the heat-gun temperature ramp as T_body when they have no body
    temperature, else themselves."""
    if any(n in channels for n in ("T_body", "temperature", "T_reservoir")):
        return channels
    t = channels["force"][0]
    u = (t - t[0]) / max(t[-1] - t[0], 1e-9)
    return {**channels, T_CHANNEL: (t, HEAT_RAMP_K[0] + (HEAT_RAMP_K[1] - HEAT_RAMP_K[0]) * u)}


def added(hidden: HiddenInFile, d: Data, base: dict, value: float) -> np.ndarray:
    """The force [N] the effect adds along d's samples at value (base: the baseline's
    fitted values, the cell's alignment with them)."""
    cell = list(WITH_BASELINE)
    m0, m1 = Model(d, cell), Model(d, cell + [hidden.name])
    p = {q.name: q.x0 for q in m1.params}
    p.update({k: v for k, v in base.items() if k in p})
    p.update(hidden.fixed)
    if hidden.shape:
        p.update({f"{hidden.param}{i}": value * c for i, c in enumerate(hidden.shape)})
    elif hidden.below_peak:  # a cap below the compression peak (the others far beyond the force)
        p.update({k: c * float(np.max(np.abs(d.F))) for k, c in hidden.peaks.items()})
        p[hidden.below_peak] = (1 - value) * float(np.max(d.F))
    else:
        p[hidden.param] = value
    return m1.force(d, p) - m0.force(d, {k: v for k, v in p.items() if k in {q.name for q in m0.params}})


def fault(hidden: HiddenInFile, t: np.ndarray, F: np.ndarray, value: float) -> np.ndarray:
    """The force channel F [N] at times t [s] with the cell's fault at value."""
    t, F = np.asarray(t, float), np.asarray(F, float)
    u = (t - t[0]) / max(t[-1] - t[0], 1e-9)
    if hidden.fault == "delay":  # the force read value seconds late
        return np.interp(t - value, t, F)
    if hidden.fault == "offset":
        return F + value * u
    if hidden.fault == "scale":
        return F * (1 + value * u)
    if hidden.fault == "lowpass":  # value: the cut-off's period [s]
        from scipy.signal import butter, lfilter, lfilter_zi
        fs = 1.0 / float(np.median(np.diff(t)))
        fc = 1.0 / value
        if fc >= 0.45 * fs:
            return F
        b, a = butter(2, fc, fs=fs)
        return lfilter(b, a, F, zi=lfilter_zi(b, a) * F[0])[0]
    raise ValueError(f"{hidden.name}: no fault form {hidden.fault!r} hiding.py knows")


def copy(hidden: HiddenInFile, channels: Channels, d: Data, base: dict, value: float) -> Channels:
    """The recording's channels with hidden at value: an effect's force added on the force
    channel's clock (nothing outside the stretches the diagnosis reads), or a cell fault."""
    t, F = channels["force"]
    if hidden.kind == "cell":
        return {**channels, "force": (t, fault(hidden, t, F, value))}
    dF = added(hidden, d, base, value)
    on = np.interp(t, d.t, dF, left=0.0, right=0.0)
    near = np.abs(t - d.t[np.clip(np.searchsorted(d.t, t), 0, len(d.t) - 1)]) <= 1.5 * float(np.max(d.h))
    near |= np.abs(t - d.t[np.clip(np.searchsorted(d.t, t) - 1, 0, len(d.t) - 1)]) <= 1.5 * float(np.max(d.h))
    return {**channels, "force": (t, F + np.where(near, on, 0.0))}


def contribution(hidden: HiddenInFile, channels: Channels, d: Data, base: dict, value: float) -> float:
    """RMS [N] of what hidden at value adds to the force over d's samples."""
    if hidden.kind == "cell":
        t, F = channels["force"]
        dF = np.interp(d.t, t, fault(hidden, t, F, value) - F)
    else:
        dF = added(hidden, d, base, value)
    return float(np.sqrt(np.mean(dF ** 2)))


def sized(hidden: HiddenInFile, channels: Channels, d: Data, base: dict, target: float) -> tuple[float | None, float]:
    """(value, its contribution [N]): the value whose RMS contribution is target [N], by
    bisection between off and far; (None, largest contribution) when even far adds less
    (a friction effect on a baseline with no friction)."""
    def at(s):
        return (hidden.off * (hidden.far / hidden.off) ** s if hidden.scale == "log"
                else hidden.off + s * (hidden.far - hidden.off))
    top = contribution(hidden, channels, d, base, at(1.0))
    if not top >= target:
        return None, top
    lo, hi = 0.0, 1.0
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if contribution(hidden, channels, d, base, at(mid)) < target else (lo, mid)
    value = float(f"{at(hi):.4g}")
    return value, contribution(hidden, channels, d, base, value)
