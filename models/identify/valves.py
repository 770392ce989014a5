"""Valve models from multi-speed data at low acceleration (thesis 4.2.3.1): per direction,
the low-speed restriction (orifice, flow-compensating or polynomial, eqs 4.12-4.14), an
optional mid-speed valve in parallel with its cracking force (eq 3.30) and an optional
high-speed line beyond a crossover (Fox-heavy, 4.2.3.3), with the damping temperature
coefficient of eq 4.17 fitted alongside. The structure is chosen by the error on held-out
segments, not by the training error.

Work is in magnitudes: u = |v| [m/s], G = |F_d| [N]; the rebound sign is put back when a
direction is turned into a damper.Direction.
"""
from __future__ import annotations

import numpy as np
from numba import njit
from scipy.optimize import least_squares

from models.physics import valves
from models.damper import LOW_BRANCH_MIN, Branch, Direction, Line
from workers.threads import each

# structure name -> its parameters: a [N s^2/m^2], b [N s/m] (low branch, eq 4.14),
# m [N s/m], c [N] (mid line slope and cracking force, eq 4.13), m2, c2 (high line)
STRUCTURES = {
    "orifice": ("a",),
    "linear": ("b",),
    "polynomial": ("a", "b"),
    "orifice+mid": ("a", "m", "c"),
    "linear+mid": ("b", "m", "c"),
    "polynomial+mid": ("a", "b", "m", "c"),
    "polynomial+mid+high": ("a", "b", "m", "c", "m2", "c2"),
}


def row(p: dict) -> np.ndarray:
    """A kernel path row (valves.py layout) for one direction, magnitudes, f_T = 1."""
    r = np.zeros((2, valves.NCOL))
    r[:, valves.A], r[:, valves.B] = p.get("a", 0.0), p.get("b", 0.0)
    if "m" in p:
        r[:, valves.MB], r[:, valves.MC] = p["m"], p["c"]
    if "m2" in p:
        r[:, valves.HB], r[:, valves.HC] = p["m2"], p["c2"]
        # parallel lines (a trial point of the fit) never cross
        dm = p["m"] - p["m2"]
        r[:, valves.VX] = (p["c2"] - p["c"]) / dm if dm != 0 else np.inf
    r[:, valves.FT] = 1.0
    return r


@njit(cache=True, nogil=True)
def _forces(u, vp):
    out = np.empty(u.shape[0])
    for i in range(u.shape[0]):
        out[i] = valves.path_force(u[i], vp, 0.0, False)
    return out


GRAD = ("a", "b", "m", "c", "m2", "c2")  # the columns of _forces_grad's derivatives


@njit(cache=True, nogil=True)
def _branch_grad(G, a, b, c):
    """(v, dv/dG, dv/da, dv/db, dv/dc) of one branch at force magnitude G (branch_velocity)."""
    d = G - c
    if d * G <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    S = np.sqrt(b * b + 4.0 * a * d)
    q = b + S
    v = 2.0 * d / q
    dv_dd = 2.0 / q - 2.0 * d * (2.0 * a / S) / q**2 if S > 0.0 else 2.0 / q
    dv_da = -2.0 * d * (2.0 * d / S) / q**2 if S > 0.0 else 0.0
    dv_db = -2.0 * d * (1.0 + b / S) / q**2 if S > 0.0 else 0.0
    return v, dv_dd, dv_da, dv_db, -dv_dd


@njit(cache=True, nogil=True)
def _forces_grad(u, vp):
    """(G, dG/d GRAD) at speeds u of a compression row (magnitudes, f_T = 1): the force by
    the path's root, its derivatives by the implicit function theorem on eq 3.30 read as
    v(G): dG/dθ = -(dv/dθ) / (dv/dG). The high line's switch is taken as it falls."""
    n = u.shape[0]
    G = np.empty(n)
    J = np.zeros((n, 6))
    for i in range(n):
        g = valves.path_force(u[i], vp, 0.0, False)
        G[i] = g
        _, dG, J[i, 0], J[i, 1], _ = _branch_grad(g, vp[0, valves.A], vp[0, valves.B], 0.0)
        if vp[0, valves.MB] > 0.0:
            vm, dm_G, _, J[i, 2], J[i, 3] = _branch_grad(g, 0.0, vp[0, valves.MB], vp[0, valves.MC])
            if vp[0, valves.HB] > 0.0 and abs(vm) > abs(vp[0, valves.VX]):
                _, dm_G, _, J[i, 4], J[i, 5] = _branch_grad(g, 0.0, vp[0, valves.HB], vp[0, valves.HC])
                J[i, 2] = J[i, 3] = 0.0
            dG += dm_G
        # dv/dθ in J's row so far: dG/dθ = -(dv/dθ) / (dv/dG)
        for k in range(6):
            J[i, k] = -J[i, k] / dG if dG > 0.0 else 0.0
    return G, J


def force(p: dict, u, T=None, T_ref=None, K=0.0):
    """Damping force magnitude [N] at speed u [m/s] (eq 3.30) and temperature T [K]
    (eq 4.17 with C_fd = 0: the scale of the coefficients absorbs it)."""
    G = _forces(np.asarray(u, float), row(p))
    if T is None:
        return G
    return G / (1.0 + K * (np.asarray(T, float) - T_ref))


def direction(p: dict, sign: float) -> Direction:
    """damper.Direction from magnitudes; sign -1 for rebound."""
    low = Branch(sign * p.get("a", 0.0), p.get("b", 0.0), 0.0)
    mid = Line(p["m"], sign * p["c"]) if "m" in p else None
    high = Line(p["m2"], sign * p["c2"]) if "m2" in p else None
    return Direction(low, mid, high)


def magnitudes(d: Direction, sign: float) -> dict:
    """Inverse of `direction`, for a damper's own coefficients."""
    p = {"a": sign * d.low.C_orrpw, "b": d.low.C_linpw}
    if d.mid is not None:
        p.update(m=d.mid.C_linw, c=sign * d.mid.C_ilinw)
    if d.high is not None:
        p.update(m2=d.high.C_linw, c2=sign * d.high.C_ilinw)
    return p


CROSSOVER_MARGIN = 0.01  # log units: a high line at least 1 % flatter and 1 % higher at zero speed


def crossover_penalty(p: dict, weight: float) -> np.ndarray:
    """Hinge residuals that keep a high-speed line one damper.check accepts: flatter than
    the mid line (m2 < m) and crossing it at a positive speed (c2 > c). Zero inside, so a
    valid fit is unchanged; weight makes a 1 % violation cost more than the whole fit."""
    if "m2" not in p:
        return np.zeros(0)
    return weight * np.maximum(0.0, [_above(p["m2"], p["m"]) + CROSSOVER_MARGIN,
                                     _above(p["c"], p["c2"]) + CROSSOVER_MARGIN])


def _above(a, b):
    """How far a is above b: log(a / b) where both are positive, else relative to the
    larger (a fit can pass an intercept through zero: no division by it)."""
    if a > 0 and b > 0:
        return float(np.log(a / b))
    return (a - b) / max(abs(a), abs(b), 1e-12)


def make_valid(p: dict) -> dict:
    """p with its high line moved inside the bounds `crossover_penalty` holds it to (what
    a penalised fit can leave outside them is a fraction of the margin)."""
    if "m2" in p:
        # the slopes stay in their declared range (damper.Line): m2 at least its lower end, m above it
        p["m"] = max(p["m"], LOW_BRANCH_MIN * np.exp(CROSSOVER_MARGIN))
        p["m2"] = max(min(p["m2"], p["m"] * np.exp(-CROSSOVER_MARGIN)), LOW_BRANCH_MIN)
        p["c2"] = max(p["c2"], p["c"] * np.exp(CROSSOVER_MARGIN))
    return p


BYPASS_JUMP = 5.0  # force ratio beyond the speed ratio between neighbouring segments


def bypass_split(u, G, groups):
    """A mis-seated bypass (eqs 4.15-4.16) in one direction's samples. Below its seating
    force the open bypass carries the flow at a small force; beyond it the valve alone, so
    between two segments the force jumps far more than the speed rises (Mechformance
    rebound: 36 N at 0.019 m/s, then 1160 N at 0.038 m/s; a valve's force at most doubles
    with the speed, an orifice's). Segments (groups) are ordered by their median force and
    split at the largest jump if it exceeds BYPASS_JUMP times their speed ratio.
    Returns (mask of the open samples, their conductance [N s/m], the largest open force
    [N]) or None."""
    keys = np.unique(groups)
    med = np.array([(np.median(u[groups == k]), np.median(G[groups == k])) for k in keys])
    med = med[np.argsort(med[:, 1])]
    if len(med) < 3 or med[0, 1] <= 0:
        return None
    excess = np.diff(np.log(med[:, 1])) - np.maximum(np.diff(np.log(med[:, 0])), 0.0)
    j = int(np.argmax(excess))
    if excess[j] < np.log(BYPASS_JUMP):
        return None
    open_ = G < np.sqrt(med[j, 1] * med[j + 1, 1])
    C = float(np.sum(G[open_] * u[open_]) / np.sum(u[open_] ** 2))  # a line through the origin
    return open_, C, float(G[open_].max())


def _start(structure, u, G):
    """Starting values from the data: the low branch from the slow third, the mid line
    from the fast half of the speeds, the high line from the fastest sixth."""
    names = STRUCTURES[structure]
    order = np.argsort(u)
    lo = order[: max(len(u) // 3, 3)]
    hi = order[len(u) // 2:]
    a, b = np.polyfit(u[lo], G[lo], 2)[:2] if len(lo) >= 3 else (0.0, 1e3)
    a, b = max(a, 1.0), max(b, 10.0)
    if "m" in names:
        if "m2" not in names:
            m, c = np.polyfit(u[hi], G[hi], 1)
            m, c = max(m, 10.0), float(np.clip(c, 0.05 * G.max(), 0.9 * G.max()))
            return {"a": a, "b": b, "m": m, "c": c}
        # mid line from the middle third of the speeds, high line from the top third
        third = max(len(u) // 3, 3)
        mid, top = order[third:2 * third], order[-third:]
        m, c = np.polyfit(u[mid], G[mid], 1)
        m2, c2 = np.polyfit(u[top], G[top], 1)
        m, c = max(m, 10.0), float(np.clip(c, 0.05 * G.max(), 0.9 * G.max()))
        m2 = float(np.clip(m2, 1.0, 0.7 * m))  # the high line is the flatter one
        return {"a": a, "b": b, "m": m, "c": c, "m2": m2, "c2": max(c2, c * 1.2)}
    if structure == "orifice":
        return {"a": float(np.sum(G * u**2) / np.sum(u**4))}
    if structure == "linear":
        return {"b": float(np.sum(G * u) / np.sum(u**2))}
    return {"a": a, "b": b}


# 1/K: the damping temperature coefficient of eq 4.17 is 0.27e-3 to 4.0e-3 for the thesis's
# dampers (Table 4.10); bounded at five times the largest, as K_MAX tanh(z / K_Z): near
# zero z is K in 1e-3/K. Unbounded, a structure that does not fit slid along a valley
# (K to -600, the coefficients to e^20) for hundreds of evaluations.
K_MAX = 0.02
K_Z = K_MAX * 1e3


def fit(structure, u, G, T, T_ref, fit_K=True, K0=5e-4, weights=None, done=None):
    """(params, K, result) for one direction: least squares in log-coefficients, relative
    residuals (the force spans two decades). A structure that contains smaller ones also
    starts from their fits (`done` keeps them for one data set), so it never ends worse
    than a structure it contains for want of a start: the least-squares surface has
    valleys where, say, the polynomial settles as an orifice plus a wrong mid line."""
    done = {} if done is None else done
    if structure in done:
        return done[structure]
    names = STRUCTURES[structure]
    own = _start(structure, u, G)
    starts = [({k: own[k] for k in names}, K0)]
    for sub, sub_names in STRUCTURES.items():
        bigger = [s for s, n in STRUCTURES.items() if set(sub_names) < set(n) < set(names)]
        if set(sub_names) < set(names) and not bigger:  # the largest structures inside this one
            p_sub, K_sub, _ = fit(sub, u, G, T, T_ref, fit_K, K0, weights, done)
            # a low-branch term it lacked starts small; a line it lacked starts where the data puts it
            starts.append(({k: p_sub.get(k, 0.1 * own[k] if k in "ab" else own[k]) for k in names}, K_sub))
    w = np.ones_like(u) if weights is None else weights
    scale = np.maximum(G, 0.05 * G.max())

    def unpack(z):
        # clipped: a coefficient the data drives to zero or infinity must stay a number
        p = dict(zip(names, np.exp(np.clip(z[: len(names)], -7.0, 23.0))))
        return p, (K_MAX * np.tanh(z[len(names)] / K_Z) if fit_K else 0.0)

    weight = 10.0 * np.sqrt(len(u))

    def resid(z):
        p, K = unpack(z)
        return np.concatenate([w * (force(p, u, T, T_ref, K) - G) / scale, crossover_penalty(p, weight)])

    def jac(z):
        """Analytic in the force (one root per sample instead of one per parameter and
        sample), by differences in the penalty, which costs no force."""
        p, K = unpack(z)
        Gm, dG = _forces_grad(np.asarray(u, float), row(p))
        f = 1.0 / (1.0 + K * (T - T_ref))
        wrow = (w * f / scale)[:, None]
        cols = [dG[:, GRAD.index(k)] * (p[k] if -7.0 < z[j] < 23.0 else 0.0) for j, k in enumerate(names)]
        if fit_K:
            cols.append(-Gm * (T - T_ref) * f * (K_MAX / K_Z) * (1.0 - np.tanh(z[len(names)] / K_Z) ** 2))
        out = np.column_stack(cols) * wrow
        pen = crossover_penalty(p, weight)
        if len(pen):
            h = 1e-7
            dpen = [(crossover_penalty(unpack(z + h * e)[0], weight) - pen) / h for e in np.eye(len(z))]
            out = np.vstack([out, np.column_stack(dpen)])
        return out

    best = None
    for p0, K_start in starts:
        z0 = np.log(np.maximum([p0[k] for k in names], 1e-300))
        if fit_K:
            z0 = np.append(z0, K_Z * np.arctanh(np.clip(K_start / K_MAX, -0.999, 0.999)))
        res = least_squares(resid, z0, jac=jac, method="lm" if len(u) > len(z0) else "trf", max_nfev=400 * len(z0))
        if best is None or res.cost < best.cost:
            best = res
    p, K = unpack(best.x)
    make_valid(p)
    done[structure] = (p, K, best)
    return done[structure]


def select(u, G, T, T_ref, groups, fit_K=True, structures=None):
    """The structure with the lowest held-out error: each group (a test segment) left out
    in turn. Returns (structure, {structure: held-out rms relative error})."""
    structures = structures or list(STRUCTURES)
    groups = np.asarray(groups)
    keys = np.unique(groups)
    tried = [s for s in structures if len(u) >= 3 * len(STRUCTURES[s]) + 2]

    def left_out(k):
        """{structure: relative errors on group k} from fits without it (the fits of one
        group share their smaller structures' results as starts)."""
        train, test = groups != k, groups == k
        done, out = {}, {}
        for s in tried:
            if train.sum() >= len(STRUCTURES[s]) + 2:
                p, K, _ = fit(s, u[train], G[train], T[train], T_ref, fit_K, done=done)
                out[s] = (force(p, u[test], T[test], T_ref, K) - G[test]) / np.maximum(G[test], 0.05 * G.max())
        return out

    per_group = each(left_out, [(k,) for k in keys])  # the groups are independent: on the cores
    scores = {}
    for s in tried:
        errs = [g[s] for g in per_group if s in g]
        if errs:
            scores[s] = float(np.sqrt(np.mean(np.concatenate(errs) ** 2)))
    if not scores:
        raise ValueError(f"{len(u)} samples from {len(keys)} group(s) of segments: a valve structure is "
                         f"chosen on segments left out, and needs samples in at least 2 groups")
    best = min(scores, key=scores.get)
    # prefer the simplest structure whose held-out error is within 2 % of the best's
    for s in structures:
        if s in scores and scores[s] <= scores[best] * 1.02 and len(STRUCTURES[s]) < len(STRUCTURES[best]):
            best = s
    return best, scores
