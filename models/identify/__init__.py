"""The identification pipeline of thesis chapter 4: a recording in, a damper model out.

Steps, each run when its data and channels are there (a step that cannot run says why),
by segment kind (records/data.py); the module of each:
  static      friction look-up (eq 3.1) and the gas charge (eq 3.7)         static.py
  gas         oil thermal expansion K_voil from the gas pressure at rest (eq 4.6)   here
  low-speed   dynamic breakaway friction and its temperature coefficients   low_speed.py
  gamma       the polytropic exponent from the gas pressure in the sine segments, with
              the oil the chambers store taken from their measured pressures   gas.py
  valves      valve structure and coefficients at low acceleration with the damping
              temperature coefficient (eqs 4.12-4.14, 3.30, 4.17)   valves.py, incompressible.py
  dynamic     the compressible model (eqs 3.31-3.56) refitted to whole training segments:
              valves, temperature coefficients, bulk modulus (constant or pressure
              dependent, chosen on held-out segments) and, when the gamma step could not
              run, gamma (eq 4.3), using the gas pressure channel when recorded   dynamic.py

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

import numpy as np

from models.damper import Damper
from models.identify import gas as identify_gas, low_speed as identify_low_speed
from models.identify.dynamic import dynamic_step, simulate_segment
from models.identify.incompressible import charge_from_reversals, valves_step
from models.identify.parameters import canonical, parameter_value, set_parameter
from models.identify.result import IdentifyError, Identified
from models.identify.segments import dynamic_segments
from models.identify.static import Estimate, identify_static, static_holds
from models.damper import T_STD
from models.physics.gas_spring import P_ATM
from models.statistics import covariance, nrmse
from records.data import at, missing, segments, sign_problem

__all__ = ["IdentifyError", "Result", "canonical", "dynamic_segments", "identify", "parameter_value",
           "set_parameter", "simulate_segment"]

HELDOUT_EVERY = 3  # every third dynamic segment is held out of all fitting


def identify(channels, events, description: Damper, progress=print, dynamic=True, smoothing=None) -> Identified:
    """A damper model from a recording (see the module docstring). dynamic=False stops
    after the incompressible valve step (what the live view shows while a test runs).
    smoothing: the source's moving average (records/source_filter.py), which the compressible
    fit's and the held-out segments' simulated force go through."""
    if missing(channels, ("force", "x")):
        raise IdentifyError(f"recording has no {' or '.join(missing(channels, ('force', 'x')))} channel: "
                            "nothing can be identified")
    sign = sign_problem(channels)
    if sign:
        raise IdentifyError(sign)
    d = canonical(description)
    res = Identified(d)
    charge, T_s = _static_step(channels, events, d, res)
    _gas_step(channels, events, d, res, charge, T_s)
    _low_speed_step(channels, events, d, res)

    # valves and the compressible model
    need = missing(channels, ("T_body",))
    left_out = {}
    dyn = dynamic_segments(channels, events, left_out, smoothing)
    if left_out:
        res.steps["data"] = (f"{len(left_out)} sine segment(s) left out: "
                             + "; ".join(f"{name}: {why}" for name, why in left_out.items()))
    if len(dyn) < 2:
        res.steps["valves"] = f"skipped: {len(dyn)} sine segments (need 2)"
        res.steps["dynamic"] = "skipped: needs the valves step"
        return res
    res.test = dyn[HELDOUT_EVERY - 1::HELDOUT_EVERY]
    res.train = [s for s in dyn if s not in res.test]
    if charge is None:
        refit = charge_from_reversals(d, res.train)
        if refit:
            res.steps["static"] += f"; {refit}"
    gamma_known = _gamma_step(d, res)
    progress(f"identify: valves from {len(res.train)} training segments ({len(res.test)} held out)")
    valves_step(d, res, fit_K=not need)
    if need:
        res.steps["valves"] += "; temperature coefficients skipped: missing channel T_body"
    if not dynamic:
        res.steps["dynamic"] = "not run (live estimate)"
        return res
    progress("identify: compressible fit (valves, bulk modulus" + ("" if gamma_known else ", gamma") + ")")
    dynamic_step(d, res, fit_K=not need, fit_gamma=not gamma_known)
    res.heldout = [(s.name, nrmse(simulate_segment(d, s), s.F[s.score_from:])) for s in res.test]
    return res


def _static_step(channels, events, d: Damper, res: Identified):
    """Friction table and gas charge at the hold temperature (eqs 3.1, 3.7); returns
    (charge (P0, V0 Estimates) or None, hold temperature [K])."""
    geo = d.geometry
    holds = segments(events, kinds=("hold",))
    T_s = T_STD
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
                T_s = float(np.mean([at(channels, "T_body", np.array([t1]))[0] for *_, t1 in holds]))
            charge, source = (est["P0"], est["V0"]), "force"
            if "P_gas" in channels:  # the gas force measured directly (eq 3.4), as the thesis checked it
                _, Pu, Pd = static_holds(channels, events, name="P_gas", extrapolate=True)
                gas = identify_static(x, (Pu - P_ATM) * geo.A_r, (Pd - P_ATM) * geo.A_r, geo.A_r)
                charge, source = (gas["P0"], gas["V0"]), "gas pressure"
            xt, Ft = est["friction"]
            d.friction.x_table, d.friction.F_table = [float(v) for v in xt], [float(max(v, 0.0)) for v in Ft]
            res.steps["static"] = (f"done: {len(x)} hold positions at {T_s - 273.15:.1f} C; charge from the "
                                   f"{source}, friction from the force")
    return charge, T_s


def _gas_step(channels, events, d: Damper, res: Identified, charge, T_s):
    """Oil thermal expansion from the gas pressure at rest (eq 4.6), then P0, V0 referred
    to 20 C (eqs 4.4-4.5)."""
    geo = d.geometry
    K_voil = None
    rests = segments(events, measured=False, kinds=("rest",))
    need = missing(channels, ("P_gas", "T_body"))
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


def _low_speed_step(channels, events, d: Damper, res: Identified):
    """Breakaway friction at the low-speed test's stroke reversals and its temperature
    coefficients (eq 4.1)."""
    slow = segments(events, kinds=("low-speed",))
    if not slow:
        res.steps["low-speed"] = "skipped: no low-speed segments"
    elif res.steps["static"].startswith("skipped"):
        res.steps["low-speed"] = "skipped: needs the static friction table"
    else:
        rows = []
        for _name, _p, t0, t1 in slow:
            t, F = channels["force"]
            k = (t >= t0) & (t <= t1)
            x = at(channels, "x", t[k])
            T = at(channels, "T_body", t[k]) if "T_body" in channels else np.full(k.sum(), T_STD)
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


def _thermal_expansion(channels, rests, charge, T_s, A_r):
    """Eq 4.6 from the gas pressure at rest: the gas volume n R T / P against temperature.
    Returns (K_voil [m^3/K], intercept [m^3], standard error of K_voil, temperature span)."""
    P0s, V0s = charge
    nR = P0s.value * V0s.value / T_s  # from the static charge (isothermal at T_s)
    Ts, dV = [], []
    for _name, _p, t0, t1 in rests:
        t = channels["P_gas"][0]
        t = t[(t >= t0 + 0.5 * (t1 - t0)) & (t <= t1)]  # the second half: the gas has settled
        if len(t) < 3:
            continue
        x = at(channels, "x", t)
        T = at(channels, "T_body", t)
        P = at(channels, "P_gas", t)
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


def _gamma_step(d: Damper, res: Identified) -> bool:
    """gamma from the training segments' gas and chamber pressures (identify_gas); True
    when it was identified (the compressible fit then keeps it)."""
    if any(s.chambers is None for s in res.train):
        res.steps["gamma"] = ("skipped: needs channels P_gas, P1, P2 in every sine segment (gamma comes from "
                              "the compressible fit)")
        return False
    parts = [(c["x"], c["P1"], c["P2"], c["P_gas"], s.T, float(s.x.mean())) for s in res.train
             for c in (s.chambers,)]
    fit = identify_gas.fit_gamma(d.layout, d.geometry, d.gas_spring, parts)
    sd, _ = covariance(fit.jac, fit.fun)
    gamma = float(fit.x[0])
    d.gas_spring.gamma = gamma
    res.add(Estimate("gas_spring.gamma", gamma, gamma - 1.96 * sd[0], gamma + 1.96 * sd[0], "-",
                     note="from the gas pressure with the chambers' measured pressures"))
    res.steps["gamma"] = f"done: gas pressure of {len(parts)} sine segments with the chambers' stored oil"
    return True
