"""Commissioning a cell (`dyno rig zero`): a plan of a hold at mid-stroke, where the load
cell is tared and the position referenced, then a slow sine, along which the LVT's
velocity is checked against the LVDT's derivative. Not a test: nothing is recorded."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.recording import segments
from protocols.plan import RigInfo, Segment

NAME = "zero"
LVT_TOLERANCE = 0.05  # the LVT's gain against the LVDT's derivative: more than 5 % off is reported (a wrong gain, not jitter)


@dataclass
class Params:
    hold_s: float = 2.0
    amplitude_mm: float = 2.0
    freq_hz: float = 1.0
    cycles: int = 3


def check(p: Params, rig: RigInfo):
    return []


def plan(p: Params, rig: RigInfo):
    yield Segment("zero hold", {"x_mm": 1e3 * rig.x_mid}, p.hold_s, lambda t: rig.x_mid, kind="hold")
    A, w = p.amplitude_mm / 1e3, 2 * math.pi * p.freq_hz
    yield Segment(f"lvt check {p.amplitude_mm:g} mm {p.freq_hz:g} Hz",
                  {"freq_hz": p.freq_hz, "cycles": p.cycles, "kind": "sine"}, p.cycles / p.freq_hz,
                  lambda t: rig.x_mid + A * math.sin(w * t), kind="sine")


def findings(channels, events):
    """{force_mean [N], x_mean [m] over the hold's second half; lvt_gain [-]: the LVT's
    velocity amplitude over the LVDT's derivative's along the sine}."""
    (_, _, h0, h1), (_, p, s0, s1) = segments(events)
    out = {}
    for name in ("force", "x"):
        t, y = channels[name]
        k = (t >= 0.5 * (h0 + h1)) & (t <= h1)
        out[f"{name}_mean"] = float(np.mean(y[k]))
    # amplitudes of the sine fitted to each: the LVT's over the LVDT's times omega (neither
    # noise nor a lag between the two biases a fitted amplitude)
    w = 2 * np.pi * p["freq_hz"]
    amp = []
    for name in ("x", "v"):
        t, y = channels[name]
        k = (t >= s0) & (t <= s1)
        A = np.column_stack([np.sin(w * t[k]), np.cos(w * t[k]), np.ones(int(k.sum()))])
        c = np.linalg.lstsq(A, y[k], rcond=None)[0]
        amp.append(float(np.hypot(c[0], c[1])))
    out["lvt_gain"] = amp[1] / (w * amp[0])
    return out
