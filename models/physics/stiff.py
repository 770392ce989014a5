"""Fixed-step implicit integration of the compressible damper ODE.

The chamber pressures relax with time constants of 10-100 us (bulk modulus over chamber
volume times the valve's flow gain), far below a 0.1 ms output step, so explicit schemes
would need tiny steps. We use BDF2 (second order, L-stable: stiff modes are damped, not
rung), started with one backward-Euler step, and solve each step's implicit equation with
a modified Newton method: the finite-difference Jacobian is kept across steps and
refreshed only when the iteration stops contracting (after a valve opens, say).

The input motion x(t), v(t) is sampled at the output times; substeps interpolate it
linearly. Discrete valve state (the Mechformance bypass seat) is updated between steps by
the assembly's `outputs` function.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from models.physics.assemblies import outputs, rhs


@njit(cache=True)
def _lu(M, piv):
    n = M.shape[0]
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(M[i, k]) > abs(M[p, k]):
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                M[k, j], M[p, j] = M[p, j], M[k, j]
        for i in range(k + 1, n):
            M[i, k] /= M[k, k]
            for j in range(k + 1, n):
                M[i, j] -= M[i, k] * M[k, j]


@njit(cache=True)
def _solve(M, piv, b):
    n = M.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        for j in range(i):
            b[i] -= M[i, j] * b[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            b[i] -= M[i, j] * b[j]
        b[i] /= M[i, i]


def new_history(n):
    """Integrator memory for an n-state model: rows y_{k-1}, y_{k-2}, [2 x steps
    taken (capped at 2) + Jacobian valid, ...], then the n x n Jacobian. All zeros: a fresh start."""
    return np.zeros((3 + n, n))


@njit(cache=True, nogil=True)
def integrate(layout, y, x, xd, nsub, h, prm, vp, vh, atol, out, hist):
    """March y of the assembly `layout` (assemblies.CODE) from sample 0 to the last
    sample of x, xd (spacing h seconds, nsub implicit steps per sample), writing its
    outputs at every sample into out[k].
    y is updated in place to the final state. hist (new_history(n)) carries the BDF2
    history and Jacobian from one call to the next, so a caller feeding one sample at
    a time (the coupled quarter car) keeps second order. Returns (Jacobian refreshes,
    steps whose Newton iteration hit its cap, Newton iterations)."""
    n = y.shape[0]
    N = x.shape[0]
    hs = h / nsub
    y_prev = hist[0].copy()
    y_prev2 = hist[1].copy()
    J = hist[3:].copy()
    code = int(hist[2, 0])
    started = code // 2  # implicit steps taken so far (0, 1, 2+)
    have_J = code % 2 == 1
    y_new = y.copy()
    r = np.empty(n)
    f = np.empty(n)
    f2 = np.empty(n)
    res = np.empty(n)
    M = np.empty((n, n))
    piv = np.zeros(n, np.int64)
    scratch = np.empty(out.shape[1])
    g_fact = -1.0
    refreshes = 0
    capped = 0
    iters = 0
    outputs(layout, y, x[0], xd[0], prm, vp, vh, out[0])
    for k in range(1, N):
        for j in range(1, nsub + 1):
            w = j / nsub
            xs = x[k - 1] + w * (x[k] - x[k - 1])
            xds = xd[k - 1] + w * (xd[k] - xd[k - 1])
            if started:  # BDF2: y_n+1 - 4/3 y_n + 1/3 y_n-1 = 2/3 h f(y_n+1)
                g = 2.0 / 3.0 * hs
                for i in range(n):
                    r[i] = (4.0 * y[i] - y_prev[i]) / 3.0
                    if started > 1:  # quadratic predictor: often converges in one iteration
                        y_new[i] = 3.0 * (y[i] - y_prev[i]) + y_prev2[i]
                    else:
                        y_new[i] = 2.0 * y[i] - y_prev[i]
            else:  # backward Euler start
                g = hs
                for i in range(n):
                    r[i] = y[i]
                    y_new[i] = y[i]
            converged = False
            last = 0.0
            for it in range(12):
                if not have_J:
                    rhs(layout, y_new, xs, xds, prm, vp, vh, f)
                    for c in range(n):
                        d = 1e-7 * max(abs(y_new[c]), 1e6 * atol[c])
                        keep = y_new[c]
                        y_new[c] = keep + d
                        rhs(layout, y_new, xs, xds, prm, vp, vh, f2)
                        y_new[c] = keep
                        for i in range(n):
                            J[i, c] = (f2[i] - f[i]) / d
                    have_J = True
                    g_fact = -1.0
                    refreshes += 1
                if g_fact != g:
                    for i in range(n):
                        for c in range(n):
                            M[i, c] = (1.0 if i == c else 0.0) - g * J[i, c]
                    _lu(M, piv)
                    g_fact = g
                iters += 1
                rhs(layout, y_new, xs, xds, prm, vp, vh, f)
                for i in range(n):
                    res[i] = -(y_new[i] - r[i] - g * f[i])
                _solve(M, piv, res)
                err = 0.0
                for i in range(n):
                    y_new[i] += res[i]
                    err = max(err, abs(res[i]) / atol[i])
                # converged when the step is tiny, or when the contraction rate theta says
                # the remaining error theta/(1-theta)*err is (Hairer & Wanner IV.8)
                if err < 1.0:
                    converged = True
                    break
                if it > 0:
                    theta = err / last
                    if theta < 0.9 and theta / (1.0 - theta) * err < 1.0:
                        converged = True
                        break
                    if theta > 0.3:  # slow contraction: refresh the Jacobian
                        have_J = False
                last = err
            if not converged:
                capped += 1
                have_J = False
            for i in range(n):
                y_prev2[i] = y_prev[i]
                y_prev[i] = y[i]
                y[i] = y_new[i]
            started += 1
            outputs(layout, y, xs, xds, prm, vp, vh, scratch)
        for i in range(out.shape[1]):
            out[k, i] = scratch[i]
    hist[0] = y_prev
    hist[1] = y_prev2
    hist[3:] = J
    hist[2, 0] = 2 * min(started, 2) + (1 if have_J else 0)
    return refreshes, capped, iters
