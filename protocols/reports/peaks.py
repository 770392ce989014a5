"""The numbers a damper engineer reads off a sine test: per measured sine segment, the peak
force at the peak compression and rebound velocity, the damping force there (measured less
gas and friction, as the thesis plots it, chapter 4), and what a damper model predicts; a
table (HTML and CSV) in the chosen unit system (protocols/units.py)."""
from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field

import numpy as np

from protocols.units import Units, fmt

READS = ("force", "x", "v", "T_body")  # the channels the peaks are read from (load_recording's channels=)
T_ROOM = 293.15  # K: a segment's temperature when the recording has no body thermocouple
SHORT_PCT = 3.0  # a segment whose peak speed falls short of its target by more is flagged
STROKE_BINS = 20  # speed bins per direction of the force read along the stroke


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
    short_pct: float = np.nan  # how far the peak speed fell short of 2 pi f A [% of it]
    adapted: str = ""  # recorded at another frequency than asked for by the pre-flight: what and why
    # the force read along the stroke (stroke()): speeds [m/s] rising from rebound to
    # compression, the measured force and the model's there [N]; what a one-speed run's
    # velocity table is read from
    stroke_v: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stroke_F: np.ndarray = field(default_factory=lambda: np.zeros(0))
    model_stroke_F: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def key(self):
        """What makes two recordings' segments comparable."""
        return (self.amplitude_mm, self.freq_hz, None if np.isnan(self.target_c) else self.target_c)




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
    return [s for s in segs if s[1]["kind"] == "sine" and "amplitude_mm" in s[1]]


def simulate_segment(damper, t, x, v, T):
    """A full damper model's force [N] along measured motion (x [m], v [m/s]) at T [K]:
    the compressible model (eq 3.19-3.32) on a uniform clock, with the gas spring's rest
    position at mid-stroke (eq 4.4) as on the rig. A minimal model (models/minimal.py)
    gives its force along the motion itself."""
    from models.minimal import MinimalModel
    from models.physics.simulate import simulate
    if isinstance(damper, MinimalModel):
        return damper.simulate(t, x, v, T)
    tu = np.linspace(t[0], t[-1], len(t))
    stroke = damper.geometry.stroke
    r = simulate(damper, tu, np.clip(x, 0.0, stroke), v, T=T, compressible=True, x_e=damper.mid_stroke)
    return r


def settled_after(prm):
    """Seconds into a sine segment after which a model started at rest along it has
    forgotten its start (one cycle)."""
    return 1.0 / prm["freq_hz"]


def segment_temperature(ch, t0, t1):
    """The body's mean temperature over [t0, t1] [K]."""
    if "T_body" not in ch:
        return T_ROOM
    _, (T,) = window(ch, ("T_body",), t0, t1)
    return float(np.mean(T)) if len(T) else T_ROOM


def stroke(v, F):
    """The force along the stroke: (speed at each bin's centre [m/s], mean force there [N])
    over STROKE_BINS bins per direction up to the top speed reached. Each bin averages the
    accelerating and the decelerating half of the cycle, as a crank dyno's curve is read
    (the loop's mid-line); bins nothing reached are left out."""
    out_v, out_F = [], []
    for sign in (-1.0, 1.0):
        s = sign * v
        top = float(np.max(s, initial=0.0))
        if top <= 0:
            continue
        edges = np.linspace(0.0, top, STROKE_BINS + 1)
        k = s > 0
        idx = np.minimum(np.searchsorted(edges, s[k], side="right") - 1, STROKE_BINS - 1)
        n = np.bincount(idx, minlength=STROKE_BINS)
        mean = np.bincount(idx, weights=F[k], minlength=STROKE_BINS) / np.maximum(n, 1)
        centre = 0.5 * (edges[:-1] + edges[1:])
        centre[-1] = top  # the last bin is read at the top speed, where the peak is
        ok = n > 0
        out_v.append(sign * centre[ok]), out_F.append(mean[ok])
    v_all, F_all = np.concatenate(out_v or [np.zeros(0)]), np.concatenate(out_F or [np.zeros(0)])
    order = np.argsort(v_all)
    return v_all[order], F_all[order]


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
        ic, ir = (int(np.flatnonzero(late)[0] + f(v[late])) for f in (np.argmax, np.argmin))
        T = segment_temperature(ch, t0, t1)
        p = Peak(name, prm["amplitude_mm"], prm["freq_hz"], prm.get("target_c", np.nan), T - 273.15,
                 float(v[ic]), float(F[ic]), float(v[ir]), float(F[ir]))
        p.achieved_mm = 0.5 * float(np.ptp(x[late])) * 1e3
        p.adapted = prm.get("adapted", "")
        p.stroke_v, p.stroke_F = stroke(v[late], F[late])
        target = 2 * np.pi * prm["freq_hz"] * prm["amplitude_mm"] * 1e-3
        p.short_pct = 100.0 * (1.0 - 0.5 * (p.v_comp - p.v_reb) / target) if target > 0 else np.nan
        if damper is not None:
            from models.physics.simulate import simulate
            r = simulate(damper, np.arange(2) * 1e-3, x[[ic, ir]], v[[ic, ir]], T=T, compressible=False,
                         x_e=damper.mid_stroke)
            p.Fd_comp, p.Fd_reb = np.array([p.F_comp, p.F_reb]) - (r.gas + r.friction)
        if model is not None:
            r = simulate_segment(model, t, x, v, T)
            p.model_comp, p.model_reb = float(r.force[ic]), float(r.force[ir])
            p.model_stroke_F = stroke(v[late], r.force[late])[1]
        out.append(p)
    return out


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
        w.writerow(["segment"] + [units.column(name, q) for _, name, q, _, _ in COLUMNS] + ["short_pct", "adapted"])
        for p in rows:
            values = [shown(p, c[0], units) for c in COLUMNS] + [p.short_pct]
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
        short = f" (speed {p.short_pct:.0f} % short)" if p.short_pct > SHORT_PCT else ""
        short += f" (adapted: {p.adapted})" if p.adapted else ""
        fields = ["amplitude_mm", "achieved_mm", "freq_hz", "T_c", "v_comp", "F_comp", "v_reb", "F_reb"]
        fields += ["Fd_comp", "Fd_reb"] if has_d else []
        fields += ["model_comp", "model_reb"] if has_m else []
        r = [p.segment + short] + [fmt(shown(p, f, units)) for f in fields]
        if has_m:
            r.append(f"{100 * (p.model_comp - p.F_comp) / span:+.1f} / {100 * (p.model_reb - p.F_reb) / span:+.1f}")
        body.append(r)
    return head, body
