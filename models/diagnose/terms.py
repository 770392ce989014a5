"""Terms outside the catalogue: forces built from the recorded variables, each with a
physical reading, that compete with the catalogue's effects on the same held-out
evidence (issue 29). Each is a smooth basis with linear coefficients:

  valve_form       the valve curve reshaped, per direction: B(|v|), zero at rest
  elastic_stroke   an elastic force along the stroke, alike in both directions: B(x)
                   (a bump stop, a top-out spring, a gas law other than the baseline's)
  stroke_damping   damping changing along the stroke, per direction: (1 + B(x)) F_damping
                   (bypass grooves, position-sensitive valving)
  drift            a slow offset in time, independent of the motion: B(t), judged only by its
                   change within each segment, because a segment's constant offset cannot be
                   told from the baseline's misfit of that segment
  damping_drift    damping changing in time: (1 + B(t)) F_damping (warm-up the temperature
                   channel does not show, a valve bedding in)
  frequency_damping damping changing with the test frequency at the same velocity, per
                   direction: (1 + c1 u + c2 u^2) F_damping, u the segment's log frequency
                   (valve dynamics, shim inertia; 2 or 3+ frequencies give 1 or 2 terms)
  interference     a tone at a frequency unrelated to the motion, found in the residual's
                   spectrum (mains hum, a pump, a fan)
  temperature_force an offset varying with temperature: B(T)
  friction_drift   not a candidate: the seal's friction changing in time, (1 + B(t)) F_friction,
                   the stand-in a friction that follows the temperature must beat
  loop_surface     not a candidate: the flexible stand-in a mechanism of the loop must beat
                   before it is named, per direction B(x) times a quadratic in |v|

B is a cubic B-spline basis whose knots are spread evenly over the variable's recorded
range (KNOTS functions). SI units: x [m], v [m/s], t [s], T [K]; forces [N].
"""
from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from models.diagnose import kernels
from models.diagnose.data import Data
from models.diagnose.forms import scaled
from models.diagnose.spec import Effect, P

DEGREE = 3
KNOTS = {"valve_form": 8, "elastic_stroke": 8, "stroke_damping": 6, "temperature_force": 4}
DRIFT_S = 10.0  # s of recording per drift basis function (4 to 8 of them)
SURFACE = (6, 3)  # the loop's stand-in: B-splines along the stroke, powers of |v| (a choice)
SURFACE_RCOND = 1e-4  # below this share of the largest singular value a surface direction is not resolved


def bspline(u: np.ndarray, lo: float, hi: float, n: int) -> np.ndarray:
    """(len(u), n) cubic B-spline basis over [lo, hi], knots evenly spread; u clipped to it."""
    inner = np.linspace(lo, hi, n - DEGREE + 1)
    knots = np.r_[[lo] * DEGREE, inner, [hi] * DEGREE]
    return kernels.bspline_basis(np.clip(np.asarray(u, float), lo, hi), knots, DEGREE, n)


def _centred(basis, ref, d):
    """basis(ref, d) with each column's mean over the model's own data (ref) removed: what
    a constant (the gas force's level) already carries is left out."""
    B = basis(ref, d)
    return B - (B if d is ref else basis(ref, ref)).mean(axis=0)


def cached(m, d: Data, key: str, make: Callable[[Data, Data], np.ndarray]) -> np.ndarray:
    """make(ref, d): a basis on d's samples whose knots (and centring) come from ref, the
    data the model was built on, so that it means the same on other motion (the next
    test's); made once per model and data (the fit evaluates the force many times)."""
    got = m.cache.get(key)
    if got is None or got[0] is not d:
        got = m.cache[key] = (d, make(m.data, d))
    return got[1]


def force_bound(d: Data) -> float:
    return 3.0 * max(float(np.percentile(np.abs(d.F), 99)), 10.0)


def add(f, part: str, e: str, B: np.ndarray, c: list | np.ndarray) -> None:
    """Adds basis B [N per unit] times coefficients c to the Forces' part ("Fd", "Fg" or
    the total "F"), and keeps B there: the force's exact derivative in c (fitting.py)."""
    f.bases[e] = (part, B)
    setattr(f, part, getattr(f, part) + _times(B, tuple(c)))


def added(m, d: Data, p: dict, f, e: str, cols: dict[str, dict[str, np.ndarray]], before: dict[str, np.ndarray]
         ) -> None:
    """The tangent of a term add()ed: its basis is its coefficients' derivative."""
    part, B = f.bases[e]
    cols[part].update(zip(m.own[e], B.T))


def _scaled_by(before, B, names, where=None, part="Fd"):
    """The tangent of a part (damping) multiplied by 1 + B @ c (where: per direction, the
    samples each set of coefficients acts on): the part's columns scaled, each coefficient's
    its basis times the part it multiplied."""
    F = before[part]
    return {n: B[:, i] * F * (1.0 if where is None else where) for i, n in enumerate(names)}


@functools.partial(kernels.recent, size=16)
def _times(B, c):
    """B @ c, remembered: a finite-difference column moves another parameter and leaves
    B and c as they were (12 % of a diagnosis went to these products)."""
    return B @ np.asarray(c)


def coefficients(prefix: str, n: int, bound: float) -> list[P]:
    return [P(f"{prefix}{i}", 0.0, -bound, bound, "N") for i in range(n)]


def _valve_basis(d, v):
    """Per direction, over the square root of the speed: a valve's curve bends most at low
    speed (the bleed giving way to the shims), where the knots are closest."""
    return _valve_basis_at(v, _speed_scale(d))


def _speed_scale(d):
    """[m/s] the 99th percentile of d's speed (at least 1 mm/s)."""
    return max(float(np.percentile(np.abs(d.v), 99)), 1e-3)


@kernels.recent
def _valve_basis_at(v, vmax):
    # remembered: with a sensor delay the velocity is a shifted copy, the same array while
    # the delay is not the parameter being moved
    B = bspline(np.sqrt(np.abs(v) / vmax), 0.0, 1.0, KNOTS["valve_form"])[:, 1:]  # the first is the only one non-zero at rest
    return np.hstack([B * (v > 0)[:, None], -B * (v < 0)[:, None]])


def _valve_form(m, d, p, f, e):
    if f.v is d.v:
        B = cached(m, d, e, lambda ref, dd: _valve_basis(ref, dd.v))
    else:  # the motion shifted by a timing offset: a basis per offset (remembered), on the model's speed scale
        B = _valve_basis_at(f.v, cached(m, m.data, f"{e}:speed", lambda ref, dd: _speed_scale(ref)))
    add(f, "Fd", e, B, [p[f"vf{i}"] for i in range(B.shape[1])])


def x_basis(ref: Data, d: Data, n: int) -> np.ndarray:
    """B(x) on d's samples, its knots over ref's stroke."""
    return bspline(d.x, float(np.min(ref.x)), float(np.max(ref.x)), n)


def _elastic_stroke(m, d, p, f, e):
    B = cached(m, d, e, lambda ref, dd: _centred(lambda r, u: x_basis(r, u, KNOTS[e]), ref, dd))
    add(f, "Fg", e, B, [p[f"es{i}"] for i in range(B.shape[1])])


def _stroke_damping(m, d, p, f, e):
    f.Fd = f.Fd * (1.0 + _per_direction(f, p, cached(m, d, e, lambda ref, dd: x_basis(ref, dd, KNOTS[e])), "sd"))


def _per_direction(f, p, B, prefix):
    """B @ c per direction: coefficients {prefix}c.. in compression, {prefix}r.. in rebound."""
    n = B.shape[1]
    gc = B @ np.array([p[f"{prefix}c{i}"] for i in range(n)])
    gr = B @ np.array([p[f"{prefix}r{i}"] for i in range(n)])
    return np.where(f.v > 0, gc, gr)


def _per_direction_tangent(p, f, cols, before, B, prefix):
    n, up = B.shape[1], f.v > 0
    scaled(cols, "Fd", 1.0 + _per_direction(f, p, B, prefix))
    cols["Fd"].update(_scaled_by(before, B, [f"{prefix}c{i}" for i in range(n)], up))
    cols["Fd"].update(_scaled_by(before, B, [f"{prefix}r{i}" for i in range(n)], ~up))


def _stroke_damping_tangent(m, d, p, f, e, cols, before):
    _per_direction_tangent(p, f, cols, before, cached(m, d, e, lambda ref, dd: x_basis(ref, dd, KNOTS[e])), "sd")


def t_span(ref: Data) -> tuple[float, float]:
    """(first, last) time [s] a function of time is fitted over: on a time split, up to the
    last sample the fits see, so that the held-out tail is a forecast at the last fitted
    level, not an extrapolation of the last spline pieces, which the training barely
    touches and the bounds alone hold."""
    hi = float(ref.t[-1]) if ref.fitted_until is None else min(float(ref.fitted_until), float(ref.t[-1]))
    return float(ref.t[0]), hi


def _drift_n(d):
    lo, hi = t_span(d)
    return int(np.clip(round((hi - lo) / DRIFT_S), DEGREE + 1, 8))


def _t_basis(ref, d):
    return bspline(d.t, *t_span(ref), _drift_n(ref))


def _drift(m, d, p, f, e):
    B = cached(m, d, e, lambda ref, dd: _centred(_t_basis, ref, dd))
    add(f, "F", e, B, [p[f"dr{i}"] for i in range(B.shape[1])])


def part_drift(part: str, prefix: str) -> tuple[Callable, Callable]:
    """(apply, tangent) of a part of the force ("Fd", "Ff") times 1 + B(t): the same part
    changing in time, the stand-in of that part changing with a temperature that only rises."""
    def apply(m, d, p, f, e):
        B = cached(m, d, e, lambda ref, dd: _centred(_t_basis, ref, dd))
        setattr(f, part, getattr(f, part) * (1.0 + B @ np.array([p[f"{prefix}{i}"] for i in range(B.shape[1])])))

    def tangent(m, d, p, f, e, cols, before):
        B = cached(m, d, e, lambda ref, dd: _centred(_t_basis, ref, dd))
        names = [f"{prefix}{i}" for i in range(B.shape[1])]
        scaled(cols, part, 1.0 + B @ np.array([p[n] for n in names]))
        cols[part].update(_scaled_by(before, B, names, part=part))
    return apply, tangent


_damping_drift, _damping_drift_tangent = part_drift("Fd", "dd")
_friction_drift, _friction_drift_tangent = part_drift("Ff", "fd")


def frequency_u(d: Data) -> np.ndarray:
    """Each sample's motion frequency as u = log(f / f_mid) over half the log range of the
    tests' frequencies: -1 at the lowest, +1 at the highest (a sweep's or ramp's, as it goes,
    clipped to them); 0 where none is known."""
    seg = np.array([f or np.nan for _, f in d.segments], float)
    fs = seg[d.segment] if d.freq is None else np.where(np.isfinite(seg[d.segment]), seg[d.segment], d.freq)
    if np.any(np.isfinite(seg)):
        fs = np.clip(fs, np.nanmin(seg), np.nanmax(seg))
    if not np.any(np.isfinite(fs)):
        return np.zeros(len(fs))
    lo, hi = np.nanmin(fs), np.nanmax(fs)
    return np.nan_to_num((2 * np.log(fs) - np.log(lo) - np.log(hi)) / max(np.log(hi / lo), 1e-9))


def frequencies(d: Data) -> list[float]:
    """The distinct sine frequencies [Hz] the recording holds."""
    return sorted({round(f, 6) for _, f in d.segments if f})


def _frequency_n(d):
    return 1 if len(frequencies(d)) < 3 else 2


def _frequency_basis(ref, dd):
    """Powers of u on dd, the square centred over ref (its mean is the valve's level)."""
    u, u_ref = frequency_u(dd), frequency_u(ref)
    return np.stack([u, u ** 2 - np.mean(u_ref ** 2)][:_frequency_n(ref)], axis=1)


def _frequency_damping(m, d, p, f, e):
    f.Fd = f.Fd * (1.0 + _per_direction(f, p, cached(m, d, e, _frequency_basis), "fd"))


def _frequency_damping_tangent(m, d, p, f, e, cols, before):
    _per_direction_tangent(p, f, cols, before, cached(m, d, e, _frequency_basis), "fd")


def _interference(m, d, p, f, e):
    B = cached(m, d, e, lambda ref, dd: np.column_stack([np.cos(2 * np.pi * dd.tone_hz * dd.t),
                                                         np.sin(2 * np.pi * dd.tone_hz * dd.t)]))
    add(f, "F", e, B, [p["hum_c"], p["hum_s"]])


def _temperature_force(m, d, p, f, e):
    def T_basis(ref, dd):
        return bspline(dd.T, float(np.min(ref.T)), float(np.max(ref.T)), KNOTS[e])
    B = cached(m, d, e, lambda ref, dd: _centred(T_basis, ref, dd))
    add(f, "F", e, B, [p[f"tf{i}"] for i in range(B.shape[1])])


def _surface_raw(ref, d):
    bx = x_basis(ref, d, SURFACE[0])
    s = np.abs(d.v) / max(float(np.percentile(np.abs(ref.v), 99)), 1e-3)
    B = np.hstack([bx * (s ** k)[:, None] for k in range(SURFACE[1])])
    return np.hstack([B * (d.v > 0)[:, None], B * (d.v <= 0)[:, None]])


def _surface_basis(ref, d):
    """Per direction, B(x) times 1, |v|, v^2 (|v| over ref's 99th percentile): a smooth
    surface over the loop, which follows any force that depends on where the rod is, how
    fast and which way it moves. Orthonormalised over ref's samples, the directions the
    recording does not span (one stroke: |v| is a function of x in each direction) set to
    zero: unresolved coefficients would otherwise run to their bounds between folds."""
    _, S, Vt = np.linalg.svd(_surface_raw(ref, ref), full_matrices=False)
    keep = S > SURFACE_RCOND * S[0]
    W = np.zeros((Vt.shape[1], Vt.shape[1]))
    W[:, :int(keep.sum())] = Vt[keep].T / S[keep] * np.sqrt(len(ref.t))  # unit RMS columns [N per N]
    return _surface_raw(ref, d) @ W


def _loop_surface(m, d, p, f, e):
    B = cached(m, d, e, _surface_basis)
    add(f, "F", e, B, [p[f"ls{i}"] for i in range(B.shape[1])])


def _damping_params(d, e):
    n = KNOTS["stroke_damping"]
    return ([P(f"sdc{i}", 0.0, -0.95, 3.0, "-") for i in range(n)]
            + [P(f"sdr{i}", 0.0, -0.95, 3.0, "-") for i in range(n)])


def tone(d: Data, r: np.ndarray, k: np.ndarray) -> float | None:
    """[Hz] of the strongest line in the residual r's spectrum (samples k) that is no
    harmonic of a segment's motion, or None. Each sine segment's periodogram, its motion's
    harmonics (and the bins beside them) masked, is put on a common 0.25 Hz grid and the
    grid's peak refined over the whole recording (a tone keeps its phase across segments)."""
    if not d.periodic:
        return None
    grid = np.arange(0.25, 0.5 / float(np.median(d.h)), 0.25)
    power, count = np.zeros(len(grid)), np.zeros(len(grid))
    for s, (_, f) in enumerate(d.segments):
        j = np.nonzero((d.segment == s) & k)[0]
        if f is None or len(j) < 64:  # a block of motion that does not repeat has no harmonics to mask
            continue
        y = np.where(k[j[0]:j[-1] + 1], r[j[0]:j[-1] + 1], 0.0)
        y = y - y.mean()
        h = float(np.median(d.h[j]))
        fr = np.fft.rfftfreq(len(y), h)
        P_ = np.abs(np.fft.rfft(y * np.hanning(len(y)))) ** 2 / len(y)
        df = fr[1]
        harmonic = np.abs(fr / f - np.round(fr / f)) * f <= 2 * df
        P_[harmonic] = np.nan
        got = np.interp(grid, fr, P_, left=np.nan, right=np.nan)
        ok = np.isfinite(got)
        power[ok] += got[ok]
        count[ok] += 1
    if not np.any(count):
        return None
    mean = np.where(count > 0, power / np.maximum(count, 1), 0.0)
    i = int(np.argmax(mean))
    if mean[i] < 10 * np.median(mean[count > 0]):  # no line stands out of the noise floor
        return None
    fine = np.linspace(grid[i] - 0.25, grid[i] + 0.25, 201)
    t, y = d.t[k], r[k]
    z = [abs(np.dot(np.exp(-2j * np.pi * fr * t), y)) for fr in fine]
    return float(fine[int(np.argmax(z))])


TERMS = {e.name: e for e in (
    Effect("valve_form", "the valve curve shaped otherwise than the baseline's two-stage law",
           lambda d, e: coefficients("vf", 2 * (KNOTS["valve_form"] - 1), force_bound(d)), "vf0", _valve_form, "parts",
           depends_on=("velocity", "direction"), linear=True, nature="form",
           tangent=added,
           order=30, short="the valve curve's form",
           say=("The valve curve is shaped otherwise than the baseline's two-stage law ({region}; {size}): "
                "the baseline's form, not physics left out. Fit the valves with a table or a richer law.",
                None, 1.0, "N")),
    Effect("elastic_stroke", "an elastic force along the stroke, alike in both directions",
           lambda d, e: coefficients("es", KNOTS["elastic_stroke"], force_bound(d)), "es0", _elastic_stroke, "parts",
           depends_on=("displacement",), linear=True, nature="open",
           tangent=added,
           order=100,
           say=("Not in the catalogue: an elastic force along the stroke, alike in both directions ({region}; "
                "{size}): a bump stop, a top-out spring, or a gas spring other than the baseline's?",
                None, 1.0, "N")),
    Effect("stroke_damping", "damping changing along the stroke, per direction", _damping_params, "sdc0",
           _stroke_damping, "parts", depends_on=("displacement", "velocity", "direction"), linear=True, nature="open",
           tangent=_stroke_damping_tangent,
           order=40,
           say=("Not in the catalogue: damping that changes along the stroke ({region}; {size}): bypass grooves "
                "or position-sensitive valving?", None, 1.0, "N")),
    Effect("drift", "a slow offset in time, independent of the motion",
           lambda d, e: coefficients("dr", _drift_n(d), force_bound(d)), "dr0", _drift, "total", depends_on=("time",),
           linear=True, nature="open",
           tangent=added,
           order=170, say=("Not in the catalogue: a slow offset in time, independent of the motion ({region}; {size}): "
                "the load cell's zero drifting, a leak or warm-up? Re-zero and repeat a reference segment.",
                None, 1.0, "N")),
    Effect("damping_drift", "damping changing in time, independent of the motion",
           lambda d, e: [P(f"dd{i}", 0.0, -0.9, 0.9, "-") for i in range(_drift_n(d))], "dd0", _damping_drift,
           "parts", depends_on=("time", "velocity", "direction"), linear=True, nature="open",
           tangent=_damping_drift_tangent,
           order=50,
           say=("Not in the catalogue: damping that changes in time ({region}; {size}): the oil warming without "
                "a thermocouple to show it, or a valve settling in? Log the oil temperature.", None, 1.0, "N")),
    Effect("frequency_damping", "damping changing with the test frequency at the same velocity",
           lambda d, e: [P(f"fd{s}{i}", 0.0, -0.9, 0.9, "-") for s in "cr" for i in range(_frequency_n(d))], "fdc0",
           _frequency_damping, "parts", needs="frequencies", depends_on=("frequency", "velocity", "direction"),
           linear=True, nature="open",
           tangent=_frequency_damping_tangent,
           order=60, say=("Not in the catalogue: damping that changes with the test frequency at the same velocity "
                "({region}; {size}): the valves' own dynamics (shim stack inertia, a pressure-lagged bleed) or "
                "oil compressibility beyond the model's?", None, 1.0, "N")),
    Effect("interference", "a tone unrelated to the motion",
           lambda d, e: [P("hum_c", 0.0, -force_bound(d), force_bound(d), "N"), P("hum_s", 0.0, -force_bound(d), force_bound(d), "N")],
           "hum_c", _interference, "total", needs="tone", depends_on=("time",), linear=True, nature="cell",
           tangent=added,
           order=180,
           say=("A tone at {hz:.2f} Hz, unrelated to the motion, rides on the force ({size}): interference in "
                "the cell (mains at 50 or 60 Hz, a pump, a fan), not the damper. Shield or filter the force "
                "channel.", None, 1.0, "N")),
    Effect("friction_drift", "the seal's friction changing in time, independent of the motion",
           lambda d, e: [P(f"fd{i}", 0.0, -0.9, 0.9, "-") for i in range(_drift_n(d))], "fd0", _friction_drift,
           "parts", needs="referee", depends_on=("time", "direction"), linear=True, nature="open",
           tangent=_friction_drift_tangent, order=52,
           say=("Not in the catalogue: the seal's friction changing in time ({region}; {size}).", None, 1.0, "N")),
    Effect("loop_surface", "a smooth surface in displacement, speed and direction",
           lambda d, e: coefficients("ls", 2 * SURFACE[0] * SURFACE[1], force_bound(d)), None, _loop_surface,
           "total", needs="referee", depends_on=("displacement", "velocity", "direction"), linear=True,
           nature="open", tangent=added,
           order=200, say=("{region}; {size}", None, 1.0, "N")),
    Effect("temperature_force", "a force varying with temperature, apart from the motion",
           lambda d, e: coefficients("tf", KNOTS["temperature_force"], force_bound(d)), "tf0", _temperature_force, "total",
           needs="T", depends_on=("temperature",), linear=True, nature="open", referee="drift",
           tangent=added,
           order=190,
           say=("Not in the catalogue: a force that varies with temperature apart from the motion ({region}; "
                "{size}): a thermal offset of the load cell?", None, 1.0, "N")),
)}
