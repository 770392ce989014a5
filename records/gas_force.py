"""The gas force a recording holds, from what physics separates (issue 89), each estimate
with its 95 % interval, as recorded (a lab's sign, a lab's unit).

At a turning point of the stroke the velocity is zero, and so is the valves' force (a
function of the velocity through the pistons' orifices, eqs 3.9-3.13); friction changes
sign with the direction; the gas spring's force at that position, F_G = p A_rod (eq 3.19),
is what is left. Near each turning point the force is fitted as

    F = G + f s + c_c v+ + c_r v-     (s = +1 before the turn, -1 after, as the motion came)

over the samples within WINDOW of the shorter half-cycle either side: G is the force at
zero velocity with friction cancelled (its two directions) whatever the valves' asymmetry.
Checked on the thesis model (models/physics): the Koni's 430.5 N is read as 428-435 N at
0.5-1 Hz, 409 +- 22 N at 3 Hz 5 mm; at 5 Hz 20 mm (0.63 m/s) the oil's compliance leaves the
force lagging the motion and 360 +- 5 N is read: a bias the interval, from the turning
points' scatter, does not hold (docs/recording.md#gas-force).
A line through every turning point's G against its position gives the gas force at the
motion's mid position and its rise with compression (the gas spring's stiffness, eq 3.19
with eq 3.7's polytropic pressure). A regression of the force on position and velocity
over a sine cannot do this: there a constant, x^2 and |v| are nearly one column.

For runs of one damper at one motion, the valves and friction are the same and the
difference of their mean forces over the same whole cycles is the difference of their gas
forces (difference()). Scale-free: raw volts tell the sign as well."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from records.steady import FoundSegment

WINDOW = 0.05  # of the shorter half-cycle either side of a turning point: the velocity within 16 % of its peak
MIN_SIDE = 3  # samples at least on each side of a turning point
MIN_TURNS = 3  # turning points at least for an interval


def _t95(dof: int) -> float:
    """Student's t for a two-sided 95 % interval."""
    from scipy.stats import t as student
    return float(student.ppf(0.975, max(dof, 1)))


@dataclass
class GasForce:
    """The gas force at the motion's mid position [F's unit] as recorded, its 95 % interval's
    half-width, its rise with compression [F's unit per x's unit] and that rise's half-width,
    the mid position [x's unit] and the turning points it was read at."""
    level: float
    half_width: float
    stiffness: float
    stiffness_half_width: float
    mid: float
    turns: int

    @property
    def above_zero(self) -> bool:
        return self.level - self.half_width > 0

    @property
    def below_zero(self) -> bool:
        return self.level + self.half_width < 0

    def text(self, unit="N") -> str:
        return f"{self.level:+.3g} +- {self.half_width:.2g} {unit}"


def at_turns(t: np.ndarray, x: np.ndarray, F: np.ndarray) -> GasForce | None:
    """The gas force from the force at zero velocity at the turning points (both ends of
    the stroke, both directions), or None where the motion has fewer than MIN_TURNS turning
    points between strokes of records/strokes.MIN_TRAVEL (in x's unit, metres here)."""
    from records.strokes import MIN_REVERSAL, REVERSAL_NOISE, Halves, noise, smoothed, turns
    t, x, F = (np.asarray(a, float) for a in (t, x, F))
    ok = np.isfinite(t) & np.isfinite(x) & np.isfinite(F)
    t, x, F = t[ok], x[ok], F[ok]
    if len(t) < 30 or np.ptp(x) <= 0:
        return None
    h = float(np.median(np.diff(t)))
    scale = float(np.ptp(x))  # scale-free: the turning points are found on x in units of its span, in metres' sizes
    xs = smoothed(x / scale, h) * 0.1
    H = Halves.of(t, xs, max(REVERSAL_NOISE * noise(t, xs), MIN_REVERSAL))
    v = np.gradient(xs, t)
    G, at = [], []
    for tr, half in turns(t, H):
        i = int(np.searchsorted(t, tr))
        w = max(MIN_SIDE, int(round(WINDOW * half / h)))
        a, b = max(0, i - w), min(len(t), i + w + 1)
        if i - a < MIN_SIDE or b - i - 1 < MIN_SIDE:
            continue
        came = np.sign(np.mean(v[a:i]))  # the direction the motion came in
        s = np.where(np.arange(a, b) < i, came, -came)
        vv = v[a:b] / (np.max(np.abs(v[a:b])) or 1.0)
        A = np.column_stack([np.ones(b - a), s, np.maximum(vv, 0), np.minimum(vv, 0)])
        coef, *_ = np.linalg.lstsq(A, F[a:b], rcond=None)
        G.append(coef[0])
        at.append(float(np.mean(x[max(0, i - 1):i + 2])))
    if len(G) < MIN_TURNS:
        return None
    G, at = np.array(G), np.array(at)
    mid = 0.5 * (at.min() + at.max())
    u = at - mid
    spread = np.ptp(at) > 0.05 * scale
    A = np.column_stack([np.ones_like(u), u]) if spread else np.ones((len(u), 1))
    coef, *_ = np.linalg.lstsq(A, G, rcond=None)
    r = G - A @ coef
    dof = len(G) - A.shape[1]
    if dof < 1:
        return None
    s2 = float(r @ r) / dof
    cov = s2 * np.linalg.pinv(A.T @ A)
    k = _t95(dof)
    level, hw = float(coef[0]), k * math.sqrt(max(cov[0, 0], 0.0))
    stiff, shw = (float(coef[1]), k * math.sqrt(max(cov[1, 1], 0.0))) if spread else (math.nan, math.nan)
    return GasForce(level, hw, stiff, shw, float(mid), len(G))


SETTLE = 0.5  # of a hold skipped at its start: the oil's compliance and the gas's heat (eq 3.7) relax there


def at_rest(t: np.ndarray, F: np.ndarray, holds: list[tuple[float, float, float, int]]) -> GasForce | None:
    """The gas force from the force held at rest: holds [(t0 [s], t1 [s], position [x's
    unit], +1 come into by compression, -1 by extension)] (records/segmentation's holds and
    dwells, their "approach"). At rest the valves give nothing and the seal holds whatever
    friction it was left with, in the direction the motion came (+f after compression, -f
    after extension), so the holds' mean forces are fitted as G + f d (+ k (x - mid) where the
    positions spread). None unless holds were come into from both directions: from one
    only, the gas force and the friction held are one number. With one hold each way the
    gas force lies between them: the interval is that bound."""
    t, F = np.asarray(t, float), np.asarray(F, float)
    m, d, at = [], [], []
    for t0, t1, x, came in holds:
        k = (t >= t0 + SETTLE * (t1 - t0)) & (t <= t1) & np.isfinite(F)
        if k.sum() >= MIN_SIDE and came:
            m.append(float(np.mean(F[k])))
            d.append(float(np.sign(came)))
            at.append(float(x))
    if not (1.0 in d and -1.0 in d):
        return None
    m, d, at = np.array(m), np.array(d), np.array(at)
    mid = 0.5 * (at.min() + at.max())
    if len(m) == 2:
        return GasForce(float(m.mean()), 0.5 * abs(m[0] - m[1]), math.nan, math.nan, float(mid), 2)
    u = at - mid
    spread = len(m) >= 4 and np.ptp(at) > 0
    A = np.column_stack([np.ones_like(m), d] + ([u] if spread else []))
    coef, *_ = np.linalg.lstsq(A, m, rcond=None)
    r = m - A @ coef
    dof = len(m) - A.shape[1]
    cov = float(r @ r) / dof * np.linalg.pinv(A.T @ A)
    k = _t95(dof)
    stiff, shw = (float(coef[2]), k * math.sqrt(max(cov[2, 2], 0.0))) if spread else (math.nan, math.nan)
    return GasForce(float(coef[0]), k * math.sqrt(max(cov[0, 0], 0.0)), stiff, shw, float(mid), len(m))


def holds_of(segments: list[FoundSegment]) -> list[tuple[float, float, float, int]]:
    """at_rest's holds from records/segmentation's segments (positions in m)."""
    side = {"compression stroke": 1, "extension stroke": -1}
    return [(s.t0, s.t1, 1e-3 * s.params["x_mm"], side.get(s.params.get("approach"), 0))
            for s in segments if s.kind in ("hold", "dwell") and "x_mm" in s.params]


def said_at_rest(gas: GasForce | None, holds: list[tuple[float, float, float, int]]) -> list[str]:
    """What import says of the gas force held at rest (SI: N, m): nothing without holds."""
    holds = [h for h in holds if h[3]]
    if not holds:
        return []
    if gas is None:
        return [f"gas force at rest: unknown ({len(holds)} hold{'s' * (len(holds) > 1)}, all come into from one "
                f"direction: the gas force and the seal's friction held are one number there)"]
    out = f"gas force at rest: {gas.text()} from {gas.turns} holds come into from both directions (friction cancelled"
    out += "; the interval is the bound between them)" if gas.turns == 2 else "; 95 % interval)"
    if gas.below_zero:
        out += ": below zero beyond its interval, which a gas spring's cannot be"
    return [out]


MEAN_REMOVED = 0.02  # of a channel's range: a mean closer to zero reads as removed by the source


def centred(y: np.ndarray, gas: GasForce | None = None) -> bool:
    """Whether a lab's channel reads as centred on zero by its source (a mean removed, or a
    load cell zeroed with the rod mid-stroke): its mean within MEAN_REMOVED of its range of
    zero, and below zero somewhere. A force's mean is its gas force and the valves'
    asymmetry: near zero it says a mean removed only where the gas force at the turning
    points (gas, the force's) is not above zero either."""
    y = np.asarray(y, float)
    if len(y) < 2 or not np.any(np.isfinite(y)):
        return False
    span = float(np.nanmax(y) - np.nanmin(y))
    held = gas is not None and gas.above_zero
    return span > 0 and np.nanmin(y) < 0 and abs(float(np.nanmean(y))) < MEAN_REMOVED * span and not held


def said(gas: GasForce | None, centred_on_zero: bool = False) -> str:
    """What import says of a recording's gas force (SI: N, m), a gas force below zero beyond
    its interval whatever its size; unknown where the force reads as centred on zero by its
    source (centred()): about a zero the source chose no reading is the gas force."""
    if gas is None:
        return "gas force: unknown (the motion has too few turning points to read it at)"
    out = (f"{gas.text()} at the stroke's turning points (friction cancelled; 95 % interval), at "
           f"{1e3 * gas.mid:.4g} mm" + (f", rising {gas.stiffness / 1e3:+.3g} +- {gas.stiffness_half_width / 1e3:.2g} "
                                        f"N/mm with compression" if np.isfinite(gas.stiffness) else ""))
    out = (f"gas force: unknown: the force reads as centred on zero (a mean removed by the source, or a load cell "
           f"zeroed with the rod mid-stroke); about that zero it reads {out}" if centred_on_zero
           else f"gas force: {out}")
    if gas.below_zero:
        out += (": below zero beyond its interval, which a gas spring's cannot be (it pushes the rod out): the force's "
                "zero is elsewhere (a load cell's offset kept, or the mean removed by the source), or force and "
                "displacement are both counted the other way (--flip force --flip displacement)")
    return out


def cycle_means(t: np.ndarray, F: np.ndarray, t0: float, t1: float, freq: float) -> np.ndarray:
    """The force's mean [F's unit] over each whole cycle of a test at freq [Hz] from t0 to t1 [s]."""
    t = np.asarray(t, float)
    k = np.floor((t - t0) * freq).astype(int)
    ok = (k >= 0) & (t <= t1) & np.isfinite(F)
    n = np.bincount(k[ok])
    sums = np.bincount(k[ok], np.asarray(F, float)[ok])
    full = n >= 0.9 * np.median(n[n > 0]) if n.any() else n > 0
    return sums[full] / n[full]


def difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(the mean of b less the mean of a, its 95 % half-width (Welch)): two runs' per-cycle
    mean forces (cycle_means) over one test of one damper, where the valves and friction
    are the same and what differs is the gas force."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < 2 or len(b) < 2:
        return math.nan, math.nan
    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    dof = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1)) if va + vb > 0 else len(a) + len(b) - 2
    return float(b.mean() - a.mean()), _t95(int(dof)) * math.sqrt(va + vb)


def rising(points: list[tuple], steps: list[tuple] = ()) -> str | None:
    """The sentence on one damper's runs at several gas charges, or None for fewer than two
    charges. points: [(run, charge [its unit], GasForce or None)]; steps: [(run a, run b,
    the difference of their mean forces over one test and its half-width)] (difference()).
    The gas force rises with the charge (eq 3.19: F_G = p A_rod) beyond its interval, falls
    (a run's sign convention or charge is to be checked), or the intervals cannot tell."""
    pts = sorted(((r, c, g) for r, c, g in points if g is not None), key=lambda p: p[1])
    if len({p[1] for p in pts}) < 2:
        return None
    said = ", ".join(f"{run} at {charge:g}: {gas.text()}" for run, charge, gas in pts)
    lo, hi = pts[0][2], pts[-1][2]
    rise, hw = hi.level - lo.level, math.hypot(hi.half_width, lo.half_width)
    falls = any(b[2].level - a[2].level < -math.hypot(a[2].half_width, b[2].half_width)
                for a, b in zip(pts, pts[1:]) if b[1] > a[1])
    more = "".join(f"; {b} against {a} over the same test, the mean force: {d:+.3g} +- {w:.2g} N"
                   for a, b, d, w in steps if np.isfinite(d))
    head = (f"Gas force at the stroke's turning points (friction cancelled) against the gas charge: {said}{more}; ")
    if falls:
        return head + ("it does not rise with the charge, which a gas spring's does (eq 3.19): check each run's sign "
                       "convention (import's --flip) and the charges given")
    if rise > hw:
        return head + f"it rises with the charge ({rise:+.3g} +- {hw:.2g} N from the lowest to the highest), as a gas " \
                      f"spring's does"
    return head + f"its rise ({rise:+.3g} +- {hw:.2g} N) is within its interval: these runs cannot tell"
