"""Other dynos' programs: the motion a lab's dyno runs, written apart from our own plans
(protocols/) so that the segmentation of an imported file is tested on programs we did not
design (issue 88). Nothing here imports the product.

A program is a list of pieces (each a function of its own time), the truth a segmentation is
judged against: steady sines (`sine`), their ramps in and out (`ramp`), dwells and static
holds (`hold`), steps between holds (`step`), triangles (constant-velocity strokes),
frequency sweeps (`sweep`, with their instantaneous frequency) and random motion
(`random`). `sample` reads it as a lab's acquisition does: at a rate, with an LVDT's white
noise and an ADC's quantisation. Displacement from full extension [m], compression positive.

`damper_force` is a plain force law on the same motion (valves, gas, friction), with the
two effects issue 88 asks the diagnosis to find in such a program: damping that falls above
a frequency, and friction that rises near reversal.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

X_MID = 0.05  # m: the program runs about mid-stroke
AMPLITUDES_M = (0.0016, 0.0032, 0.0064, 0.0127)
FREQS_HZ = (0.5, 1.0, 2.0, 4.0, 8.0, 12.0, 16.0)
LVDT_NOISE_M = 4e-6  # m RMS: a real LVDT's few micrometres
LVDT_QUANTUM_M = 100e-3 / 2 ** 16  # m: 16 bits over a 100 mm range
# a DAQ's spikes on the displacement as UTFSM's exports hold them (measured on the 1 A
# chirp's opening hold at 1 kHz: ~120 a second, up to 135 um, 22 um RMS in all; most one
# sample long, some 2-40 ms): bursts of a level each, lasting SPIKE_S on average
SPIKES_PER_S = 120.0
SPIKE_M = 60e-6  # m RMS
SPIKE_S = 3e-3


@dataclass
class Piece:
    kind: str  # sine, ramp, hold, step, triangle, sweep, random
    t0: float  # s
    t1: float  # s
    amplitude: float = 0.0  # m (a sweep's or a ramp's steady amplitude)
    freq: float = 0.0  # Hz (a sweep: at its start)
    freq_end: float = 0.0  # Hz (a sweep at its end)
    law: str = ""  # a sweep's: log or linear
    motion: object = field(default=None, repr=False)  # x(u) [m], u the time since t0 [s]

    @property
    def cycles(self) -> float:
        return (self.t1 - self.t0) * self.freq


@dataclass
class Program:
    name: str
    pieces: list

    @property
    def duration(self) -> float:
        return self.pieces[-1].t1

    def x(self, t):
        """The true displacement [m] at times t [s]."""
        t = np.asarray(t, float)
        out = np.full(t.shape, X_MID)
        for p in self.pieces:
            k = (t >= p.t0) & (t < p.t1)
            out[k] = p.motion(t[k] - p.t0)
        return out

    def freq_at(self, t):
        """The motion's frequency [Hz] at t: a sine's or ramp's, a sweep's instantaneous one;
        0 in a hold or a step, nan in random motion."""
        t = np.asarray(t, float)
        out = np.zeros(t.shape)
        for p in self.pieces:
            k = (t >= p.t0) & (t < p.t1)
            if p.kind in ("sine", "ramp", "triangle"):
                out[k] = p.freq
            elif p.kind == "sweep":
                out[k] = _sweep_freq(p, t[k] - p.t0)
            elif p.kind == "random":
                out[k] = np.nan
        return out

    def sines(self):
        return [p for p in self.pieces if p.kind == "sine"]


class Builder:
    """Pieces appended one after another, the displacement continuous across them."""

    def __init__(self, name):
        self.name, self.pieces, self.t = name, [], 0.0

    def add(self, kind, duration, motion, **kw):
        self.pieces.append(Piece(kind, self.t, self.t + duration, motion=motion, **kw))
        self.t += duration
        return self

    def hold(self, seconds, at=X_MID):
        return self.add("hold", seconds, lambda u: np.full(np.shape(u), at))

    def sine(self, A, f, cycles, ramp_cycles=1.0):
        """A sine from mid-stroke: ramped in over ramp_cycles (its amplitude rising linearly
        from 0), `cycles` steady, ramped out as it came in; ramp_cycles 0 steps straight in."""
        w = 2 * math.pi * f
        if ramp_cycles:
            r = ramp_cycles / f
            self.add("ramp", r, lambda u: X_MID + A * (u / r) * np.sin(w * u), amplitude=A, freq=f)
        self.add("sine", cycles / f, lambda u: X_MID + A * np.sin(w * u), amplitude=A, freq=f)
        if ramp_cycles:
            self.add("ramp", r, lambda u: X_MID + A * (1 - u / r) * np.sin(w * u), amplitude=A, freq=f)
        return self

    def triangle(self, A, f, cycles):
        """Constant-velocity strokes (4 A f) from mid-stroke, whole cycles."""
        def x(u):
            ph = (u * f + 0.25) % 1.0  # a quarter cycle in: starts at mid-stroke, rising
            return X_MID + A * (4 * np.abs(ph - 0.5) - 1) * -1
        return self.add("triangle", cycles / f, x, amplitude=A, freq=f)

    def sweep(self, A, f0, f1, seconds, law="log", taper_cycles=1.0):
        """A sine sweep at amplitude A from f0 to f1 [Hz] (log or linear), its amplitude
        tapered in and out over taper_cycles of its end frequencies."""
        ti, to = taper_cycles / f0, taper_cycles / f1

        def x(u):
            env = np.clip(np.minimum(u / ti, (seconds - u) / to), 0.0, 1.0) if taper_cycles else 1.0
            return X_MID + A * env * np.sin(sweep_phase(law, f0, f1, seconds, u))
        self.add("sweep", seconds, x, amplitude=A, freq=f0, freq_end=f1)
        self.pieces[-1].law = law
        return self

    def random(self, rms, seconds, band=(0.5, 12.0), seed=0, taper_s=1.0):
        """Band-limited random motion of `rms` [m]: a sum of many sines of random phase,
        flat in displacement over the band [Hz], tapered in and out from mid-stroke."""
        rng = np.random.default_rng(seed)
        fk = rng.uniform(*band, 200)
        ph = rng.uniform(0, 2 * math.pi, 200)
        a = rms * math.sqrt(2.0 / 200)

        def x(u):
            u = np.asarray(u, float)
            env = np.clip(np.minimum(u, seconds - u) / taper_s, 0.0, 1.0)
            s = np.zeros(u.shape)
            for fi, pi in zip(fk, ph):
                s += np.sin(2 * math.pi * fi * u + pi)
            return X_MID + env * a * s
        return self.add("random", seconds, x, amplitude=rms)

    def step(self, dx, hold_s=2.0, move_s=0.05):
        """A move of dx [m] in move_s (a half cosine), then a hold there, then back."""
        a, b = self.level(), self.level() + dx
        self.add("step", move_s, lambda u: a + (b - a) * 0.5 * (1 - np.cos(math.pi * u / move_s)))
        self.hold(hold_s, b)
        self.add("step", move_s, lambda u: b + (a - b) * 0.5 * (1 - np.cos(math.pi * u / move_s)))
        return self

    def level(self):
        return X_MID

    def build(self):
        return Program(self.name, self.pieces)


def sweep_phase(law, f0, f1, T, u):
    """A sweep's phase [rad] u [s] after its start: its frequency from f0 to f1 [Hz] in T [s]."""
    u = np.asarray(u, float)
    if law == "linear":
        return 2 * math.pi * (f0 * u + 0.5 * (f1 - f0) / T * u * u)
    k = math.log(f1 / f0) / T
    return 2 * math.pi * f0 * np.expm1(k * u) / k


def _sweep_freq(p, u):
    f0, f1, T = p.freq, p.freq_end, p.t1 - p.t0
    if p.law == "linear":
        return f0 + (f1 - f0) * u / T
    return f0 * np.exp(math.log(f1 / f0) / T * u)


# -- the programs -------------------------------------------------------------------------------

def matrix(style="ramped", amplitudes=AMPLITUDES_M, freqs=FREQS_HZ, cycles=4, dwell_s=0.2, speed_limit=0.8):
    """A sine matrix as other dynos write it, each (amplitude, frequency) under the speed
    limit [m/s], frequency fastest within an amplitude:
    ramped: each sine ramped in over one cycle and out over one, a dwell of dwell_s between;
    stepped: each straight into the next (no ramp, no dwell);
    dwells: ramped, with long dwells (2 s) between."""
    b = Builder(f"{style} matrix")
    b.hold(0.5)
    for A in amplitudes:
        for f in freqs:
            if 2 * math.pi * f * A > speed_limit:
                continue
            if style == "stepped":
                b.sine(A, f, cycles, ramp_cycles=0)
            else:
                b.sine(A, f, cycles, ramp_cycles=1)
                b.hold(2.0 if style == "dwells" else dwell_s)
    return b.hold(0.5).build()


def lab_matrix(amplitudes=AMPLITUDES_M):
    """A 70 s sine matrix (1.6-12.7 mm, 1-16 Hz): per amplitude, a 2 Hz reference, then 4 cycles of each frequency,
    each ramped in and out over a cycle with 0.2 s dwells."""
    b = Builder("lab matrix")
    b.hold(0.5)
    for A in sorted(amplitudes, reverse=True):
        b.sine(0.005, 2.0, 4).hold(0.2)
        for f in (1.0, 2.0, 4.0, 8.0, 12.0, 16.0):
            if 2 * math.pi * f * A <= 0.8:
                b.sine(A, f, 4).hold(0.2)
    b.sine(0.005, 2.0, 4)
    return b.hold(0.5).build()


def sweeps():
    b = Builder("sweeps")
    b.hold(0.5).sweep(0.005, 0.5, 16.0, 40.0, "log").hold(0.5)
    b.sweep(0.003, 1.0, 12.0, 20.0, "linear").hold(0.5)
    return b.build()


def triangles():
    b = Builder("triangles")
    b.hold(0.5)
    for A, f in ((0.02, 0.25), (0.01, 1.0), (0.005, 2.5)):
        b.triangle(A, f, 3).hold(0.5)
    return b.build()


def road():
    return Builder("random").hold(0.5).random(0.004, 30.0).hold(0.5).build()


def static():
    b = Builder("steps and holds")
    b.hold(1.0)
    for dx in (0.01, -0.01, 0.02):
        b.step(dx, hold_s=2.0).hold(1.0)
    return b.build()


def chirp():
    """A lab's chirp from rest (UTFSM's): a hold, then a linear sweep from 0.2 to 20 Hz that
    starts at its first phase with no taper, its first strokes seconds long, ended by a
    hold."""
    b = Builder("chirp")
    return b.hold(4.0).sweep(0.002, 0.2, 20.0, 45.0, "linear", taper_cycles=0.0).hold(2.0).build()


def mixed():
    """A program of everything: holds, a step, a ramped sine pair, a stepped pair, a sweep,
    triangles and random motion."""
    b = Builder("mixed")
    b.hold(1.0).step(0.01).hold(0.5)
    b.sine(0.0064, 1.0, 3).hold(0.2).sine(0.0032, 8.0, 6).hold(0.2)
    b.sine(0.0127, 2.0, 2, ramp_cycles=0).sine(0.0064, 2.0, 2, ramp_cycles=0).sine(0.0064, 4.0, 4, ramp_cycles=0)
    b.hold(0.5).sweep(0.004, 1.0, 10.0, 15.0).hold(0.5)
    b.triangle(0.008, 1.0, 3).hold(0.5)
    b.random(0.003, 10.0, seed=3)
    return b.hold(1.0).build()


PROGRAMS = {"ramped": lambda: matrix("ramped"), "stepped": lambda: matrix("stepped"),
            "dwells": lambda: matrix("dwells"), "lab": lab_matrix, "sweeps": sweeps, "triangles": triangles,
            "random": road, "static": static, "mixed": mixed, "chirp": chirp}
RATES_HZ = (300.0, 1000.0, 2000.0, 5000.0, 10000.0)
# (white noise [m RMS], quantum [m], spikes a second): what every cut is held to; and a DAQ's
# spikes besides, under which the table (tests/segmentation_grid.py) says how the cut fares
NOISES = {"clean": (0.0, 0.0, 0.0), "lvdt": (LVDT_NOISE_M, LVDT_QUANTUM_M, 0.0)}
SPIKY = {**NOISES, "spikes": (LVDT_NOISE_M, LVDT_QUANTUM_M, SPIKES_PER_S)}


def sample(program, rate, noise=0.0, quantum=0.0, spikes=0.0, seed=0):
    """(t [s], x [m]) of the program as acquired at `rate` [Hz]: white noise of `noise` [m]
    RMS, `spikes` bursts a second (_spikes) and quantisation to `quantum` [m] (0: none) on
    the displacement."""
    t = np.arange(int(program.duration * rate)) / rate
    x = program.x(t)
    rng = np.random.default_rng(seed)
    if noise:
        x = x + rng.normal(0.0, noise, len(t))
    if spikes:
        x = x + _spikes(t, spikes, rng)
    if quantum:
        x = np.round(x / quantum) * quantum
    return t, x


def _spikes(t, per_s, rng):
    """Bursts [m] at times t [s]: per_s a second, each a level (SPIKE_M RMS) held for an
    exponential time (SPIKE_S on average, at least a sample)."""
    out = np.zeros(len(t))
    starts = np.sort(rng.uniform(t[0], t[-1], rng.poisson(per_s * (t[-1] - t[0]))))
    ends = starts + rng.exponential(SPIKE_S, len(starts))
    for a, b, level in zip(np.searchsorted(t, starts), np.searchsorted(t, ends), rng.normal(0.0, SPIKE_M, len(starts))):
        out[a:max(b, a + 1)] = level
    return out


# -- a force on the motion --------------------------------------------------------------------------

def damper_force(program, t, rate=None, friction=40.0, fade_above_hz=None, fade=0.3, reversal=None, seed=0,
                 noise=3.0):
    """Force [N] (compression positive) of a plain damper along the program's true motion:
    quadratic-plus-linear valves, a polytropic gas spring (80 mm of gas, 150 N at
    mid-stroke), Coulomb friction, white load-cell noise of `noise` [N].
    fade_above_hz: the valves lose `fade` of their damping above it (a smooth step over a
    tenth of the frequency). reversal: friction rises near reversal (a breakaway peak
    `reversal` times the Coulomb level, decaying with speed over 5 mm/s)."""
    h = 1e-5
    x = program.x(t)
    v = (program.x(t + h) - program.x(t - h)) / (2 * h)
    Fd = np.where(v > 0, 2000.0, 4000.0) * v + np.where(v > 0, 3000.0, 7000.0) * v * np.abs(v)
    if fade_above_hz:
        f = np.nan_to_num(program.freq_at(t))
        Fd = Fd * (1 - fade / (1 + np.exp(-(f - fade_above_hz) / (0.1 * fade_above_hz))))
    s = np.tanh(v / 2e-4)  # a seal's sign, softened over 0.2 mm/s
    Ff = friction * s * (1 + (reversal or 0.0) * np.exp(-np.abs(v) / 5e-3))
    gas = 150.0 * (0.08 / (0.08 - (x - X_MID))) ** 1.4  # polytropic, near adiabatic at test speeds
    return Fd + Ff + gas + np.random.default_rng(seed + 1).normal(0.0, noise, len(t))


# -- judging a cut against the program ----------------------------------------------------------

FREQ_TOL = 0.002  # a found sine's frequency within 0.2 % ...
AMP_TOL = 0.01  # ... and its amplitude within 1 % (issue 88)
EDGE_CYCLES = 0.1  # a found sine may reach this share of a cycle past its steady stretch


# what each kind of piece is to be read as
AS = {"hold": lambda s: s[0] in ("hold", "dwell"), "step": lambda s: s[0] == "step",
      "ramp": lambda s: s[0] == "ramp", "sweep": lambda s: s[0] == "sweep", "random": lambda s: s[0] == "random",
      "triangle": lambda s: s[0] == "sine" and s[3].get("waveform") == "triangle"}


@dataclass
class Score:
    sines: int  # steady sines of two or more cycles in the program
    found: int  # ... found whole: within tolerance, every cycle, nothing past them
    invented: int  # found sines that are no steady sine of the program (in a ramp, a hold, a sweep...)
    freq_err: float  # worst share among those found
    amp_err: float
    unread_s: float  # s of the program in no segment at all
    missed: list = field(default_factory=list)  # the sines not found, and why
    kinds: dict = field(default_factory=dict)  # {a piece's kind: the share of its time read as that kind}

    @property
    def share(self):
        return self.found / self.sines if self.sines else 1.0


def cut_right(sc, rate) -> bool:
    """Every steady sine found whole, none invented, less than a sample [1/rate Hz] unread: what
    each drawn program is held to (tests/test_segmentation.py, tests/drawn.py)."""
    return sc.found == sc.sines and sc.invented == 0 and sc.unread_s < 1 / rate


def score(program, segments, t_end=np.inf):
    """How a cut [(kind, t0, t1, params)] reads the program (sampled up to t_end [s]): its sine
    segments (kind "sine", params amplitude_mm, freq_hz, cycles) against the steady sines,
    the time of each other kind of piece read as what it is, the seconds in no segment."""
    found = [s for s in segments if s[0] == "sine" and s[3].get("waveform", "sine") == "sine"]
    out = Score(0, 0, 0, 0.0, 0.0, 0.0)
    used = set()
    for p in program.sines():
        if p.cycles < 2 - 1e-9:
            continue
        out.sines += 1
        slack = EDGE_CYCLES / p.freq
        # a found sine is of this piece when most of it lies in it (the sine stepped into it may
        # reach a sample into it, and is the piece before's)
        near = [i for i, s in enumerate(found) if min(s[2], p.t1) - max(s[1], p.t0) > 0.5 * (s[2] - s[1])]
        inside = [i for i in near if found[i][1] >= p.t0 - slack and found[i][2] <= p.t1 + slack]
        if not inside:
            out.missed.append((p, "not found" if not near else f"found past its ends: {found[near[0]][1]:.3f}-"
                               f"{found[near[0]][2]:.3f} s for {p.t0:.3f}-{p.t1:.3f} s"))
            continue
        s = found[inside[0]]
        used.update(inside)
        fe = abs(s[3]["freq_hz"] / p.freq - 1)
        ae = abs(s[3]["amplitude_mm"] * 1e-3 / p.amplitude - 1)
        cycles = s[3].get("cycles", 0)
        if len(inside) > 1 or fe > FREQ_TOL or ae > AMP_TOL or cycles != round(p.cycles):
            out.missed.append((p, f"{len(inside)} pieces, {cycles} cycles, frequency {s[3]['freq_hz']:.5g} Hz "
                                  f"({100 * fe:.2f} %), amplitude {s[3]['amplitude_mm']:.4g} mm ({100 * ae:.2f} %)"))
        else:
            out.found += 1
        out.freq_err, out.amp_err = max(out.freq_err, fe), max(out.amp_err, ae)
    steady = [(p.t0, p.t1, p.freq) for p in program.sines()]
    out.invented = sum(1 for i, s in enumerate(found) if i not in used and not any(
        s[1] >= a - EDGE_CYCLES / f and s[2] <= b + EDGE_CYCLES / f for a, b, f in steady))
    for kind, found_as in AS.items():
        pieces = [p for p in program.pieces if p.kind == kind]
        total = sum(p.t1 - p.t0 for p in pieces)
        if total > 0:
            right = sum(max(0.0, min(p.t1, s[2]) - max(p.t0, s[1])) for p in pieces for s in segments
                        if found_as(s))
            out.kinds[kind] = right / total
    covered = sorted((s[1], s[2]) for s in segments)
    read, end = 0.0, 0.0
    for a, b in covered:
        a = max(a, end)
        if b > a:
            read, end = read + b - a, b
    out.unread_s = max(min(program.duration, t_end) - read, 0.0)
    return out
