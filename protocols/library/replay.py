"""Replay a measured damper displacement history, iterating the drive until the damper
follows it (iterative learning control, as durability rigs reach a target motion: remote
parameter control practice).

Iteration 0 drives the target itself. After each iteration the error e = target -
measured corrects the drive through the rig's frequency response H (measured motion over
drive, estimated from iteration 0): d <- d + gain * IFFT(E conj(H) / (|H|^2 + eps)),
within BAND_HZ and tapered to zero at both ends so every drive starts and ends where the
target does. Each iteration is a recorded segment of kind `road` with its NRMS error in a
`result` event.

The target: a CSV with a header row, then time [s] and displacement [mm] about the
installed position (mid-stroke), compression positive; resampled to the loop's rate.
"""
from __future__ import annotations

import importlib
import math
from dataclasses import dataclass

import numpy as np

from rig.errors import RigError

from protocols.library import roads
from protocols.plan import ParamError, RigInfo, Segment, after_stall, drain, said_stalled, stalled

NAME = "replay"
# the correction's band: a road-driven damper history has content past the road's 20 Hz (the
# wheel's hop, friction's sticks) that a 40 Hz servo attenuates; above this it would chase noise
BAND_HZ = 60.0
EPS = 0.01  # regularisation of the inverse, relative to max |H|^2
TAPER_S = 0.05
MOVE_S = 1.0  # to the target's start from mid-stroke, and back
# the actuator catching up after a stall of the control loop (the setpoint held, then the
# target where it has gone): over the wires, a 62 ms freeze of the controller's process left
# 1.7 mm RMS error in the next 10 ms, 0.2 mm in the 10 after, then the 20-30 um of before.
# Those ticks are the controller's, not the rig's: the error is also given without them
RECOVER_S = 0.02
UNITS = {"replay.drive": "m", "replay.target": "m", "replay.error": "m"}


@dataclass
class Params:
    target: str = ""  # CSV: time [s], displacement [mm] about mid-stroke
    iterations: int = 5
    gain: float = 1.0  # share of the estimated correction applied each iteration
    rest_s: float = 1.0  # back from the target's end to its start between iterations
    correction_mm: float = 10.0  # the most the drive may leave the target


def check(p: Params, rig: RigInfo):
    if not 1 <= p.iterations <= 50:
        raise ParamError(f"iterations: 1 to 50, got {p.iterations}")
    if not 0 < p.gain <= 1.5:
        raise ParamError(f"gain: above 0 and at most 1.5, got {p.gain:g}")
    for name in ("rest_s", "correction_mm"):
        if not getattr(p, name) > 0:
            raise ParamError(f"{name}: must be positive, got {getattr(p, name):g}")
    _target(p, rig)
    return []


def _target(p, rig):
    """The target displacement [m from full extension] at the loop's rate."""
    if not p.target:
        raise ParamError("target: give the displacement history (--target CSV)")
    _, x = roads.history(p.target, "target", "displacement", 1.0 / rig.rate_hz)
    return rig.x_mid + x / 1e3


def plan(p: Params, rig: RigInfo):
    target = _target(p, rig)
    h = 1.0 / rig.rate_hz
    learn = Learning(p, target, h)
    x0 = float(target[0])
    yield Segment("move to the target's start", {}, MOVE_S, _move(rig.x_mid, x0, MOVE_S))
    for i in range(p.iterations):
        yield Segment(f"replay iteration {i}", {"iteration": i, "target": p.target}, len(target) * h,
                      lambda t: float(np.interp(t, np.arange(len(target)) * h, target)), kind="road",
                      control=learn.iteration(i))
        yield Segment(f"back to the start after iteration {i}", {"iteration": i}, p.rest_s,
                      _move(float(target[-1]), x0, p.rest_s))
    yield Segment("return to mid-stroke", {}, MOVE_S, _move(x0, rig.x_mid, MOVE_S))


def _move(a, b, T):
    return lambda t: a + (b - a) * (0.5 - 0.5 * math.cos(math.pi * min(t / T, 1.0)))


class Learning:
    """The drive, corrected between iterations from what each one measured."""

    units = UNITS

    def __init__(self, p: Params, target, h):
        self.p, self.target, self.h = p, target, h
        # scipy.signal takes half a second to load: here, as the plan is made before the run,
        # never for the first time in learn() (a control tick); not at every dyno command's start
        importlib.import_module("scipy.signal")
        self.drive = target.copy()
        self.H = None  # the rig's frequency response, from iteration 0
        self.measured = {}  # iteration -> measured x per tick
        self.unlearned = set()  # iterations with too few readings to learn from
        n = len(target)
        f = np.fft.rfftfreq(n, h)
        self.band = f <= BAND_HZ
        w = np.ones(n)
        m = max(1, int(TAPER_S / h))
        w[:m] = w[-m:][::-1] = 0.5 - 0.5 * np.cos(np.pi * np.arange(m) / m)
        self.taper = w

    def iteration(self, i):
        return _Iteration(self, i)

    def learn(self, i):
        """Correct the drive from iteration i's error (before iteration i + 1 starts)."""
        m = self.measured[i]
        seen = np.isfinite(m)
        # ticks a real-time loop skipped after a stall (a few %) are interpolated; with most
        # of the iteration unseen there is nothing to learn from. Those it spent catching up
        # are learned from as measured: interpolating 20 ms after each of the short stalls
        # common over the wires removed more of the road's motion than the catch-up adds
        # (the next iteration at 1.9 and 5.0 % in the two runs tried so)
        if seen.sum() < 0.9 * len(m):
            self.unlearned.add(i)
            return
        k = np.arange(len(m))
        m = np.interp(k, k[seen], m[seen])  # a tick without a reading, or one the segment did not reach
        if self.H is None:
            self.H = np.where(self.band, _response(self.drive, m, self.h, len(self.target)), 0.0)
        E = np.fft.rfft(self.target - m)
        inverse = np.conj(self.H) / (np.abs(self.H) ** 2 + EPS * np.max(np.abs(self.H) ** 2))
        step = np.fft.irfft(np.where(self.band, E * inverse, 0.0), len(self.target))
        # the first correction whole, then gain / (i + 1): the steps average what does not
        # repeat from one iteration to the next (a real-time loop's timing, noise) instead of
        # following each. With the whole gain every time, over the wires the third iteration
        # came out worse than the second in 3 of 4 runs (2.3 % -> 4.9 % once)
        self.drive = self.drive + self.p.gain / (i + 1) * self.taper * step
        worst = float(np.max(np.abs(self.drive - self.target)))
        if worst > self.p.correction_mm / 1e3:
            raise RigError(f"replay: the drive would leave the target by {worst * 1e3:.2f} mm (at most "
                           f"{self.p.correction_mm:g} mm): the rig does not follow as iteration 0 measured")



def _response(drive, measured, h, n):
    """The rig's frequency response measured/drive on the rfft grid of n samples: Welch's
    H1 estimate (cross spectrum over the drive's spectrum, averaged over overlapping
    segments, so the noise of one realisation does not enter the inverse), interpolated."""
    from scipy.signal import csd, welch
    nper = min(1024, len(drive) // 4)
    f, p_dm = csd(drive, measured, fs=1.0 / h, nperseg=nper)
    _, p_dd = welch(drive, fs=1.0 / h, nperseg=nper)
    H = p_dm / np.maximum(p_dd, 1e-30)
    grid = np.fft.rfftfreq(n, h)
    return np.interp(grid, f, H.real) + 1j * np.interp(grid, f, H.imag)


class _Iteration:
    """One replay: the drive as it stands, every tick's position kept and logged; its NRMS
    error once the rig is safe."""

    units = UNITS

    def __init__(self, learning, i):
        self.l, self.i = learning, i
        self.log = {n: ([], []) for n in UNITS}
        self.ts = []  # each tick's time into the segment [s]
        self.ks = []  # each tick's index into the target

    def setpoint(self, t, ts, readings):
        L = self.l
        if self.i not in L.measured:
            if self.i > 0:
                L.learn(self.i - 1)
            L.measured[self.i] = np.full(len(L.target), np.nan)  # by tick, so iterations align
        k = min(int(round(ts / L.h)), len(L.drive) - 1)
        d = float(L.drive[k])
        self.ts.append(ts)
        self.ks.append(k)
        if "x" in readings:
            x = readings["x"].value
            # by the tick it was read at, not the sample's own time: over the wires that
            # time carries the transport's jitter, while the tick's lag repeats from one
            # iteration to the next and the learned correction takes it up
            L.measured[self.i][k] = x
            for name, value in (("replay.drive", d), ("replay.target", L.target[k]), ("replay.error", x - L.target[k])):
                self.log[name][0].append(t)
                self.log[name][1].append(value)
        return d

    def channels(self):
        return drain(self.log)

    def recovering(self):
        """The target's ticks within RECOVER_S after a stall of the control loop."""
        return np.asarray(self.ks, int)[after_stall(self.ts, self.l.h, RECOVER_S)]

    def after(self):
        m = self.l.measured.get(self.i)
        seen = np.isfinite(m) if m is not None else None
        if m is None or seen.sum() < 10:
            return {}, {}
        calm = seen.copy()
        calm[self.recovering()] = False
        target, scale = self.l.target, max(np.std(self.l.target[seen]), 1e-12)
        nrms = [float(np.sqrt(np.mean((m[w] - target[w]) ** 2)) / scale) for w in (seen, calm)]
        return {}, {"nrmse": nrms[0], "nrmse_undisturbed": nrms[1], "samples": int(seen.sum()),
                    "stalled": stalled(self.ts, self.l.h), "learned_from": self.i not in self.l.unlearned}


def summary(m):
    out = f"NRMS error {100 * m['nrmse']:.2f} % of the target's motion"
    if m.get("nrmse_undisturbed", m["nrmse"]) < 0.9 * m["nrmse"]:
        out += f", {100 * m['nrmse_undisturbed']:.2f} % without the ticks a stall of the control loop disturbed"
    out += said_stalled(m)
    if not m.get("learned_from", True):
        out += f"; not learned from: {m['samples']} ticks had a reading, too few"
    return out
