"""The diagnosis's compiled kernels (numba): state and filter loops over a recording's
samples that numpy cannot vectorise. Arrays in, arrays out; SI units."""
from __future__ import annotations

import functools
import math
import threading

import numpy as np
from numba import njit


def recent(fn, size=8):
    """fn remembering its last `size` results. A fit's finite-difference Jacobian moves one
    parameter at a time, so most parts of a model are asked again with the inputs they
    just had. Arrays are matched by identity (an entry keeps its arrays alive, so their
    ids are not reused while it is remembered, and nothing here changes an array in
    place), other arguments by value; results are read-only. One memory per thread (a
    cluster worker may run diagnoses on several)."""
    local = threading.local()

    @functools.wraps(fn)
    def wrapped(*args):
        cache = local.__dict__.setdefault("cache", {})
        key = tuple(id(a) if isinstance(a, np.ndarray) else a for a in args)
        hit = cache.get(key)
        if hit is not None:
            return hit[1]
        out = fn(*args)
        if isinstance(out, np.ndarray):
            out.flags.writeable = False
        cache[key] = (args, out)
        if len(cache) > size:
            del cache[next(iter(cache))]
        return out
    return wrapped


@njit(cache=True, nogil=True)
def lag(F, tau, h):
    """F through a first-order lag of time constant tau[i] [s] (implicit Euler)."""
    out = np.empty_like(F)
    y = F[0]
    for i in range(len(F)):
        y += h[i] / (tau[i] + h[i]) * (F[i] - y)
        out[i] = y
    return out


@njit(cache=True, nogil=True)
def delayed(Y, t, tau):
    """Each row of Y at t - tau (t increasing [s], tau [s]): np.interp(t - tau, t, y)
    operation for operation, so the same numbers to the last bit, with a walk to each
    interval instead of its binary search, walked once for all the rows (a sensor delay's
    fit shifts three channels at every evaluation)."""
    k, n = Y.shape
    out = np.empty((k, n))
    j = 0
    for i in range(n):
        x = t[i] - tau
        if np.isnan(x):
            out[:, i] = x
        elif x < t[0]:
            out[:, i] = Y[:, 0]
        elif x > t[n - 1]:
            out[:, i] = Y[:, n - 1]
        else:
            while j < n - 1 and t[j + 1] <= x:
                j += 1
            while j > 0 and t[j] > x:
                j -= 1
            if j == n - 1 or t[j] == x:
                out[:, i] = Y[:, j]
                continue
            for q in range(k):
                y0, y1 = Y[q, j], Y[q, j + 1]
                slope = (y1 - y0) / (t[j + 1] - t[j])
                r = slope * (x - t[j]) + y0
                if np.isnan(r):  # numpy's retry from the interval's other end
                    r = slope * (x - t[j + 1]) + y1
                    if np.isnan(r) and y0 == y1:
                        r = y0
                out[q, i] = r
    return out


@njit(cache=True, nogil=True)
def bspline_basis(x, t, k, n):
    """(len(x), n) B-spline basis of degree k on knots t at x (inside [t[k], t[n]]): de
    Boor's recursion as scipy's BSpline.design_matrix runs it, operation for operation, so
    the same numbers to the last bit, without its sparse matrix (a third of the time)."""
    B = np.zeros((len(x), n))
    h = np.empty(k + 1)
    hh = np.empty(k + 1)
    for i in range(len(x)):
        xi = x[i]
        # the knot interval [t[ell], t[ell + 1]) holding xi; the last one closed
        ell = min(max(np.searchsorted(t, xi, side="right") - 1, k), n - 1)
        h[0] = 1.0
        for j in range(1, k + 1):
            for m in range(j):
                hh[m] = h[m]
            h[0] = 0.0
            for m in range(1, j + 1):
                xb, xa = t[ell + m], t[ell + m - j]
                if xb == xa:
                    h[m] = 0.0
                    continue
                w = hh[m - 1] / (xb - xa)
                h[m - 1] += w * (xb - xi)
                h[m] = w * (xi - xa)
        for m in range(k + 1):
            B[i, ell - k + m] = h[m]
    return B


@njit(cache=True, nogil=True, inline="always")
def _trapezoid(f0, f1, t0, t1, a, b):
    """The integral over [a, b] of a force linear from f0 at t0 to f1 at t1."""
    s = (f1 - f0) / (t1 - t0)
    return (b - a) * (f0 + s * (0.5 * (a + b) - t0))


@njit(cache=True, nogil=True)
def integral(F, t, lo, hi):
    """Integral over [lo, hi] of F linear between samples t (lo >= t[0])."""
    j = max(np.searchsorted(t, lo) - 1, 0)
    out = 0.0
    while j < len(t) - 1 and t[j] < hi:
        a, b = max(t[j], lo), min(t[j + 1], hi)
        if b > a:
            out += _trapezoid(F[j], F[j + 1], t[j], t[j + 1], a, b)
        j += 1
    return out


@njit(cache=True, nogil=True)
def _integral_at(F, at, t, j, lo, hi):
    """integral() of a force known only at some samples (F[at[i]] is sample i's), from the
    interval j that holds lo (max(searchsorted(t, lo) - 1, 0), found once for many rows)."""
    out = 0.0
    while j < len(t) - 1 and t[j] < hi:
        a, b = max(t[j], lo), min(t[j + 1], hi)
        if b > a:
            out += _trapezoid(F[at[j]], F[at[j + 1]], t[j], t[j + 1], a, b)
        j += 1
    return out


@njit(cache=True, nogil=True)
def _gap_closes(F, S, t, c, i):
    """Where a crossing of the clearance c [m] begun between samples i - 1 and i ends:
    (t_z, side, t_e, j, closed), t_z where F [N] changed sign, side its new sign, t_e
    where the gap closes (closed: the integral of |F| / S from t_z reached c, within
    interval j) or F turned back (between j - 1 and j; t_e the last time when it never
    did). S [N s/m] stepwise, its value at each interval's end."""
    n = len(F)
    h = t[i] - t[i - 1]
    tz = t[i - 1] + h * F[i - 1] / (F[i - 1] - F[i])
    side = 1.0 if F[i] > 0 else -1.0
    s, t0, f0 = 0.0, tz, 0.0
    j = i
    while j < n:
        f1 = side * F[j]
        if f1 < 0.0:  # back to the old side before the gap closed: contact resumes there
            return tz, side, t[j - 1] + (t[j] - t[j - 1]) * (side * F[j - 1]) / (side * F[j - 1] - f1), j, False
        dt = t[j] - t0
        k = max(S[j], 1e-9)
        ds = 0.5 * (f0 + f1) * dt / k
        if s + ds >= c and dt > 0.0:
            # |F| linear over the interval: s(tau) = (f0 tau + b tau^2 / 2) / k, b = (f1 - f0) / dt
            b = (f1 - f0) / dt
            need = (c - s) * k
            if abs(b) * need < 1e-12 * f0 * f0:
                tau = need / max(f0, 1e-30)
            else:
                tau = (-f0 + np.sqrt(max(f0 * f0 + 2.0 * b * need, 0.0))) / b
            return tz, side, t0 + min(max(tau, 0.0), dt), j, True
        s += ds
        t0, f0 = t[j], f1
        j += 1
    return tz, side, t[n - 1], n, False


@njit(cache=True, nogil=True)
def _crossings(F, S, t, c, W):
    """Each crossing of a clearance c [m] that plateau models, in time order, as arrays:
    (i, t_z, side, t_e, j, closed) of _gap_closes and `end`, the first sample whose window
    [t - W / 2, t + W / 2] starts after t_e (the next crossing is looked for from there).
    A crossing begins where F changes sign between samples i - 1 and i with no gap between
    them (an interval no longer than 4 W)."""
    n = len(F)
    at, end, j_of = np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.int64)
    tz_of, side_of, te_of, closed_of = np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.bool_)
    k = 0
    i = 1
    while i < n:
        h = t[i] - t[i - 1]
        if not (F[i - 1] * F[i] < 0.0) or h <= 0.0 or h > 4.0 * W:
            i += 1
            continue
        tz, side, te, j, closed = _gap_closes(F, S, t, c, i)
        m = i - 1
        while m < n and t[m] - 0.5 * W < te:
            m += 1
        at[k], end[k], j_of[k], tz_of[k], side_of[k], te_of[k], closed_of[k] = i, m, j, tz, side, te, closed
        k += 1
        i = max(m, i + 1)
    return at[:k], tz_of[:k], side_of[:k], te_of[:k], j_of[:k], closed_of[:k], end[:k]


@njit(cache=True, nogil=True)
def plateau(F, S, t, c, W):
    """Free play: the load cell reads zero while the mount crosses a clearance c [m].
    When the force F [N] changes sign (at t_z, between samples) the rod leaves its contact
    and floats where the damper's own force on it is zero; the mount then moves away from
    it at the speed it would have needed to make the force, |F| / S (S: the damping's slope
    dF/dv [N s/m]), so the gap closes at t_e where the integral of |F| / S from t_z is c.
    Each sample holds the force's mean over a window W [s] about it (the amplifier's
    anti-alias filter), so it loses what the part of its window inside the crossing would
    have carried: the force depends smoothly on c and on where the crossing falls between
    samples, and c = 0 is the model without. No crossing is begun across a gap."""
    out = F.copy()
    if c <= 0.0:
        return out
    at, tz, _, te, _, _, end = _crossings(F, S, t, c, W)
    for q in range(len(at)):
        for k in range(at[q] - 1, end[q]):
            lo, hi = max(t[k] - 0.5 * W, tz[q]), min(t[k] + 0.5 * W, te[q])
            if hi > lo:
                out[k] -= integral(F, t, lo, hi) / W
    return out


@njit(cache=True, nogil=True)
def plateau_reach(F, S, t, c, W):
    """(the samples plateau_tangent reads or changes, sorted; the crossings it works on,
    _crossings' at c = 0 or more): about each crossing, from the sample before its interval
    to where the gap has closed and the window past it. Elsewhere a clearance leaves the
    force's derivatives as they are."""
    n = len(F)
    keep = np.zeros(n, np.bool_)
    crossings = _crossings(F, S, t, max(c, 0.0), W)  # at c = 0, the derivative on the side of a clearance
    at, _, _, _, j, _, end = crossings
    for q in range(len(at)):
        keep[max(at[q] - 2, 0):min(max(j[q], end[q]) + 1, n)] = True
    return np.flatnonzero(keep), crossings


@njit(cache=True, nogil=True)
def reset(t, h, i):
    """Whether sample i starts a new stretch (the data jump over left-out cycles)."""
    return i == 0 or t[i] - t[i - 1] > 1.5 * h[i]


# The state kernels below take each sample's transcendental (an exp or tanh of its travel,
# which does not depend on the state) from numpy beforehand: numpy's vectorised ones cost a
# tenth of numba's scalar calls, which were the kernels' whole cost. The loops that carry
# the state are then rational.

def dahl(x, t, h, x_stick):
    """Pre-sliding state z [-] of a Dahl friction along displacement x [m]:
    dz/dx = (1 - z sgn(dx)) / x_stick, exact over each sample (z -> sgn(dx) exponentially
    over x_stick of travel); z starts sliding (sign of the first motion) in each stretch."""
    dx = np.diff(x, prepend=x[:1])
    return _dahl(x, t, h, np.exp(-np.abs(dx) / x_stick))


@njit(cache=True, nogil=True)
def _dahl(x, t, h, decay):
    z = np.empty_like(x)
    zi = 0.0
    for i in range(len(x)):
        if reset(t, h, i):
            dx = x[i + 1] - x[i] if i + 1 < len(x) else 0.0
            zi = 1.0 if dx > 0 else -1.0
        else:
            s = 1.0 if x[i] > x[i - 1] else -1.0
            zi = s + (zi - s) * decay[i]
        z[i] = zi
    return z


def bouc_wen(x, t, h, x_y, gamma):
    """Hysteretic state z [-] (|z| < 1) of a Bouc-Wen element with n = 2 (Spencer et al.
    1997) along displacement x [m], normalised so that z -> 1 on loading:
    dz/dt = (v - beta v z^2 - gamma |v| z |z|) / x_y, beta = 1 - gamma; x_y [m] is the
    travel over which it yields. Exact for displacement linear between samples: along the
    travel u = |dx| / x_y, dz/du = 1 - c z^2 with c = 1 loading (z >= 0) and c = 1 - 2 gamma
    unloading (z < 0), whose closed forms tanh(atanh z + u) and tanh(atanh(r z) + r u) / r
    (r^2 = c; tan for c < 0) are taken by the addition formula from tanh u and tanh r u."""
    u = np.abs(np.diff(x, prepend=x[:1])) / x_y
    c = 1.0 - 2.0 * gamma
    r = np.sqrt(abs(c))
    if c > 1e-9:
        down = np.tanh(r * u)
    elif c < -1e-9:  # past a quarter turn the state has surely reached 0: inf says so
        ru = r * u
        down = np.where(ru < 0.5 * np.pi, np.tan(np.where(ru < 0.5 * np.pi, ru, 0.0)), np.inf)
    else:
        down = u
    return _bouc_wen(x, t, h, u, np.tanh(u), down, c, r)


@njit(cache=True, nogil=True)
def _bouc_wen(x, t, h, u, up, down, c, r):
    z = np.empty_like(x)
    zi = 0.0
    for i in range(len(x)):
        if reset(t, h, i):
            zi = 0.0
        else:
            s = 1.0 if x[i] >= x[i - 1] else -1.0
            zi = s * _bw_step(s * zi, u[i], up[i], down[i], c, r)
        z[i] = zi
    return z


@njit(cache=True, nogil=True)
def _bw_step(z, u, up, down, c, r):
    """The state after travel u [yield lengths] from z, in the direction of travel; up and
    down are tanh u and tanh r u (tan r u for c < 0, u for c = 0)."""
    if z < 0.0:  # unloading until z reaches 0, then loading over the rest of the travel
        w = r * z
        if c > 1e-9:
            w = max(w, -1.0 + 1e-15)
            if w + down < 0.0:
                return (w + down) / (1.0 + w * down) / r
            u -= math.atanh(-w) / r
        elif c < -1e-9:
            if w + down < 0.0:
                return (w + down) / (1.0 - w * down) / r
            u -= math.atan(-w) / r
        else:
            if z + u < 0.0:
                return z + u
            u += z
        return math.tanh(max(u, 0.0))
    z = min(z, 1.0 - 1e-15)
    return (z + up) / (1.0 + z * up)


# --- tangents: each kernel's derivative along the fit's parameters, (k, n) rows in, (k, n)
# out, one row per parameter (the Jacobian's columns; models/diagnose/candidates.py)

@njit(cache=True, nogil=True)
def lag_tangent(F, tau, h, y, dF, dtau):
    """lag(F, tau, h) = y's derivative: y_i = y_(i-1) + a_i (F_i - y_(i-1)), a_i = h_i / (tau_i + h_i),
    y_(-1) = F_0, so dy_i = dy_(i-1) + a_i (dF_i - dy_(i-1)) + da_i (F_i - y_(i-1))."""
    k, n = dF.shape
    out = np.empty((k, n))
    for q in range(k):
        dy, yp = dF[q, 0], F[0]
        for i in range(n):
            a = h[i] / (tau[i] + h[i])
            da = -h[i] / (tau[i] + h[i]) ** 2 * dtau[q, i]
            dy = dy + a * (dF[q, i] - dy) + da * (F[i] - yp)
            yp = y[i]
            out[q, i] = dy
    return out


@njit(cache=True, nogil=True)
def dahl_tangent(x, t, h, decay, z, ddecay):
    """dahl's state z's derivative in its x_stick, from each sample's decay's (ddecay):
    z_i = s + (z_(i-1) - s) decay_i, so dz_i = dz_(i-1) decay_i + (z_(i-1) - s) ddecay_i; none at a reset."""
    out = np.empty_like(x)
    dz = 0.0
    for i in range(len(x)):
        if reset(t, h, i):
            dz = 0.0
        else:
            s = 1.0 if x[i] > x[i - 1] else -1.0
            dz = dz * decay[i] + (z[i - 1] - s) * ddecay[i]
        out[i] = dz
    return out


@njit(cache=True, nogil=True)
def plateau_tangent(F, S, t, W, reach, dF, dS, dc):
    """plateau(F, S, t, c, W)'s derivative along rows dF, dS (the force's and the slope's,
    known at the samples of plateau_reach(F, S, t, c, W), `reach`: column m is sample
    at[m]'s) and dc (the clearance's, one per row), at those samples. Each crossing's window integrals move
    with F at fixed limits, and with the gap's closing time t_e, where the force is |F_e|:
    the start t_z moves the limits where F is zero, which moves nothing. t_e solves
    int_tz^te |F| / S dt = c, so |F_e| dt_e = S_e (dc - int_tz^te d(|F| / S) dt), S stepwise
    as plateau takes it (its value at each interval's end)."""
    k = dF.shape[0]
    at, (starts, tzs, sides, tes, js, closes, ends) = reach
    pos = np.full(len(F), -1)
    pos[at] = np.arange(len(at))
    out = dF.copy()
    G = np.zeros(k)
    for x in range(len(starts)):
        i, tz, side, te, jc, closed = starts[x], tzs[x], sides[x], tes[x], js[x], closes[x]
        for q in range(k):
            G[q] = 0.0
        t0 = tz
        # each interval's share of int d(|F| / S) up to where the gap closed: |F| = side F on
        # the gap, S = kj there (none of the interval where F turned back)
        for j in range(i, jc + 1 if closed else jc):
            kj = max(S[j], 1e-9)
            hi = te if closed and j == jc else t[j]
            first, whole = max(np.searchsorted(t, t0) - 1, 0), integral(F, t, t0, hi)
            for q in range(k):
                dk = dS[q, pos[j]] if S[j] > 1e-9 else 0.0
                G[q] -= side * _integral_at(dF[q], pos, t, first, t0, hi) / kj - dk / (kj * kj) * side * whole
            t0 = t[j]
        if closed:
            kj = max(S[jc], 1e-9)
            for q in range(k):
                G[q] = kj * (G[q] + dc[q])  # |F_e| dt_e
        for m in range(i - 1, ends[x]):
            lo, hi = max(t[m] - 0.5 * W, tz), min(t[m] + 0.5 * W, te)
            first = max(np.searchsorted(t, lo) - 1, 0)
            for q in range(k):  # (at c = 0 the window holding t_z has no width and still moves)
                acc = _integral_at(dF[q], pos, t, first, lo, hi) if hi > lo else 0.0
                if closed and hi == te:
                    acc += side * G[q]
                out[q, pos[m]] -= acc / W
    return out
