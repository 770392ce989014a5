"""The numbers a damper engineer reads off a sine test: per measured sine segment, the peak
force at the peak compression and rebound velocity, the damping force there (measured less
gas and friction, as the thesis plots it, chapter 4), and what a damper model predicts; a
table (HTML and CSV) in the chosen unit system (protocols/units.py)."""
from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from protocols.units import Units, fmt
from views.reports.stroke import stroke

READS = ("force", "x", "v", "T_body")  # the channels the peaks are read from (load_recording's channels=)
T_ROOM = 293.15  # K: a segment's temperature when the recording has no body thermocouple
SHORT_PCT = 3.0  # a segment whose peak speed falls short of its target by more is flagged
# the motion's fit: a sine and its overtones (a crank's stroke carries its rod ratio's
# second and third harmonics; a servo's sine has none to speak of) - a choice
HARMONICS = 3
FIT_MISFIT = 0.05  # of the half-travel: a worse fit is no sine, its peaks are read off the samples
PHASE_WINDOW = 0.01  # of a cycle either side of the peak speed's phase the force is averaged over


@dataclass
class Peak:
    segment: str
    amplitude_mm: float
    freq_hz: float
    target_c: float  # nan: not a temperature sweep
    T_c: float  # measured body temperature over the segment [C]
    v_comp: float  # peak compression velocity [m/s]
    F_comp: float  # measured force there [N]
    v_reb: float  # peak rebound velocity [m/s] (negative)
    F_reb: float  # [N] (negative)
    Fd_comp: float = np.nan  # damping force: measured - gas - friction [N]
    Fd_reb: float = np.nan
    model_comp: float = np.nan  # the model's force at the same instants [N]
    model_reb: float = np.nan
    achieved_mm: float = np.nan  # amplitude the rod reached, half its travel over the segment [mm]
    short_pct: float = np.nan  # how far the peak speed fell short of 2 pi f A [% of it]; negative: over
    cycles: int = 0  # settled cycles the peaks are averaged over (0: read off single samples)
    crank_ratio: float = np.nan  # the source's motion a slider crank's, of this r/l (crank_ratio()); nan: a sine
    adapted: str = ""  # recorded at another frequency than asked for by the pre-flight: what and why
    # the force read along the stroke (stroke()): speeds [m/s] rising from rebound to
    # compression, the measured force and the model's there [N]; what a one-speed run's
    # velocity table is read from
    stroke_v: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stroke_F: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stroke_W: np.ndarray = field(default_factory=lambda: np.zeros(0))  # the loop's half-width there [N]
    model_stroke_F: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def test(self):
        """What makes two recordings' segments comparable (Test.same), never the name."""
        from records.data import Test
        return Test.of(vars(self))




def recorded_damper(meta):
    """The full damper model the recording was made with, or None (simplified or absent)."""
    from models.damper import DamperError, from_dict
    try:
        d = from_dict(json.loads(meta.get("damper", {}).get("model", "") or "null"))
    except (DamperError, ValueError, TypeError, KeyError):
        return None
    return None if getattr(d, "layout", "simplified") == "simplified" else d


def window(ch, names, t0, t1):
    """(t, [values...]) of the channels `names` between t0 and t1 on the first one's clock
    (the others interpolated to its sample times: channels arrive at their own rates)."""
    t, first = ch[names[0]]
    k = (t >= t0) & (t <= t1)
    tk = t[k]
    return tk, [first[k]] + [np.interp(tk, *ch[n]) if len(ch[n][0]) else np.full(len(tk), np.nan)
                             for n in names[1:]]


def sines(segs):
    return [s for s in segs if s.kind == "sine" and "amplitude_mm" in s.params]


def simulate_segment(damper, t, x, v, T):
    """A full damper model's force [N] along measured motion (x [m], v [m/s]) at T [K]:
    the compressible model (eq 3.19-3.32) on a uniform clock, with the gas spring's rest
    position at mid-stroke (eq 4.4) as on the rig. A minimal model (models/minimal.py)
    gives its force along the motion itself."""
    from models.physics.simulate import simulate
    if not hasattr(damper, "geometry"):  # a minimal model, or one sampled along the recording (along())
        return damper.simulate(t, x, v, T)
    tu = np.linspace(t[0], t[-1], len(t))
    stroke = damper.geometry.stroke
    r = simulate(damper, tu, np.clip(x, 0.0, stroke), v, T=T, compressible=True, x_e=damper.mid_stroke)
    return r


@dataclass
class Sampled:
    """A model's force computed once along a whole recording, read at any instants of it."""
    name: str
    t: np.ndarray  # s
    force: np.ndarray  # N

    def simulate(self, t, x, v, T=None):
        return SimpleNamespace(force=np.interp(t, self.t, self.force))


@dataclass
class ThroughSource:
    """A full damper model read through the moving average a recording's source applied
    (records/source_filter.py): its force along a stretch of motion, filtered at the
    stretch's own period (its displacement's strongest frequency)."""
    damper: object
    smoothing: object

    @property
    def name(self):
        return self.damper.name

    def simulate(self, t, x, v, T=None):
        r = simulate_segment(self.damper, t, x, v, T)
        h = float(np.median(np.diff(t)))
        spectrum = np.abs(np.fft.rfft(x - np.mean(x), 8 * len(x)))  # padded: a few cycles still read finely
        f = float(np.fft.rfftfreq(8 * len(x), h)[1 + np.argmax(spectrum[1:])])
        cycles = (t[-1] - t[0] + h) * f  # a sine segment's whole cycles: the filter reaches round them
        whole = cycles >= 1.5 and abs(cycles - round(cycles)) < 0.05
        r.force = self.smoothing.apply(r.force, t, h, f if self.smoothing.per_period else None, whole_cycles=whole)
        return r


def along(model, ch, events, meta=None):
    """The model to read along this recording: a minimal model with the diagnosis's effects
    (which read time, history and auxiliary channels, and are built on the recording they
    were fitted on), or along a recording its source smoothed (meta: load_recording's; the
    model goes through the same filter), computed once along all of it (Sampled; between
    the samples the diagnosis keeps, interpolated); a full damper model along a smoothed
    recording through its filter (ThroughSource); any other model as it is. DamperError
    when its source recording or a channel its effects read is missing."""
    from records import source_filter
    smoothing = source_filter.of(meta or {})
    if smoothing and hasattr(model, "geometry"):  # a full damper model, simulated stretch by stretch
        return ThroughSource(model, smoothing)
    if not getattr(model, "effects", None) and not (smoothing and hasattr(model, "along")):
        return model
    if not model.effects:
        return Sampled(model.name, *model.along(None, (ch, events), smoothing))
    from models.damper import DamperError
    from records.reader import merged
    from rig.errors import UsageError
    try:
        source = merged(model.source)[:2]
    except (UsageError, OSError) as e:
        raise DamperError(f"{model.name}: its effects are built on the recording it was fitted on: {e}") from None
    return Sampled(model.name, *model.along(source, (ch, events), smoothing))


def settled_after(prm):
    """Seconds into a sine segment after which a model started at rest along it has
    forgotten its start (one cycle)."""
    return 1.0 / prm["freq_hz"]


def segment_temperature(ch, t0, t1):
    """The body's mean temperature over [t0, t1] [K]; nan when the recording has none (it
    is shown as "-", never as a room temperature the file does not hold)."""
    if "T_body" not in ch:
        return np.nan
    _, (T,) = window(ch, ("T_body",), t0, t1)
    return float(np.mean(T)) if len(T) else np.nan


def model_temperature(T):
    """The temperature [K] a model is evaluated at: the measured one, T_ROOM without one."""
    return T if np.isfinite(T) else T_ROOM


NO_TEMPERATURE = (f"The recording has no body temperature: its T is shown as \"-\", and a model read along it is "
                  f"evaluated at {T_ROOM - 273.15:g} C.")


@dataclass
class Cycle:
    """A sine segment's averaged cycle: the displacement's harmonic fit at the segment's
    (refined) frequency, and where on the cycle its speed peaks."""
    phase: np.ndarray  # of each sample, 0..1 of a cycle
    v: np.ndarray  # the fitted displacement's derivative at each sample [m/s]
    peak_phase: tuple  # (compression, rebound) phase of the fitted peak speeds
    v_peak: tuple  # (compression, rebound) fitted peak speeds [m/s]
    cycles: int  # whole cycles averaged
    crank_ratio: float = np.nan  # a slider crank's crank-to-rod ratio r/l the stroke shows (crank_ratio())

    def at_peaks(self, y):
        """The mean of y over the samples within PHASE_WINDOW of each peak's phase, all
        cycles together: (compression, rebound)."""
        half = max(PHASE_WINDOW, 0.6 / max(len(y) / max(self.cycles, 1), 1.0))
        out = []
        for ph in self.peak_phase:
            near = np.abs((self.phase - ph + 0.5) % 1.0 - 0.5) <= half
            out.append(float(np.mean(y[near])) if np.any(near) else np.nan)
        return tuple(out)


def _harmonics(t, f, n=HARMONICS):
    w = 2 * np.pi * f * t
    return np.column_stack([np.ones(len(t))] + [g(k * w) for k in range(1, n + 1) for g in (np.sin, np.cos)])


def cycle(t, x, freq_hz):
    """The averaged cycle of a sine segment's settled samples (Cycle), or None when its
    displacement is no periodic motion at that frequency (the fit misses by more than
    FIT_MISFIT of the half-travel). The frequency is refined within 2 % first: an imported
    run's is estimated."""
    if freq_hz <= 0 or len(t) < 4 * (2 * HARMONICS + 1):
        return None
    t = t - t[0]
    half = 0.5 * float(np.ptp(x))
    if half <= 0 or t[-1] * freq_hz < 1.0:
        return None

    def fit(f, step=1):
        A = _harmonics(t[::step], f)
        c = np.linalg.lstsq(A, x[::step], rcond=None)[0]
        return float(np.sum((A @ c - x[::step]) ** 2)), c
    step = max(1, len(t) // 20000)  # the search on a thinned copy: a long import's million samples
    fs = freq_hz * np.linspace(0.98, 1.02, 41)
    i = int(np.argmin([fit(f, step)[0] for f in fs]))
    fine = fs[max(i - 1, 0)] + (fs[min(i + 1, len(fs) - 1)] - fs[max(i - 1, 0)]) * np.linspace(0, 1, 21)
    f = float(min(fine, key=lambda g: fit(g, step)[0]))
    sse, c = fit(f)
    if np.sqrt(sse / len(t)) > FIT_MISFIT * half:
        return None
    k = np.arange(1, HARMONICS + 1)
    w = 2 * np.pi * f

    def speed(tt):  # the fit's derivative [m/s]
        return sum(w * kk * (c[2 * kk - 1] * np.cos(kk * w * tt) - c[2 * kk] * np.sin(kk * w * tt)) for kk in k)
    grid = np.linspace(0.0, 1.0 / f, 2000, endpoint=False)
    vg = speed(grid)
    ic, ir = int(np.argmax(vg)), int(np.argmin(vg))
    return Cycle((t * f) % 1.0, speed(t), (ic / len(grid), ir / len(grid)), (float(vg[ic]), float(vg[ir])),
                 int(t[-1] * f), crank_ratio(c))


CRANK_SECOND = 0.01  # a second harmonic of at least this share of the stroke's fundamental ...
CRANK_ALIGNED = 0.3  # ... in phase with it as a crank's (|sin| of the phase difference below this)


def crank_ratio(c):
    """A slider crank's crank-to-rod ratio r/l from a stroke's harmonic fit c (constant, then
    sin and cos of each harmonic), nan when the stroke is no crank's. A slider crank moves
    x = r (1 - cos th) + l (1 - sqrt(1 - (r/l)^2 sin^2 th)): to second order a fundamental and
    a second harmonic of r/l / 4 of it, their phases locked (the two peak speeds equal, both
    above 2 pi f r); a servo's or a Scotch yoke's sine has none."""
    a1, a2 = np.hypot(c[1], c[2]), np.hypot(c[3], c[4])
    if a1 <= 0 or a2 < CRANK_SECOND * a1:
        return np.nan
    aligned = abs(np.sin(np.arctan2(c[3], c[4]) - 2 * np.arctan2(c[1], c[2]))) < CRANK_ALIGNED
    return float(4 * a2 / a1) if aligned else np.nan


def crank_over(ratio):
    """How far a slider crank's peak speed lies above 2 pi f r [share], at its ratio r/l:
    the peak of sin th + (r/l) / 2 sin 2 th."""
    th = np.linspace(0.0, np.pi, 4001)
    return float(np.max(np.sin(th) + 0.5 * ratio * np.sin(2 * th)) - 1.0)


def peaks(ch, segs, damper=None, model=None):
    """[Peak] of the sine segments. damper: a full model whose gas and friction are taken
    off for the damping force; model: a full model simulated along each segment."""
    out = []
    if not {"force", "x", "v"} <= set(ch):
        return out
    for name, prm, t0, t1 in sines(segs):
        t, (F, x, v) = window(ch, ("force", "x", "v"), t0, t1)
        if len(F) < 10:
            continue
        late = t >= t[0] + settled_after(prm)  # a model simulated along the segment has settled
        late = late if late.sum() > 10 else np.ones(len(t), bool)
        T_measured = segment_temperature(ch, t0, t1)
        T = model_temperature(T_measured)
        # peak speed from the fitted motion, force from the averaged cycle at that phase (as
        # commercial dyno software reads it): a noisy velocity channel's largest sample is not
        # the rod's speed; a segment that is no sine falls back to single samples
        cyc = cycle(t[late], x[late], prm["freq_hz"])
        if cyc is not None:
            (vc, vr), (Fc, Fr) = cyc.v_peak, cyc.at_peaks(F[late])
            xs = np.array(cyc.at_peaks(x[late]))
            v_read = cyc.v
        else:
            ic, ir = (int(np.flatnonzero(late)[0] + f(v[late])) for f in (np.argmax, np.argmin))
            vc, Fc, vr, Fr, xs = float(v[ic]), float(F[ic]), float(v[ir]), float(F[ir]), x[[ic, ir]]
            v_read = v[late]
        p = Peak(name, prm["amplitude_mm"], prm["freq_hz"], prm.get("target_c", np.nan), T_measured - 273.15, vc, Fc, vr,
                 Fr)
        p.cycles = cyc.cycles if cyc is not None else 0
        p.crank_ratio = cyc.crank_ratio if cyc is not None else np.nan
        p.achieved_mm = 0.5 * float(np.ptp(x[late])) * 1e3
        p.adapted = prm.get("adapted", "")
        p.stroke_v, p.stroke_F, p.stroke_W = stroke(v_read, F[late], widths=True)
        target = 2 * np.pi * prm["freq_hz"] * prm["amplitude_mm"] * 1e-3
        p.short_pct = 100.0 * (1.0 - 0.5 * (p.v_comp - p.v_reb) / target) if target > 0 else np.nan
        if damper is not None:
            from models.physics.simulate import simulate
            r = simulate(damper, np.arange(2) * 1e-3, xs, np.array([vc, vr]), T=T, compressible=False,
                         x_e=damper.mid_stroke)
            p.Fd_comp, p.Fd_reb = np.array([p.F_comp, p.F_reb]) - (r.gas + r.friction)
        if model is not None:
            r = simulate_segment(model, t, x, v, T)
            p.model_comp, p.model_reb = (cyc.at_peaks(r.force[late]) if cyc is not None
                                         else (float(r.force[ic]), float(r.force[ir])))
            p.model_stroke_F = stroke(v_read, r.force[late])[1]
        out.append(p)
    return out


SCATTER = "motion that does not repeat"  # the name of scatter()'s row
UNREPEATED = ("road", "random", "sweep", "ramp")  # segments of motion that does not repeat ...
STILL = ("hold", "dwell", "step")  # ... and those read beside them
SCATTER_QUANTILE = 0.005  # of each direction's samples left out at its top speed: a random input's rare extremes


def scattered(ch, segs, model=None) -> list:
    """[scatter()] of a recording whose motion does not repeat (road input, an imported
    program's random motion or sweeps, with holds beside them); [] when it holds tests of
    ours or steady tests cut from an imported program, whose table is read from them."""
    if not any(s.kind in UNREPEATED for s in segs) or any(s.kind not in UNREPEATED + STILL for s in segs):
        return []
    return [p for p in (scatter(ch, model),) if p is not None]


def scatter(ch, model=None):
    """A recording of motion that does not repeat (a random or road input) read as one
    stroke (Peak named SCATTER): the mean force in speed bins over all its samples, the
    force-velocity scatter's mid-line, as a random-input test is read; the model's force
    along the same motion binned alike. None without force, x and v."""
    if not {"force", "x", "v"} <= set(ch) or len(ch["force"][0]) < 10:
        return None
    t, (F, x, v) = window(ch, ("force", "x", "v"), -np.inf, np.inf)
    lo, hi = np.quantile(v, [SCATTER_QUANTILE, 1 - SCATTER_QUANTILE])
    k = (v >= lo) & (v <= hi)
    T_measured = segment_temperature(ch, t[0], t[-1])
    T = model_temperature(T_measured)
    p = Peak(SCATTER, np.nan, np.nan, np.nan, T_measured - 273.15, float(hi), np.nan, float(lo), np.nan)
    p.stroke_v, p.stroke_F = stroke(v[k], F[k])  # no loop: motion that does not repeat
    if len(p.stroke_v) == 0:
        return None
    p.F_comp, p.F_reb = float(p.stroke_F[-1]), float(p.stroke_F[0])
    if model is not None:
        p.model_stroke_F = stroke(v[k], simulate_segment(model, t, x, v, T).force[k])[1]
        p.model_comp, p.model_reb = float(p.model_stroke_F[-1]), float(p.model_stroke_F[0])
    return p


# (Peak field, column name, quantity, and the scale and offset that take it to SI) of the
# CSV and the page's table, shown in the chosen unit system (protocols/units.py)
COLUMNS = (("amplitude_mm", "amplitude", "length", 1e-3, 0.0), ("achieved_mm", "reached", "length", 1e-3, 0.0),
           ("freq_hz", "freq", "frequency", 1.0, 0.0), ("target_c", "target_T", "temperature", 1.0, 273.15),
           ("T_c", "T", "temperature", 1.0, 273.15), ("v_comp", "v_comp", "velocity", 1.0, 0.0),
           ("F_comp", "F_comp", "force", 1.0, 0.0), ("v_reb", "v_reb", "velocity", 1.0, 0.0),
           ("F_reb", "F_reb", "force", 1.0, 0.0), ("Fd_comp", "Fd_comp", "force", 1.0, 0.0),
           ("Fd_reb", "Fd_reb", "force", 1.0, 0.0), ("model_comp", "model_comp", "force", 1.0, 0.0),
           ("model_reb", "model_reb", "force", 1.0, 0.0))


def shown(p, field, units):
    """A Peak's field in the unit system's unit."""
    _, _, q, scale, offset = next(c for c in COLUMNS if c[0] == field)
    return units.show(q, getattr(p, field) * scale + offset)


def write_csv(rows, path, units=Units()):
    """peaks.csv: a column per field with its unit in the name; blank where not measured."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["segment"] + [units.column(name, q) for _, name, q, _, _ in COLUMNS] + ["cycles_averaged", "short_pct", "adapted"])
        for p in rows:
            values = [shown(p, c[0], units) for c in COLUMNS] + [p.cycles, p.short_pct]
            w.writerow([p.segment] + ["" if not np.isfinite(v) else f"{v:.6g}" for v in values] + [p.adapted])
    return path


def table(rows, units=Units()):
    """(header, rows) for the page, in the unit system's units."""
    has_d = any(np.isfinite(p.Fd_comp) for p in rows)
    has_m = any(np.isfinite(p.model_comp) for p in rows)
    lab = units.label
    head = (["segment", lab("amplitude", "length"), lab("reached", "length"), "freq [Hz]", lab("T", "temperature"),
             lab("v comp", "velocity"), lab("F comp", "force"), lab("v reb", "velocity"), lab("F reb", "force")]
            + ([lab("damping comp", "force"), lab("damping reb", "force")] if has_d else [])
            + ([lab("model comp", "force"), lab("model reb", "force"),
                "model error comp/reb [% of the segment's force range]"] if has_m else []))
    body = []
    for p in rows:
        span = max(p.F_comp - p.F_reb, 1e-9)
        short = (f" (speed {p.short_pct:.0f} % short)" if p.short_pct > SHORT_PCT else
                 f" (speed {-p.short_pct:.0f} % over)" if p.short_pct < -SHORT_PCT else "")
        short += f" (adapted: {p.adapted})" if p.adapted else ""
        fields = ["amplitude_mm", "achieved_mm", "freq_hz", "T_c", "v_comp", "F_comp", "v_reb", "F_reb"]
        fields += ["Fd_comp", "Fd_reb"] if has_d else []
        fields += ["model_comp", "model_reb"] if has_m else []
        r = [units.segment(p.segment) + short] + [fmt(shown(p, f, units)) for f in fields]
        if has_m:
            r.append(f"{100 * (p.model_comp - p.F_comp) / span:+.1f} / {100 * (p.model_reb - p.F_reb) / span:+.1f}")
        body.append(r)
    return head, body
