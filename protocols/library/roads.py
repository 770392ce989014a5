"""Road inputs for the hardware-in-the-loop car, from the operator's spec (mm, km/h, Hz at
the edge; m, s inside):

    step:MM                    a step of MM mm at 0.5 s (rising over 20 ms), 2.5 s to settle
    sine:HZ:MM                 MM mm peak at HZ Hz, faded in and out, max(10 cycles, 4 s)
    sweep:F0:F1:MM             logarithmic sweep F0 -> F1 Hz at MM mm peak, 20 s
    iso8608:CLASS:KMH[:SECONDS]  ISO 8608 class A-H random road at KMH km/h (10 s, at most
                               600), its content limited to 0.5-20 Hz (what a damper rig
                               reproduces)
    file:CSV                   road height over time: columns time [s], height [mm]

Every road ends with SETTLE_S held at its last height, so the car comes to rest.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from models.quarter_car import road as roads

from protocols.plan import ParamError
from protocols.preflight import MAX_RUN_S

SETTLE_S = 1.0
# a step rises over this (a half-cosine): about a tire's footprint crossing a kerb at
# 30 km/h; a step within one tick has content far beyond what a damper rig reproduces
STEP_RISE_S = 0.02
FADE_S = 0.5
CONTENT_HZ = (0.5, 20.0)  # temporal band of a random road
KINDS = ("step", "sine", "sweep", "iso8608", "file")
MAX_ROWS = 10_000_000  # of a road or target file: hours at 1 kHz
ROAD_HZ_MAX, ROAD_MM_MAX = 100.0, 1000.0  # a sine or sweep's frequency [Hz] and height [mm]
ISO_KMH = (1.0, 400.0)  # km/h: a random road's speed
ISO_MAX_S = 600.0  # s: its synthesis (2,000 sinusoids a sample) grows with its length


@dataclass
class Road:
    spec: str
    t: np.ndarray  # s, from 0, the loop's period apart
    y: np.ndarray  # m, positive up
    v: np.ndarray  # m/s
    band_hz: tuple | None = None  # (f0, f1) of a sweep: where a transmissibility means something


def _numbers(spec, fields, n_min):
    try:
        values = [float(f) for f in fields]
    except ValueError:
        raise ParamError(f"road: {spec!r}: {', '.join(map(repr, fields))} are not all numbers") from None
    if len(values) < n_min or not all(np.isfinite(values)):
        raise ParamError(f"road: {spec!r}: needs {n_min} numbers")
    return values


def parse(spec: str, rate_hz: float) -> Road:
    """The road a spec names, sampled at the loop's rate; ParamError naming what is wrong."""
    kind, _, rest = spec.partition(":")
    fields = rest.split(":") if rest else []
    h = 1.0 / rate_hz
    if kind == "step":
        (mm,) = _numbers(spec, fields[:1], 1)
        t = np.arange(0.0, 3.0, h)
        rise = np.clip((t - 0.5) / STEP_RISE_S, 0.0, 1.0)
        y = mm / 1e3 * (0.5 - 0.5 * np.cos(np.pi * rise))
        v, band = np.gradient(y, h), None
    elif kind == "sine":
        hz, mm = _numbers(spec, fields[:2], 2)
        _positive(spec, hz=hz, mm=mm)
        t = np.arange(0.0, _length(f"road: {spec!r}", max(10.0 / hz, 4.0)), h)
        y = roads.faded(t, roads.harmonic(t, mm / 1e3, hz)[0], FADE_S)
        v, band = np.gradient(y, h), None
    elif kind == "sweep":
        f0, f1, mm = _numbers(spec, fields[:3], 3)
        _positive(spec, f0=f0, f1=f1, mm=mm)
        if not f1 > f0:
            raise ParamError(f"road: {spec!r}: the sweep must rise (F1 above F0)")
        t = np.arange(0.0, 20.0, h)
        y = roads.faded(t, roads.sweep(t, f0, f1, mm / 1e3)[0], FADE_S)
        v, band = np.gradient(y, h), (f0, f1)
    elif kind == "iso8608":
        if not fields or fields[0].upper() not in roads.ISO8608_GD0:
            raise ParamError(f"road: {spec!r}: the class is one of A-H")
        kmh, *seconds = _numbers(spec, fields[1:3], 1)
        seconds = seconds[0] if seconds else 10.0
        if not (ISO_KMH[0] <= kmh <= ISO_KMH[1] and 1.0 <= seconds <= ISO_MAX_S):
            raise ParamError(f"road: {spec!r}: a random road at {ISO_KMH[0]:g} to {ISO_KMH[1]:g} km/h for 1 to "
                             f"{ISO_MAX_S:g} s (a longer one: file:CSV)")
        speed = kmh / 3.6
        t = np.arange(0.0, seconds, h)
        band = (CONTENT_HZ[0] / speed, CONTENT_HZ[1] / speed)  # cycles/m
        y = roads.faded(t, roads.iso8608(t, speed, fields[0].upper(), seed=0, n_band=band)[0], FADE_S)
        y -= y[0]
        v, band = np.gradient(y, h), None
    elif kind == "file":
        t, y = history(rest, "road", "height", h)
        y = (y - y[0]) / 1e3  # the car starts at rest on the road's first height
        v, band = np.gradient(y, h), None
    else:
        raise ParamError(f"road: {spec!r}: unknown kind {kind!r} (known: {', '.join(KINDS)})")
    n = int(round(SETTLE_S / h))
    t = np.arange(len(t) + n) * h
    return Road(spec, t, np.concatenate([y, np.full(n, y[-1])]), np.concatenate([v, np.zeros(n)]), band)


def _positive(spec, **values):
    """Frequencies [Hz] and heights [mm] above 0 and within what a damper rig reproduces."""
    for name, v in values.items():
        hi = ROAD_MM_MAX if name == "mm" else ROAD_HZ_MAX
        if not 0 < v <= hi:
            raise ParamError(f"road: {spec!r}: {name} must be above 0 and at most {hi:g}, got {v:g}")


def history(path, what, quantity, h):
    """(t from 0 [s], values [mm]) of a two-column CSV (time [s], QUANTITY [mm]) with a
    header line, resampled to the loop's period h; ParamError naming what is wrong. The
    road's file and the replay's target are read here."""
    p = Path(path)
    if not p.is_file():
        raise ParamError(f"{what}: {path}: no such file")
    try:
        with warnings.catch_warnings():  # a ragged or empty file is refused below, in one line
            warnings.simplefilter("ignore")
            data = np.genfromtxt(p, delimiter=",", skip_header=1, usecols=(0, 1), dtype=float, max_rows=MAX_ROWS + 1)
    except (ValueError, OSError, UnicodeDecodeError) as e:
        raise ParamError(f"{what}: {path}: not a two-column CSV of time [s] and {quantity} [mm] "
                         f"({str(e).splitlines()[0] if str(e) else type(e).__name__})") from None
    data = np.atleast_2d(data)
    if data.ndim != 2 or data.shape[1] != 2 or data.shape[0] < 2 or not np.all(np.isfinite(data)):
        raise ParamError(f"{what}: {path}: needs at least two rows of finite numbers (time [s], {quantity} [mm])")
    if data.shape[0] > MAX_ROWS:
        raise ParamError(f"{what}: {path}: more than {MAX_ROWS:,} rows")
    if not np.all(np.diff(data[:, 0]) > 0):
        raise ParamError(f"{what}: {path}: time must increase row by row")
    _length(f"{what}: {path}", data[-1, 0] - data[0, 0])
    t = np.arange(data[0, 0], data[-1, 0], h)
    return t - t[0], np.interp(t, data[:, 0], data[:, 1])


def _length(spec, seconds):
    """ParamError when a road or target lasts longer than any run may (MAX_RUN_S): made
    before anything is allocated for it."""
    if not seconds <= MAX_RUN_S:
        raise ParamError(f"{spec}: lasts {seconds:.3g} s; a run lasts at most {MAX_RUN_S / 3600:g} hours")
    return seconds
