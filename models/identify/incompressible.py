"""The valves step: valve structure and coefficients per path and direction at low
acceleration, where the compressibility hardly matters (thesis 4.2.3.1, eqs 4.12-4.17)."""
from __future__ import annotations

import numpy as np

from models.damper import Bypass, Damper, ValvePath, Valves
from models.identify import valves as identify_valves
from models.identify.result import IdentifyError, Identified
from models.identify.segments import Resampled
from models.physics.gas_spring import P_ATM

BYPASS_SEAT_MARGIN = 1.25  # ... one the valve step found: this times the largest open force


def _gas_force(d: Damper, s: Resampled):
    """Gas force [N] over a segment: measured pressure x rod area when recorded (eq 3.4),
    else the polytropic model about the segment's mean position (eq 4.3)."""
    if s.P_gas is not None:
        return (s.P_gas - P_ATM) * d.geometry.A_r
    from models.physics.gas_spring import equilibrium_state, force_from_pressure, polytropic_pressure
    g = d.gas_spring
    x_e = float(s.x.mean())
    V_e, P_e = equilibrium_state(x_e, s.T, g.P0, g.V0, g.T0, d.geometry.A_r, g.K_voil, g.K_voint)
    return force_from_pressure(polytropic_pressure(s.x, x_e, V_e, P_e, d.geometry.A_r, g.gamma), d.geometry.A_r)


GAS_MISFIT = 0.1  # the description's gas force this share of the force range off the data's: refitted


def _at_reversals(s: Resampled):
    """Indices of a segment's velocity reversals (scored part): there the damping is nil and
    the force is the gas force give or take friction, which the two ends cancel."""
    v = s.v[s.score_from:]
    return s.score_from + np.nonzero(np.diff(np.sign(v)) != 0)[0]


def charge_from_reversals(d: Damper, segments) -> str:
    """With no static holds and no gas pressure, the gas charge P0 [Pa] set so that the gas
    force at the velocity reversals (eq 4.3) is the force measured there, when the
    description's is more than GAS_MISFIT of the force range off: a description gives the
    layout and geometry, its charge is another damper's. Returns what was done, or ""."""
    from scipy.optimize import brentq
    rev = [(s, _at_reversals(s)) for s in segments if s.P_gas is None]
    rev = [(s, k) for s, k in rev if len(k) >= 4]
    if not rev:
        return ""
    measured = float(np.mean([s.F[k].mean() for s, k in rev]))
    span = float(np.mean([np.ptp(np.percentile(s.F[s.score_from:], [1, 99])) for s, _ in rev]))

    def gas_at(P0):
        d.gas_spring.P0 = P0
        return float(np.mean([_gas_force(d, s)[k].mean() for s, k in rev]))
    P0 = d.gas_spring.P0
    described = gas_at(P0)
    if abs(described - measured) <= GAS_MISFIT * span:
        return ""
    lo, hi = 1.001 * P_ATM, 1000 * P_ATM
    if not gas_at(lo) < measured < gas_at(hi):
        d.gas_spring.P0 = P0
        return ""
    d.gas_spring.P0 = brentq(lambda p: gas_at(p) - measured, lo, hi, xtol=1.0)
    return (f"then the gas charge refitted from the force at the velocity reversals: "
            f"{described:.0f} N described, {measured:.0f} N measured; P0 {P0 / 1e5:.2f} -> "
            f"{d.gas_spring.P0 / 1e5:.2f} bar")


def _low_acceleration(s: Resampled):
    """Samples where the compressibility hardly matters (thesis 4.2.3.1): within half the
    amplitude of mid-stroke (|acceleration| below half its peak)."""
    A = 0.5 * np.ptp(s.x[s.score_from:])
    k = np.zeros(len(s.t), bool)
    k[s.score_from:] = np.abs(s.x[s.score_from:] - s.x[s.score_from:].mean()) <= 0.5 * A
    return k


def valves_step(d: Damper, res: Identified, fit_K=True):
    """Incompressible start: structure and coefficients per path and direction on
    low-acceleration samples of the training segments. Monotube: damping = force - gas -
    friction. Remote reservoir with chamber pressures: the piston's share (P1 - P2) A_w and
    the compression head's (P1 - P_gas) A_r (eq 3.55) separately; without them the
    split is not identifiable and the piston takes all of it."""
    from models.physics.friction import friction_force
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
            raise IdentifyError(f"{path} {tag}: {len(u)} low-acceleration samples (need 12)" + (
                f": the force less the description's gas force ({np.mean([_gas_force(d, s).mean() for s in res.train]):.0f} N) "
                f"and friction never opposes the motion; the data's static force is about "
                f"{np.mean([np.median(s.F) for s in res.train]):.0f} N: the description's gas charge does not fit "
                f"this damper (record static holds, or describe it with --damper)" if not split else ""))
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
        bypass_compression_start(structures)
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


def bypass_compression_start(structures):
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
    from models.damper import Branch, Direction
    return ValvePath(Direction(Branch(0.0, 1.0, 0.0)), Direction(Branch(0.0, 1.0, 0.0)))
