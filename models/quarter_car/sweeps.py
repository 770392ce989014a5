"""Quarter-car studies of thesis chapter 6, as independent jobs run in parallel:

- frequency_response: harmonic road input of fixed amplitude over a frequency list
  (6.2.3: 0.32 and 1.27 cm, 1.25-20 Hz), the thesis's metrics at each point;
- step_response: overshoot and settling time of both masses (6.2.2, Tables 6.2-6.3);
- parametric_study: low/mid-speed compression/rebound damping, friction and compliance at
  50 % and 200 %, temperature 45 and 180 C against the 90 C baseline (6.3);
- the simplified models I and II against the comprehensive model (6.4) are
  frequency_response with a SimplifiedDamper.

Lengths m, frequencies Hz, velocities m/s, forces N, temperatures K.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from models.physics import gas_spring
from models.quarter_car import metrics
from models.damper import Damper, DamperError, load
from workers.pool import run_all
from models.quarter_car import QuarterCar
from models.quarter_car.sim import run
from models.quarter_car.road import harmonic, square_edge, step
from models.physics.simulate import C_to_K, warm

AMPLITUDES = (0.0032, 0.0127)  # m (6.2.3)
FREQS = tuple(np.arange(1.25, 20.001, 0.25))  # Hz: 1.25-20 Hz at the 0.25 Hz the tables resolve
T_BASE = float(C_to_K(90.0))  # baseline damper temperature of chapter 6 (6.3.4)
# a point settles for max(2 s, 5 cycles) and is measured over max(1 s, 5 cycles), whole
# cycles: the sprung mode (about 2.4 Hz, damping ratio 0.2-0.5) decays to under 1 % in 2 s
SETTLE = (2.0, 5)
MEASURE = (1.0, 5)
METRICS = ("rms_ratio_sprung", "rms_ratio_unsprung", "peak_v_sprung_up", "peak_v_sprung_down",
           "peak_v_unsprung_up", "peak_v_unsprung_down", "peak_damper_v_compression",
           "peak_damper_v_rebound", "ride_height_change", "min_tire_load_ratio",
           "lift_off_fraction", "stop_fraction")


@dataclass(frozen=True)
class Harmonic:
    """One frequency-response point."""
    car: QuarterCar
    damper: object  # Damper or SimplifiedDamper
    amplitude: float  # m
    freq: float  # Hz
    T: float = T_BASE  # K
    compressible: bool = True
    h: float = 1e-4  # s, largest step; shortened to fit whole cycles


def harmonic_point(job: Harmonic) -> dict:
    """The thesis's metrics (6.2.3, 6.3) at one amplitude and frequency, over whole cycles
    of the settled response."""
    f = job.freq
    n_settle = math.ceil(max(SETTLE[0] * f, SETTLE[1]))
    n_measure = math.ceil(max(MEASURE[0] * f, MEASURE[1]))
    per_cycle = math.ceil(1.0 / (f * job.h))
    t = np.arange((n_settle + n_measure) * per_cycle + 1) / (f * per_cycle)
    y_in, v_in = harmonic(t, job.amplitude, f)
    r = run(job.car, job.damper, t, y_in, v_in, T=job.T, compressible=job.compressible)
    w = slice(n_settle * per_cycle, len(t) - 1)
    stroke = job.damper.geometry.stroke if isinstance(job.damper, Damper) else np.inf
    vd = -(r.v1[w] - r.v2[w])  # damper velocity, compression positive
    up1, down1 = metrics.peak_velocities(r.v1[w])
    up2, down2 = metrics.peak_velocities(r.v2[w])
    values = (metrics.rms_velocity_ratio(r.v1[w], v_in[w]), metrics.rms_velocity_ratio(r.v2[w], v_in[w]),
              up1, down1, up2, down2, max(vd.max(), 0.0), min(vd.min(), 0.0),
              metrics.average_ride_height_change(r.y1[w], r.y_in[w]),
              metrics.min_tire_load_ratio(r.tire_force[w], r.static_tire_force),
              metrics.lift_off_fraction(r.tire_force[w]),
              float(np.mean((r.damper_x[w] < 0.0) | (r.damper_x[w] > stroke))))
    return dict(zip(METRICS, values))


@dataclass
class FrequencyResponse:
    car: str
    damper: str
    T: float  # K
    amplitudes: np.ndarray  # m
    freqs: np.ndarray  # Hz
    values: dict  # metric name -> array (amplitude, frequency)
    # static sprung height against the study's baseline [m]: a hotter gas spring lifts the
    # car by its extra force over the spring rate (6.3.4); each run itself starts at its
    # own equilibrium with the damper at mid-stroke
    static_offset: float = 0.0

    def peak(self, metric, amplitude_index, sign=1.0):
        """(value, frequency) where sign * metric is largest."""
        v = self.values[metric][amplitude_index]
        k = int(np.argmax(sign * v))
        return float(v[k]), float(self.freqs[k])


def check_sweep(amplitudes, freqs):
    amplitudes = np.atleast_1d(np.asarray(amplitudes, float))
    freqs = np.atleast_1d(np.asarray(freqs, float))
    if freqs.size == 0:
        raise DamperError("the frequency list is empty")
    if amplitudes.size == 0:
        raise DamperError("the amplitude list is empty")
    bad = freqs[~(freqs > 0) | ~np.isfinite(freqs)]
    if bad.size:
        raise DamperError(f"frequencies must be positive and finite, got {bad[0]:g} Hz")
    bad = amplitudes[~(amplitudes > 0) | ~np.isfinite(amplitudes)]
    if bad.size:
        raise DamperError(f"amplitudes must be positive and finite, got {bad[0] * 1e3:g} mm")
    return amplitudes, freqs


def _damper(damper):
    return load(damper)


def _check_amplitude(d, amplitudes):
    # above wheel hop the sprung mass stands still and the wheel follows the road, so the
    # suspension travels the road amplitude: more than the damper's travel bottoms it
    if isinstance(d, Damper):
        travel = min(d.mid_stroke, d.geometry.stroke - d.mid_stroke)
        if amplitudes.max() >= travel:
            raise DamperError(f"amplitude {amplitudes.max() * 1e3:.1f} mm bottoms the suspension: the "
                              f"{d.name} damper has {travel * 1e3:.1f} mm of travel each side")


def sweep_cases(car: QuarterCar, cases, amplitudes=AMPLITUDES, freqs=FREQS, compressible=True, executor=None,
                workers=None, progress=None, label="sweep") -> dict:
    """{case label: FrequencyResponse} for cases [(label, damper, T [K])], every point of
    every case in one parallel batch."""
    amplitudes, freqs = check_sweep(amplitudes, freqs)
    cases = [(name, _damper(d), float(T)) for name, d, T in cases]
    for _, d, _ in cases:
        _check_amplitude(d, amplitudes)
    jobs = [Harmonic(car, d, float(a), float(f), T, compressible) for _, d, T in cases for a in amplitudes
            for f in freqs]
    out = iter(run_all(harmonic_point, jobs, executor, workers, progress, label, warm=warm))
    result = {}
    for name, d, T in cases:
        rows = [next(out) for _ in range(len(amplitudes) * len(freqs))]
        values = {m: np.array([o[m] for o in rows]).reshape(len(amplitudes), len(freqs)) for m in METRICS}
        result[name] = FrequencyResponse(car.name, d.name, T, amplitudes, freqs, values)
    return result


def frequency_response(car: QuarterCar, damper, amplitudes=AMPLITUDES, freqs=FREQS, T=T_BASE,
                       compressible=True, executor=None, workers=None, progress=None) -> FrequencyResponse:
    """Harmonic sweep: every (amplitude, frequency) pair is an independent job."""
    d = _damper(damper)
    return sweep_cases(car, [(d.name, d, T)], amplitudes, freqs, compressible, executor, workers, progress,
                       f"{d.name} sweep")[d.name]


def step_response(car: QuarterCar, damper, amplitude, T=T_BASE, duration=2.0, t_step=0.05, h=1e-4,
                  square=False, x_install=None):
    """(result, metrics) for a road step of `amplitude` [m] at t_step (6.2.2): percent
    overshoot and 90 % settling time of the sprung and unsprung displacements. square:
    the step is the edge of a square wave, from -amplitude / 2 held since t = 0 to
    +amplitude / 2 (road.square_edge); x_install: where the damper sits at rest (run)."""
    if not amplitude or not np.isfinite(amplitude):
        raise DamperError(f"step amplitude must be non-zero and finite, got {amplitude}")
    d = _damper(damper)
    t = np.arange(int(round(duration / h)) + 1) * h
    road = square_edge(t, amplitude, t_step) if square else step(t, amplitude, t_step)
    r = run(car, d, t, road, np.zeros_like(t), T=T, x_install=x_install)
    m = {"overshoot_sprung": metrics.overshoot_percent(t, r.y1, t_step),
         "settling_sprung": metrics.settling_time(t, r.y1, t_step),
         "overshoot_unsprung": metrics.overshoot_percent(t, r.y2, t_step),
         "settling_unsprung": metrics.settling_time(t, r.y2, t_step)}
    return r, m


# --- parametric study (6.3) ------------------------------------------------------------

VARIATIONS = ("low_speed_compression", "mid_speed_compression", "low_speed_rebound",
              "mid_speed_rebound", "friction", "compliance")
FACTORS = (0.5, 2.0)
TEMPERATURES_C = (45.0, 180.0)  # 6.3.4 (180 C is beyond the rated 150 C: the thesis's choice)


def _scale_direction(direction, speed, k):
    if speed == "low":
        b = direction.low
        return dataclasses.replace(direction, low=dataclasses.replace(
            b, C_orrpw=b.C_orrpw * k, C_linpw=b.C_linpw * k, C_ipw=b.C_ipw * k))
    # mid-speed: the slope of the mid valve (and of the high-speed valve replacing it)
    mid = direction.mid and dataclasses.replace(direction.mid, C_linw=direction.mid.C_linw * k)
    high = direction.high and dataclasses.replace(direction.high, C_linw=direction.high.C_linw * k)
    return dataclasses.replace(direction, mid=mid, high=high)


def vary(d: Damper, variation: str, k: float) -> Damper:
    """A copy of damper d with one property scaled by k (6.3.1-6.3.3). Compression
    damping scales the piston's compression side and the compression head alike."""
    if variation == "friction":
        f = d.friction
        return dataclasses.replace(d, friction=dataclasses.replace(f, F_table=[F * k for F in f.F_table]))
    if variation == "compliance":  # compliance is 1 / bulk modulus
        c = d.compressibility
        scaled = {n: getattr(c, n) / k for n in ("beta_inv", "C_ibeta", "C_sbeta", "beta_min_inv")
                  if getattr(c, n) is not None}
        return dataclasses.replace(d, compressibility=dataclasses.replace(c, **scaled))
    if variation not in VARIATIONS:
        raise DamperError(f"unknown variation {variation!r} (known: {', '.join(VARIATIONS)}, temperature)")
    speed, side = variation.split("_speed_")
    v = d.valves

    def path(p):
        if p is None:
            return None
        return dataclasses.replace(p, **{side: _scale_direction(getattr(p, side), speed, k)})

    head = path(v.head) if side == "compression" else v.head
    return dataclasses.replace(d, name=f"{d.name} {variation} x{k:g}",
                               valves=dataclasses.replace(v, piston=path(v.piston), head=head))


def parametric_cases(d: Damper):
    """(label, damper, T [K]) for the baseline and every variation of 6.3."""
    cases = [("baseline", d, T_BASE)]
    for var in VARIATIONS:
        for k in FACTORS:
            cases.append((f"{var} x{k:g}", vary(d, var, k), T_BASE))
    for T_C in TEMPERATURES_C:
        cases.append((f"temperature {T_C:g}C", d, float(C_to_K(T_C))))
    return cases


def parametric_study(car: QuarterCar, damper, amplitudes=AMPLITUDES, freqs=FREQS, executor=None,
                     workers=None, progress=None) -> dict:
    """label -> FrequencyResponse for the baseline and each variation, all points of all
    cases in one parallel batch."""
    d = _damper(damper)
    if not isinstance(d, Damper):
        raise DamperError("the parametric study needs a comprehensive damper model, not a simplified one")
    study = sweep_cases(car, parametric_cases(d), amplitudes, freqs, True, executor, workers, progress,
                        f"{d.name} parametric")
    g = d.gas_spring
    gas = lambda T: float(gas_spring.static_force(d.mid_stroke, T, g.P0, g.V0, g.T0, d.geometry.A_r,
                                                  g.K_voil, g.K_voint))  # eqs 4.3-4.5
    for label, fr in study.items():
        fr.damper = label
        fr.static_offset = (gas(fr.T) - gas(T_BASE)) / car.k_s
    return study


def simplified_comparison(car: QuarterCar, comprehensive="koni", simplified=("simplified-I", "simplified-II"),
                          amplitude=0.0032, freqs=FREQS, executor=None, workers=None, progress=None) -> dict:
    """name -> FrequencyResponse of the comprehensive model and the simplified models I and
    II (6.4: 0.32 cm excitation)."""
    names = (comprehensive, *simplified)
    return sweep_cases(car, [(n, n, T_BASE) for n in names], [amplitude], freqs, True, executor, workers,
                       progress, "simplified models")
