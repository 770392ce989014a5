"""The identification pipeline of thesis chapter 4: a recording in, a damper model out.

Steps, each run when its data and channels are there (a step that cannot run says why):
  static      friction look-up (eq 3.1) and the gas charge (eq 3.7)       identify_static
  low-speed   dynamic breakaway friction and its temperature coefficients identify_low_speed
  gas         oil thermal expansion K_voil from the gas pressure at rest (eq 4.6)
  gamma       the polytropic exponent from the gas pressure in the sine segments, with
              the oil the chambers store taken from their measured pressures   identify_gas
  valves      valve structure and coefficients at low acceleration with the damping
              temperature coefficient (eqs 4.12-4.14, 3.30, 4.17)          identify_valves
  dynamic     the compressible model (eqs 3.31-3.56) refitted to whole training segments:
              valves, temperature coefficients, bulk modulus (constant or pressure
              dependent, chosen on held-out segments) and, when the gamma step could not
              run, gamma (eq 4.3), using the gas pressure channel when recorded

Input is plain data: channels {name: (t [s], values [SI])}, the recording's events
(docs/recording.md) and a damper description giving what is measured with a calliper,
not identified: layout, geometry, charge temperature T0 and the reference temperature
T_ref the valve coefficients refer to.

Parameters that enter the model only in combination are identified in one canonical form
(and the comparison with a known damper uses the same form, `canonical`):
  * V0 and K_voint only as V0 - K_voint (eq 4.4), so K_voint = 0;
  * the damping coefficients and C_fd only as coefficient / (1 + C_fd) (eq 4.17), so
    C_fd = 0 and K_effoil / (1 + C_fd) is the temperature coefficient.
"""
from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import butter, filtfilt

from . import identify_gas, identify_low_speed, identify_valves
from .damper import Bypass, Damper, DamperError, ValvePath, Valves
from .gas_spring import P_ATM, T_STD
from .identify_static import Estimate, identify_static, static_holds
from .simulate import simulate

G_START = 1.40  # adiabatic nitrogen: where the gamma fit starts (the thesis found 1.38)
X_STICK_START = 2e-4  # m: starting pre-sliding travel of the friction (Dahl)
BETA_START = 2.0e8  # Pa: starting effective bulk modulus (the thesis's range 0.45-5e8)
HELDOUT_EVERY = 3  # every third dynamic segment is held out of all fitting
WARMUP_S = 0.1  # simulated before a segment's scored part (chamber pressures settle in ms)
TRAIN_CYCLES = 2  # cycles of each training segment used by the compressible fit
MAX_RUNS = 100  # model evaluations per compressible fit (Jacobians not counted)
SCREEN_RUNS = 30  # ... per screening fit (model forms, extra valves), on one cycle per segment
EXTRA_AT = 0.03  # validation NRMSE above which a bypass or high-speed line is tried
BYPASS_SEAT_START = 100.0  # N: seating force a bypass found by the compressible fit starts from
BYPASS_SEAT_MARGIN = 1.25  # ... one the valve step found: this times the largest open force
P_WEIGHT = 0.3  # gas-pressure residuals against force residuals: enough to fix gamma (eq 4.3)


@dataclass
class Segment:
    """A recorded test segment resampled on a uniform clock (the force's)."""
    name: str
    params: dict
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    F: np.ndarray
    T: float  # mean body temperature [K]
    P_gas: np.ndarray | None  # gas pressure on the segment's clock [Pa]
    score_from: int  # samples before it are warm-up
    tP: np.ndarray | None = None  # the gas pressure as sampled (scored part) [s]
    P: np.ndarray | None = None  # [Pa]
    chambers: dict | None = None  # {"t", "x", "v", "P1", "P2", "P_gas"} at the pressure samples

    @property
    def freq(self):
        return float(self.params.get("freq_hz", 0.0))


@dataclass
class Result:
    damper: Damper
    estimates: list = field(default_factory=list)  # [Estimate]
    steps: dict = field(default_factory=dict)  # step -> "done ..." | "skipped: ..."
    correlated: list = field(default_factory=list)  # [(name, name, rho)]
    heldout: list = field(default_factory=list)  # [(segment name, nrmse)]
    train: list = field(default_factory=list)  # [Segment]
    test: list = field(default_factory=list)  # [Segment]
    structures: dict = field(default_factory=dict)  # (path, direction) -> (structure, params, K, K fitted)

    def add(self, *estimates):
        """Record estimates; one a later step refines (the compressible fit refits the
        friction's level found at the reversals) replaces the earlier, which its note keeps."""
        for e in estimates:
            old = next((o for o in self.estimates if o.name == e.name), None)
            if old is None:
                self.estimates.append(e)
                continue
            was = f"{old.value:.4g}" + (" (not identifiable)" if not old.identifiable else "")
            e.note = "; ".join(filter(None, [e.note, f"before the compressible fit {was}"]))
            self.estimates[self.estimates.index(old)] = e

    @property
    def heldout_nrmse(self):
        return float(np.mean([e for _, e in self.heldout])) if self.heldout else float("nan")


class IdentifyError(ValueError):
    """The recording cannot give a model (say what is missing)."""


# --- recordings as data ---------------------------------------------------------------

def segments(events, measured=True):
    """[(name, params, t0, t1)] of a recording's segments (measured ones by default)."""
    out, open_ = [], {}
    for e in events:
        if e["kind"] == "segment_start":
            open_ = {"name": e["segment"], "params": e["params"], "t0": e["t"]}
        elif e["kind"] == "segment_end" and open_ and open_["name"] == e["segment"]:
            if not measured or open_["params"].get("measured", True):
                out.append((open_["name"], open_["params"], open_["t0"], e["t"]))
            open_ = {}
    return out


def _missing(channels, names):
    return [n for n in names if n not in channels or len(channels[n][0]) < 2]


def _at(channels, name, t):
    tc, vc = channels[name]
    return np.interp(t, tc, vc)


def dynamic_segments(channels, events):
    """The sine segments (sine matrix, temperature sweep, imported cycling) as Segments."""
    spans = [(n, p, t0, t1) for n, p, t0, t1 in segments(events) if "freq_hz" in p and p["freq_hz"] > 0.5]
    if not spans and not events:  # an imported recording: blocks of whole cycles
        spans = cycle_blocks(channels)
    tf = channels["force"][0]
    h = float(np.median(np.diff(tf)))
    out = []
    for name, params, t0, t1 in spans:
        start = max(t0 - WARMUP_S, tf[0])
        t = np.arange(start, t1, h)
        if len(t) < 20:
            continue
        f = params.get("freq_hz", 1.0)
        x = smooth(_at(channels, "x", t), h, f)
        v = smooth(_at(channels, "v", t) if "v" in channels else np.gradient(x, t), h, f)
        T = float(_at(channels, "T_body", t).mean()) if "T_body" in channels else T_STD
        P = _at(channels, "P_gas", t) if "P_gas" in channels else None
        seg = Segment(name, params, t, x, v, _at(channels, "force", t), T, P, int(np.searchsorted(t, t0)))
        if P is not None:
            tp, pv = channels["P_gas"]
            k = (tp >= t0) & (tp <= t1)
            seg.tP, seg.P = tp[k], pv[k]
            if not _missing(channels, ("P1", "P2")) and k.sum() > 4:
                seg.chambers = {"t": seg.tP, "x": np.interp(seg.tP, t, x), "v": np.interp(seg.tP, t, v),
                                "P_gas": seg.P, "P1": _at(channels, "P1", seg.tP), "P2": _at(channels, "P2", seg.tP)}
        out.append(seg)
    return out


def smooth(y, h, freq):
    """The motion the model is driven with: zero-phase low-pass at ten times the test
    frequency (at least 20 Hz, at most 0.4 x Nyquist). The transducers' noise would
    otherwise flip the sign of the model's friction and put noise into its damping
    force, which the measured force does not have."""
    fc = min(max(10.0 * freq, 20.0), 0.2 / h)
    if len(y) < 30:
        return y
    b, a = butter(2, fc * 2 * h)
    return filtfilt(b, a, y)


def cycle_blocks(channels, cycles=3):
    """[(name, params, t0, t1)]: a recording without segment events cut into blocks of
    `cycles` whole strokes (displacement rising through its median)."""
    t, x = channels["x"]
    up = np.nonzero((x[:-1] < np.median(x)) & (x[1:] >= np.median(x)))[0]
    # a crossing counts once the motion has gone 1 mm the other way since the last one
    starts = []
    for i in up:
        if not starts or np.ptp(x[starts[-1]:i + 1]) > 2e-3:
            starts.append(i)
    out = []
    for k in range(0, len(starts) - cycles, cycles):
        t0, t1 = float(t[starts[k]]), float(t[starts[k + cycles]])
        out.append((f"cycles {k + 1}-{k + cycles}", {"freq_hz": cycles / (t1 - t0), "cycles": cycles}, t0, t1))
    return out


def nrmse(F_model, F_meas):
    """RMS error over the measured force's peak-to-peak range [-]."""
    return float(np.sqrt(np.mean((F_model - F_meas) ** 2)) / max(np.ptp(F_meas), 1e-9))


# --- the pipeline ---------------------------------------------------------------------

def identify(channels, events, description: Damper, progress=print, dynamic=True) -> Result:
    """A damper model from a recording (see the module docstring). dynamic=False stops
    after the incompressible valve step (what the live view shows while a test runs)."""
    if _missing(channels, ("force", "x")):
        raise IdentifyError(f"recording has no {' or '.join(_missing(channels, ('force', 'x')))} channel: "
                            "nothing can be identified")
    d = canonical(description)
    res = Result(d)
    geo = d.geometry
    T_ambient = T_STD

    # static: friction table and gas charge at the hold temperature
    holds = [s for s in segments(events) if "x_mm" in s[1]]
    T_s = T_ambient
    charge = None
    if not holds:
        res.steps["static"] = "skipped: no static holds in the recording (the description's charge and friction kept)"
    else:
        x, up, down = static_holds(channels, events)
        if len(x) < 3:
            res.steps["static"] = (f"skipped: {len(x)} complete hold positions (need 3; the description's charge "
                                   f"and friction kept)")
        else:
            est = identify_static(x, up, down, geo.A_r)
            if "T_body" in channels:
                T_s = float(np.mean([_at(channels, "T_body", np.array([t1]))[0] for *_, t1 in holds]))
            charge, source = (est["P0"], est["V0"]), "force"
            if "P_gas" in channels:  # the gas force measured directly (eq 3.4), as the thesis checked it
                _, Pu, Pd = static_holds(channels, events, name="P_gas", extrapolate=True)
                gas = identify_static(x, (Pu - P_ATM) * geo.A_r, (Pd - P_ATM) * geo.A_r, geo.A_r)
                charge, source = (gas["P0"], gas["V0"]), "gas pressure"
            xt, Ft = est["friction"]
            d.friction.x_table, d.friction.F_table = [float(v) for v in xt], [float(max(v, 0.0)) for v in Ft]
            res.steps["static"] = (f"done: {len(x)} hold positions at {T_s - 273.15:.1f} C; charge from the "
                                   f"{source}, friction from the force")

    # gas: thermal expansion from the gas pressure at rest, then P0, V0 referred to 20 C
    K_voil = None
    rests = [s for s in segments(events, measured=False) if s[1].get("measured") is False and "target_c" in s[1]
             and "cycles" not in s[1]]
    need = _missing(channels, ("P_gas", "T_body"))
    if charge is None:
        res.steps["gas"] = "skipped: needs the static step's charge"
    elif need:
        res.steps["gas"] = f"skipped: missing channels {', '.join(need)}"
    elif not rests:
        res.steps["gas"] = "skipped: no rests at different temperatures (temperature sweep)"
    else:
        K_voil, k0, se, T_span = _thermal_expansion(channels, rests, charge, T_s, geo.A_r)
        # rests a few kelvin apart leave it undetermined: said so, the fitted value still used
        # (0 instead would give the gas at the test temperature the wrong volume)
        ok = bool(1.96 * se < abs(K_voil))
        res.add(Estimate("K_voil", K_voil, K_voil - 1.96 * se, K_voil + 1.96 * se, "m^3/K", identifiable=ok,
                         note=f"rests over {T_span:.0f} K; intercept {k0 * 1e6:+.2f} cc"
                         + ("" if ok else "; the interval is wider than the value: not determined, the fit's value used")))
        res.steps["gas"] = f"done: rests spanning {T_span:.0f} K"
    if charge is not None:
        P0s, V0s = charge
        Kv = K_voil if K_voil is not None else 0.0
        V0 = V0s.value + Kv * (T_s - T_STD)  # the gas volume at 20 C (eq 4.4, K_voint = 0)
        P0 = P0s.value * V0s.value * d.gas_spring.T0 / (T_s * V0)  # eq 4.5
        r0, r1 = P0 / P0s.value, V0 / V0s.value
        res.add(Estimate("P0", P0, P0s.ci_low * r0, P0s.ci_high * r0, "Pa"),
                Estimate("V0", V0, V0s.ci_low * r1, V0s.ci_high * r1, "m^3"))
        d.gas_spring.P0, d.gas_spring.V0, d.gas_spring.K_voil = P0, V0, Kv
        if K_voil is None:
            res.add(Estimate("K_voil", 0.0, np.nan, np.nan, "m^3/K", identifiable=False,
                             note="needs the gas pressure at rest at several temperatures"))
    res.add(Estimate("K_voint", 0.0, np.nan, np.nan, "m^3", identifiable=False,
                     note="enters only as V0 - K_voint (eq 4.4): folded into V0"))

    # low-speed: breakaway friction at reversals
    slow = [s for s in segments(events) if s[1].get("freq_hz", 1.0) <= 0.5 and "cycles" in s[1]]
    if not slow:
        res.steps["low-speed"] = "skipped: no low-speed segments"
    elif res.steps["static"].startswith("skipped"):
        res.steps["low-speed"] = "skipped: needs the static friction table"
    else:
        rows = []
        for name, p, t0, t1 in slow:
            t, F = channels["force"]
            k = (t >= t0) & (t <= t1)
            x = _at(channels, "x", t[k])
            T = _at(channels, "T_body", t[k]) if "T_body" in channels else np.full(k.sum(), T_ambient)
            rows.append(identify_low_speed.breakaway_ratios(x, F[k], T, d.friction.x_table, d.friction.F_table))
        rows = np.vstack(rows)
        if len(rows) < 2:
            res.steps["low-speed"] = f"skipped: {len(rows)} stroke reversals found (need 2)"
        else:
            fr = identify_low_speed.fit_ratio(rows[:, 1], rows[:, 2])
            d.friction.C_sfT, d.friction.C_ifT = fr["C_sfT"].value, fr["C_ifT"].value
            res.add(fr["C_sfT"], fr["C_ifT"])
            res.steps["low-speed"] = f"done: {len(rows)} stroke reversals"
    if res.steps["static"].startswith("done") and not res.steps["low-speed"].startswith("done"):
        d.friction.C_sfT, d.friction.C_ifT = 0.0, 1.0  # the measured static friction taken as the dynamic

    # valves and the compressible model
    need = _missing(channels, ("T_body",))
    dyn = dynamic_segments(channels, events)
    if len(dyn) < 2:
        res.steps["valves"] = f"skipped: {len(dyn)} sine segments (need 2)"
        res.steps["dynamic"] = "skipped: needs the valves step"
        return res
    res.test = dyn[HELDOUT_EVERY - 1::HELDOUT_EVERY]
    res.train = [s for s in dyn if s not in res.test]
    gamma_known = _gamma_step(d, res)
    progress(f"identify: valves from {len(res.train)} training segments ({len(res.test)} held out)")
    _valves_step(d, res, fit_K=not need)
    if need:
        res.steps["valves"] += "; temperature coefficients skipped: missing channel T_body"
    if not dynamic:
        res.steps["dynamic"] = "not run (live estimate)"
        return res
    progress("identify: compressible fit (valves, bulk modulus" + ("" if gamma_known else ", gamma") + ")")
    _dynamic_step(d, res, fit_K=not need, fit_gamma=not gamma_known)
    res.heldout = [(s.name, nrmse(_simulate(d, s), s.F[s.score_from:])) for s in res.test]
    return res


def _thermal_expansion(channels, rests, charge, T_s, A_r):
    """Eq 4.6 from the gas pressure at rest: the gas volume n R T / P against temperature.
    Returns (K_voil [m^3/K], intercept [m^3], standard error of K_voil, temperature span)."""
    P0s, V0s = charge
    nR = P0s.value * V0s.value / T_s  # from the static charge (isothermal at T_s)
    Ts, dV = [], []
    for name, p, t0, t1 in rests:
        t = channels["P_gas"][0]
        t = t[(t >= t0 + 0.5 * (t1 - t0)) & (t <= t1)]  # the second half: the gas has settled
        if len(t) < 3:
            continue
        x = _at(channels, "x", t)
        T = _at(channels, "T_body", t)
        P = _at(channels, "P_gas", t)
        V = nR * T / P
        Ts.append(T)
        dV.append(V0s.value - x * A_r - V)  # oil grown since T_s: K_voil (T - T_s) + k0
    T, dV = np.concatenate(Ts), np.concatenate(dV)
    A = np.column_stack([T - T_s, np.ones_like(T)])
    coef, *_ = np.linalg.lstsq(A, dV, rcond=None)
    r = dV - A @ coef
    # samples within a rest are correlated: count rests, not samples, for the error
    cov = r @ r / max(len(rests) - 2, 1) * np.linalg.inv(A.T @ A) * len(T) / max(len(rests), 1)
    return float(coef[0]), float(coef[1]), float(np.sqrt(cov[0, 0])), float(np.ptp(T))


def _gamma_step(d: Damper, res: Result) -> bool:
    """gamma from the training segments' gas and chamber pressures (identify_gas); True
    when it was identified (the compressible fit then keeps it)."""
    if any(s.chambers is None for s in res.train):
        res.steps["gamma"] = ("skipped: needs channels P_gas, P1, P2 in every sine segment (gamma comes from "
                              "the compressible fit)")
        return False
    parts = [(c["x"], c["P1"], c["P2"], c["P_gas"], s.T, float(s.x.mean())) for s in res.train
             for c in (s.chambers,)]
    fit = identify_gas.fit_gamma(d.layout, d.geometry, d.gas_spring, parts)
    sd, _ = _covariance(fit)
    gamma = float(fit.x[0])
    d.gas_spring.gamma = gamma
    res.add(Estimate("gas_spring.gamma", gamma, gamma - 1.96 * sd[0], gamma + 1.96 * sd[0], "-",
                     note="from the gas pressure with the chambers' measured pressures"))
    res.steps["gamma"] = f"done: gas pressure of {len(parts)} sine segments with the chambers' stored oil"
    return True


def _gas_force(d: Damper, s: Segment):
    """Gas force [N] over a segment: measured pressure x rod area when recorded (eq 3.4),
    else the polytropic model about the segment's mean position (eq 4.3)."""
    if s.P_gas is not None:
        return (s.P_gas - P_ATM) * d.geometry.A_r
    from .gas_spring import equilibrium_state, force_from_pressure, polytropic_pressure
    g = d.gas_spring
    x_e = float(s.x.mean())
    V_e, P_e = equilibrium_state(x_e, s.T, g.P0, g.V0, g.T0, d.geometry.A_r, g.K_voil, g.K_voint)
    return force_from_pressure(polytropic_pressure(s.x, x_e, V_e, P_e, d.geometry.A_r, g.gamma), d.geometry.A_r)


def _low_acceleration(s: Segment):
    """Samples where the compressibility hardly matters (thesis 4.2.3.1): within half the
    amplitude of mid-stroke (|acceleration| below half its peak)."""
    A = 0.5 * np.ptp(s.x[s.score_from:])
    k = np.zeros(len(s.t), bool)
    k[s.score_from:] = np.abs(s.x[s.score_from:] - s.x[s.score_from:].mean()) <= 0.5 * A
    return k


def _valves_step(d: Damper, res: Result, fit_K=True):
    """Incompressible start: structure and coefficients per path and direction on
    low-acceleration samples of the training segments. Monotube: damping = force - gas -
    friction. Remote reservoir with chamber pressures: the piston's share (P1 - P2) A_w and
    the compression head's (P1 - P_gas) A_r (eq 3.55) separately; without them the
    split is not identifiable and the piston takes all of it."""
    from .friction import friction_force
    f = d.friction
    split = d.layout == "remote_reservoir" and all(s.chambers is not None for s in res.train)
    samples = {}  # (path, sign) -> lists of (u, G, T, group)
    for i, s in enumerate(res.train):
        if split:
            c = s.chambers
            k = np.abs(c["x"] - s.x[s.score_from:].mean()) <= 0.25 * np.ptp(s.x[s.score_from:])
            targets = {"piston": (c["v"], (c["P1"] - c["P2"]) * d.geometry.A_w),
                       "head": (c["v"], (c["P1"] - c["P_gas"]) * d.geometry.A_r)}
        else:
            k = _low_acceleration(s)
            Fd = s.F - _gas_force(d, s) - friction_force(s.x, s.v, s.T, f.x_table, f.F_table, f.C_sfT, f.C_ifT)
            targets = {"piston": (s.v, Fd)}
        for path, (v, Fd) in targets.items():
            for sign in (1, -1):
                kk = k & (v * sign > 0.005) & (Fd * sign > 0)
                samples.setdefault((path, sign), []).append(
                    (np.abs(v[kk]), np.abs(Fd[kk]), np.full(kk.sum(), s.T), np.full(kk.sum(), i)))
    T_ref = d.temperature.T_ref
    speeds = np.array([np.ptp(s.v[s.score_from:]) for s in res.train])
    fold = np.empty(len(speeds), int)
    fold[np.argsort(speeds)] = np.arange(len(speeds)) % 4
    structures, notes, bypass = {}, [], None
    for (path, sign), parts in samples.items():
        tag = "compression" if sign > 0 else "rebound"
        u, G, T, g = (np.concatenate([p[j] for p in parts]) for j in range(4))
        if len(u) < 12:
            raise IdentifyError(f"{path} {tag}: {len(u)} low-acceleration samples (need 12)")
        # thin to at most 300 samples per segment: the fit is by segment anyway
        keep = np.concatenate([np.nonzero(g == k)[0][:: max(1, (g == k).sum() // 300)] for k in np.unique(g)])
        u, G, T, g = u[keep], G[keep], T[keep], g[keep]
        if split and (path, sign) == ("piston", -1):
            found = identify_valves.bypass_split(u, G, g)
            if found is not None:  # the valve is what the seated samples show
                open_, C_open, F_open = found
                bypass = Bypass(C_seatw=C_open, dP_seat_Aw=-BYPASS_SEAT_MARGIN * F_open)
                u, G, T, g = u[~open_], G[~open_], T[~open_], g[~open_]
                notes.append(f"piston bypass: rebound {C_open:.0f} N s/m up to {F_open:.0f} N, then seated")
        K_fit = fit_K and path == "piston" and np.ptp(T) >= 10.0
        # folds interleaved by the segments' peak speeds, so that no fold leaves a whole
        # speed range out (a left-out range would be extrapolated, and judged on that)
        try:
            chosen, scores = identify_valves.select(u, G, T, T_ref, fold[g], fit_K=K_fit)
        except ValueError as e:
            raise IdentifyError(f"{path} {tag}: {e}") from None
        # the selection decides the valves (mid, high); the low branch stays polynomial,
        # which holds the orifice and the linear valve as special cases: at low
        # acceleration compressibility still bends the data enough to fool a choice
        # between them, and the compressible fit sends the absent term towards zero
        structure = chosen.replace("orifice", "polynomial").replace("linear", "polynomial")
        p, K, _ = identify_valves.fit(structure, u, G, T, T_ref, fit_K=K_fit)
        structures[(path, tag)] = (structure, p, K, K_fit)
        best = sorted(scores.items(), key=lambda kv: kv[1])[:3]
        notes.append(f"{path} {tag} {chosen} (held-out " + ", ".join(f"{k} {v:.3f}" for k, v in best) + ")")
        if path == "piston":
            getattr(d.temperature, tag).K_effoil = K
            getattr(d.temperature, tag).C_fd = 0.0
    if bypass is not None:
        _bypass_compression_start(structures)
    paths = {path: ValvePath(identify_valves.direction(structures[(path, "compression")][1], 1.0),
                             identify_valves.direction(structures[(path, "rebound")][1], -1.0))
             for path in {p for p, _ in structures}}
    head = paths.get("head", _quiet_head()) if d.layout == "remote_reservoir" else None
    d.valves = Valves(paths["piston"], head=head, bypass=bypass)
    res.steps["valves"] = "done: " + "; ".join(notes)
    if d.layout == "remote_reservoir" and not split:
        res.steps["valves"] += ("; piston/head split not identifiable without channels P1, P2: the piston "
                                "takes all the damping")
    res.structures = structures


def _bypass_compression_start(structures):
    """With a bypass across the piston, the piston's own compression low branch starts as
    a line through the rebound low branch at 0.1 m/s: in compression the open bypass hides
    its shape (so whatever the valve step made of it says nothing); its size is what the
    seated rebound shows."""
    comp, reb = structures[("piston", "compression")][1], structures[("piston", "rebound")][1]
    low = {k: reb[k] for k in ("a", "b") if k in reb}
    stiff = identify_valves.force(low, np.array([0.1]))[0] / 0.1  # N s/m
    for k in ("a", "b"):
        if k in comp:
            comp[k] = stiff if k == "b" else 1.0  # a log parameter cannot start at 0


def _quiet_head() -> ValvePath:
    """A compression head that passes its flow (A_r v) at almost no pressure: without the
    chamber pressures the split between piston and head is not identifiable, and the whole
    damping force is given to the piston."""
    from .damper import Branch, Direction
    return ValvePath(Direction(Branch(0.0, 1.0, 0.0)), Direction(Branch(0.0, 1.0, 0.0)))


# --- the compressible fit -------------------------------------------------------------

def _simulate(d: Damper, s: Segment, cycles=None, full=False):
    """Model force over a segment's scored part, driven by its measured motion (the
    simulate.Result from the segment's start if full)."""
    end = len(s.t)
    if cycles and s.freq:
        end = min(end, s.score_from + int(cycles / s.freq / (s.t[1] - s.t[0])))
    x = np.clip(s.x[:end], 0.0, d.geometry.stroke)
    r = simulate(d, s.t[:end], x, s.v[:end], T=s.T, compressible=True, x_e=float(s.x.mean()))
    return r if full else r.force[s.score_from:]


def _direction_ranges(Fm, v):
    """Per sample, the measured force's range over its direction's half of the loop [N]:
    compression and rebound each count as much, however unequal. A racing damper's rebound
    is often ten times its compression; scaled by the whole loop's range, the compression
    side would hardly count and its curve would be fitted to a few per cent only (the
    Fox-heavy's was 6.4 % off at 1 m/s, 1.5 % with this scaling)."""
    comp = v > 0
    scale = np.empty(len(Fm))
    for k in (comp, ~comp):
        scale[k] = max(np.ptp(Fm[k]), 1.0) if k.any() else 1.0
    return scale


def _residual(d: Damper, s: Segment, cycles):
    """Force error over the force's range in each direction (`_direction_ranges`), and
    gas-pressure error over the pressure's range where the gas pressure was recorded, each
    weighted so that every segment counts the same."""
    r = _simulate(d, s, cycles, full=True)
    F = r.force[s.score_from:]
    Fm = s.F[s.score_from:s.score_from + len(F)]
    out = [(F - Fm) / _direction_ranges(Fm, s.v[s.score_from:s.score_from + len(F)]) / np.sqrt(2 * len(F))]
    if s.P is not None:
        k = s.tP <= r.t[-1]
        if k.sum() > 4:
            measured = {"P_gas": s.P[k]}
            if s.chambers is not None:  # chamber pressures pin the bulk modulus (eqs 3.31-3.32)
                measured.update(P1=s.chambers["P1"][k], P2=s.chambers["P2"][k])
            for name, Pm in measured.items():
                Ps = np.interp(s.tP[k], r.t, getattr(r, name))
                out.append(P_WEIGHT * (Ps - Pm) / max(np.ptp(Pm), 1.0) / np.sqrt(k.sum()))
    return np.concatenate(out)


def _dynamic_step(d: Damper, res: Result, fit_K=True, fit_gamma=True):
    """Refit valves, temperature coefficients, bulk modulus, gamma and the friction's
    pre-sliding travel to whole training segments with the compressible model. The bulk
    modulus form (constant, or pressure dependent by eq 3.32) is chosen on validation
    segments taken from the training set; a damping temperature coefficient the data
    cannot determine is fixed at 0 and the model refitted without it. fit_gamma=False keeps
    d's gamma (identified from the gas pressure by the gamma step)."""
    keep = set() if fit_gamma else {"gas_spring.gamma"}
    val = res.train[3::4]
    fit_on = [s for s in res.train if s not in val]

    def score(trial):
        return float(np.mean([nrmse(_simulate(trial, s), s.F[s.score_from:]) for s in val]))

    # screening fits: one cycle per segment, validation segments left out
    screened = {}
    for form in ("constant", "pressure"):
        trial = copy.deepcopy(d)
        *_, st = _fit(trial, res.structures, form, fit_K, keep, fit_on, cycles=1, max_runs=SCREEN_RUNS)
        screened[form] = (score(trial), trial, st, ())
    scores = {k: v[0] for k, v in screened.items()}
    # the three-parameter form must earn its place: 2 % lower validation error
    form = "pressure" if scores["pressure"] < 0.98 * scores["constant"] else "constant"
    best = screened[form]
    # a model that misses the validation loops by more than EXTRA_AT gets the chance of a
    # valve the selection did not see: a bypass disc (eqs 4.15-4.16) or a high-speed line,
    # each started from the fit so far
    tried = {}
    if best[0] > EXTRA_AT:
        for extra in _extra_candidates(best[2], best[1].valves.bypass is not None):
            trial = copy.deepcopy(best[1])
            try:
                *_, st = _fit(trial, best[2], form, fit_K, keep, fit_on, (extra,), cycles=1,
                              max_runs=SCREEN_RUNS, warm=True)
            except (ValueError, FloatingPointError, np.linalg.LinAlgError):
                continue
            tried[extra] = score(trial)
            if tried[extra] < 0.8 * best[0] and (not best[3] or tried[extra] < screened["extra"][0]):
                screened["extra"] = (tried[extra], trial, st, (extra,))
        best = screened.get("extra", best)
    start, start_structures, extras = best[1], best[2], best[3]
    fixed, runs = set(keep), 0
    while True:  # the final fit on all training segments, from the screened start
        trial = copy.deepcopy(start)
        if "friction.C_sfT" in fixed:  # back to the low-speed step's, which the screening moved
            trial.friction.C_sfT = d.friction.C_sfT
        names, fit, sd, structures = _fit(trial, start_structures, form, fit_K, fixed, res.train, warm=True)
        runs += fit.nfev
        weak = {n for n, s in zip(names, sd) if _is_slope(n) and not _determined(n, fit.x[names.index(n)], s)}
        if not weak - fixed:
            break
        fixed |= weak
    for field_ in dataclasses.fields(d):
        setattr(d, field_.name, getattr(trial, field_.name))
    res.structures = structures
    _, rho = _covariance(fit)
    for i, n in enumerate(names):
        lo, hi = (_value(n, fit.x[i] + k * 1.96 * sd[i]) for k in (-1, 1))
        ok = _determined(n, fit.x[i], sd[i])
        res.add(Estimate(n, parameter_value(d, n), min(lo, hi), max(lo, hi), UNITS.get(n.split(".")[-1], ""),
                         identifiable=ok, note="" if ok else "the data does not determine it"))
    for n in sorted(fixed - keep):
        res.add(Estimate(n, parameter_value(d, n), np.nan, np.nan, "1/K", identifiable=False,
                         note="the data does not determine it: " + (
                             "the low-speed step's value kept" if n == "friction.C_sfT"
                             else "fixed at 0 (no temperature effect)")))
    res.correlated = [(names[i], names[j], float(rho[i, j])) for i in range(len(names))
                      for j in range(i + 1, len(names)) if abs(rho[i, j]) > 0.95]
    res.steps["dynamic"] = (f"done: bulk modulus {form} (validation NRMSE constant {scores['constant']:.4f}, "
                            f"pressure-dependent {scores['pressure']:.4f})"
                            + "".join(f"; with {e}: {v:.4f}" for e, v in tried.items())
                            + (f"; added {extras[0]}" if extras else "") + f", {runs} model runs")


def _extra_candidates(structures, has_bypass):
    out = [] if has_bypass else ["bypass"]
    for tag in ("compression", "rebound"):
        structure = structures[("piston", tag)][0]
        if "mid" in structure and "high" not in structure:
            out.append(f"high {tag}")
    return out


UNITS = {"C_seatw": "N s/m", "dP_seat_Aw": "N", "C_ifT": "-", "C_sfT": "1/K", "a": "N s^2/m^2", "b": "N s/m", "m": "N s/m", "c": "N", "m2": "N s/m", "c2": "N", "K_effoil": "1/K",
         "gamma": "-", "x_stick": "m", "beta_inv": "Pa", "C_ibeta": "Pa", "C_sbeta": "-", "beta_min_inv": "Pa"}


def _is_slope(name):
    """A temperature coefficient [1/K]: K_effoil (eq 4.17) or the friction's C_sfT (eq 4.1)."""
    return name.endswith("K_effoil") or name.endswith("C_sfT")


def _is_log(name):
    """Positive quantities are fitted as logs (a step of 1e-3 is 0.1 %); temperature
    coefficients in units of 1e-3 /K, gamma as it is."""
    return not (_is_slope(name) or name.endswith("gamma") or name.endswith("dP_seat_Aw"))


def _value(name, z):
    if _is_log(name):
        with np.errstate(over="ignore"):  # the bound of an interval that has none
            return float(np.exp(z))
    return float(z) * (1e-3 if _is_slope(name) else 1.0)


def _z(name, value):
    if _is_log(name):
        with np.errstate(divide="ignore"):
            return float(np.log(value))
    return float(value) * (1e3 if _is_slope(name) else 1.0)


def _determined(name, z, sd):
    """Identifiable: an interval narrower than a factor e (logs) or than the value."""
    return bool(np.isfinite(sd) and 1.96 * sd < (1.0 if _is_log(name) else abs(z)))


def _fit(d: Damper, structures, form: str, fit_K: bool, fixed: set, segs, extras=(), cycles=TRAIN_CYCLES,
         max_runs=MAX_RUNS, warm=False):
    """Least squares of the compressible model on segs (`cycles` of each); d is updated in
    place. extras: "bypass" (a seat valve across the piston, starting as the compression
    side's soft path while the piston's own valve starts as the rebound one), "high
    compression", "high rebound". warm: start from d's own gamma, friction and bulk
    modulus (and keep a bypass it has). Returns (names, scipy result, standard deviations
    of z, structures)."""
    structures = copy.deepcopy(structures)
    for extra in extras:
        if extra.startswith("high"):
            key = ("piston", extra.split()[1])
            structure, p, K, K_fit = structures[key]
            # the line fitted so far is taken as the high-speed one, a steeper mid valve
            # opening earlier put in front of it (crossover at 0.2 c / m)
            p.update(m2=p["m"], c2=p["c"], m=2.5 * p["m"], c=0.7 * p["c"])
            structures[key] = (structure + "+high", p, K, K_fit)
    names = []
    for (path, tag), (structure, p, K, K_fit) in structures.items():
        names += [f"valves.{path}.{tag}.{k}" for k in identify_valves.STRUCTURES[structure]]
        if path != "piston":
            continue
        tc = getattr(d.temperature, tag)
        if fit_K and K_fit and f"temperature.{tag}.K_effoil" not in fixed:
            names.append(f"temperature.{tag}.K_effoil")
            tc.K_effoil = tc.K_effoil if warm else K
        else:
            tc.K_effoil = 0.0 if f"temperature.{tag}.K_effoil" in fixed else tc.K_effoil
    # the friction's level too: the low-speed extrapolation keeps some damping in it
    # (the thesis says so of the heavily damped Fox), the loops' jumps at reversal do not
    names += [n for n in ("gas_spring.gamma", "friction.x_stick", "friction.C_ifT") if n not in fixed]
    # and its temperature slope (eq 4.1) where the segments' temperatures spread: the
    # standard sequence's low-speed cycles all run at the cell's temperature
    T_spread = np.ptp([s.T for s in segs]) if segs else 0.0
    if T_spread >= identify_low_speed.MIN_T_SPREAD_K and "friction.C_sfT" not in fixed:
        names.append("friction.C_sfT")
    if not warm:
        d.friction.x_stick = X_STICK_START
        if "gas_spring.gamma" not in fixed:
            d.gas_spring.gamma = G_START
    if d.valves.bypass is not None:
        names += ["valves.bypass.C_seatw", "valves.bypass.dP_seat_Aw"]
    elif "bypass" in extras:
        # the bypass starts as the soft path the compression showed
        soft = identify_valves.force(structures[("piston", "compression")][1], np.array([0.1]))[0] / 0.1
        _bypass_compression_start(structures)
        d.valves.bypass = Bypass(C_seatw=soft, dP_seat_Aw=-BYPASS_SEAT_START)
        names += ["valves.bypass.C_seatw", "valves.bypass.dP_seat_Aw"]
    c = d.compressibility
    if form == "constant":
        if not warm:
            c.beta_inv, c.C_ibeta, c.C_sbeta, c.beta_min_inv = BETA_START, None, None, None
        names.append("compressibility.beta_inv")
    else:
        if not warm:
            c.beta_inv, c.C_ibeta, c.C_sbeta, c.beta_min_inv = None, 0.5 * BETA_START, 50.0, 3 * BETA_START
        names += ["compressibility.C_ibeta", "compressibility.C_sbeta", "compressibility.beta_min_inv"]

    def apply_structures():
        for (path, tag), (_, p, _, _) in structures.items():
            setattr(getattr(d.valves, path), tag, identify_valves.direction(p, 1.0 if tag == "compression" else -1.0))

    def apply(z):
        for n, zi in zip(names, z):
            set_parameter(d, structures, n, _value(n, zi))
        apply_structures()
        d.gas_spring.gamma = float(np.clip(d.gas_spring.gamma, 1.0, 1.67))

    def start(n):
        parts = n.split(".")
        if parts[0] == "valves" and parts[1] != "bypass":
            return structures[(parts[1], parts[2])][1][parts[3]]
        return parameter_value(d, n)

    z0 = np.array([_z(n, start(n)) for n in names])
    z0 = np.nan_to_num(z0, nan=0.0, neginf=-25.0, posinf=25.0)  # a coefficient driven to zero
    size = []

    def resid(z):
        apply(z)
        try:
            out = np.concatenate([_residual(d, s, cycles) for s in segs])
        except DamperError:  # a trial parameter set outside the model's range
            return np.full(size[0], 1.0)
        # a high-speed line must stay one the model accepts (it crosses the mid line at a
        # positive speed): the fit has driven it to the wrong side when the data let it
        weight = 10.0 * np.sqrt(len(out))
        out = np.concatenate([out, *(identify_valves.crossover_penalty(p, weight) for _, p, _, _ in structures.values())])
        size[:] = [len(out)]
        return out

    fit = least_squares(resid, z0, method="trf", x_scale=1.0, diff_step=1e-3, max_nfev=max_runs)
    apply(fit.x)
    for _, p, _, _ in structures.values():
        identify_valves.make_valid(p)
    apply_structures()
    sd, _ = _covariance(fit)
    return names, fit, sd, structures


def set_parameter(d: Damper, structures, name: str, value: float):
    """Inverse of `parameter_value`; a valve coefficient goes into its structure's
    magnitudes (structures: (path, direction) -> (structure, magnitudes, ...)), which the
    caller turns into the damper's valves."""
    parts = name.split(".")
    if parts[0] == "valves" and parts[1] == "bypass":
        setattr(d.valves.bypass, parts[2], value)
    elif parts[0] == "valves":
        structures[(parts[1], parts[2])][1][parts[3]] = value
    else:
        obj = d
        for p in parts[:-1]:
            obj = getattr(obj, p)
        setattr(obj, parts[-1], value)


def parameter_value(d: Damper, name: str) -> float:
    """A parameter by its dotted name; valve coefficients by magnitude (a, b, m, c, m2, c2)."""
    parts = name.split(".")
    if parts[0] == "valves" and parts[1] == "bypass":
        return float(getattr(d.valves.bypass, parts[2])) if d.valves.bypass is not None else np.nan
    if parts[0] == "valves":
        _, path, tag, k = parts
        sign = 1.0 if tag == "compression" else -1.0
        return identify_valves.magnitudes(getattr(getattr(d.valves, path), tag), sign).get(k, np.nan)
    obj = d
    for p in parts:
        obj = getattr(obj, p)
    return float(obj) if obj is not None else np.nan


def _covariance(fit):
    """(standard deviations, correlation matrix) of the fitted z from the Jacobian: the
    residual variance per effective independent sample (neighbouring samples' errors are
    correlated; one independent error per sign change of the residual). A parameter
    without influence on the fit gets an infinite deviation."""
    J, r = fit.jac, fit.fun
    n, p = J.shape
    n_eff = max(int(np.sum(np.diff(np.sign(r)) != 0)), p + 1)
    norms = np.linalg.norm(J, axis=0)
    live = norms > 1e-6 * max(norms.max(), 1e-300)
    sd = np.full(p, np.inf)
    rho = np.zeros((p, p))
    if live.any():
        Jl = J[:, live]
        # sigma^2 (J^T J)^-1 with the residual variance counted per independent error
        cov = (r @ r) / max(n_eff - p, 1) * np.linalg.pinv(Jl.T @ Jl)
        var = np.diag(cov)
        # pinv gives a direction the data does not see no variance at all: not "exact"
        sdl = np.where(var > 0, np.sqrt(np.abs(var)), np.inf)
        sd[live] = sdl
        with np.errstate(invalid="ignore", divide="ignore"):
            rho[np.ix_(live, live)] = np.clip(np.nan_to_num(cov / np.outer(sdl, sdl)), -1.0, 1.0)
    return sd, rho


# --- canonical form and comparison with a known damper ---------------------------------

def canonical(d: Damper) -> Damper:
    """The equivalent damper with K_voint = 0 and C_fd = 0 (module docstring)."""
    d = copy.deepcopy(d)
    g = d.gas_spring
    V0 = g.V0 - g.K_voint
    g.P0, g.V0, g.K_voint = g.P0 * g.V0 / V0, V0, 0.0
    for tag in ("compression", "rebound"):
        tc = getattr(d.temperature, tag)
        s = 1.0 + tc.C_fd
        tc.K_effoil, tc.C_fd = tc.K_effoil / s, 0.0
        for path in (d.valves.piston, d.valves.head):
            if path is None:
                continue
            dr = getattr(path, tag)
            dr.low.C_orrpw, dr.low.C_linpw, dr.low.C_ipw = (c / s for c in (dr.low.C_orrpw, dr.low.C_linpw,
                                                                             dr.low.C_ipw))
            for line in (dr.mid, dr.high):
                if line is not None:
                    line.C_linw, line.C_ilinw = line.C_linw / s, line.C_ilinw / s
        if d.valves.bypass is not None and tag == "compression":
            # its seating force compares the force itself: unchanged. Not exact in rebound,
            # where the same seat coefficient meets the rebound C_fd (within 1e-4 of the peak)
            d.valves.bypass.C_seatw /= s
    return d
