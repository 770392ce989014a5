"""Actuator delay compensation for hardware-in-the-loop: each tick the loop knows where the
damper must be one tick from now (x [m], v [m/s], a [m/s^2], from the virtual car) and
must command the actuator so that it is there, although the servo lags (the virtual
rig's: a 40 Hz first-order position loop, 4 ms) and the frame gives under the force.

    comp = make("adaptive", delay_s=0.005, period=0.001)
    x_cmd = comp.command(x, v, a, F)      # each tick, before sending the setpoint
    comp.observe(x_cmd, x_measured, F)    # each tick, the command sent and this tick's reading

Compensators (real-time hybrid simulation practice):
- none: the target itself;
- polynomial: the target extrapolated over the estimated delay d (Horiuchi's
  predictor): x + d v + d^2/2 a;
- adaptive: adaptive time series (Chae, Kazemibidokhti and Ricles 2013): the command is
  a0 x + a1 v + a2 a + a3 F, its coefficients re-fitted every UPDATE_S by least squares
  from the commands sent and the motion measured over the last WINDOW_S (the inverse of
  the actuator and frame as they are now); a3 takes up the frame's compliance.

Delay and gain are estimated by `fit` on any stretch of commands and measurements (a
probe before the run, or the run so far); the estimated delay is a1 / a0.
"""
from __future__ import annotations

import math
from collections import deque
from functools import lru_cache

import numpy as np

WINDOW_S = 1.0  # s of history each adaptive fit uses
UPDATE_S = 0.1  # s between adaptive fits
SMOOTH_S = 0.015  # s: the local polynomial the measured motion's derivatives come from
# bounds of the adaptive coefficients: beyond them the fit is not of an actuator
A0 = (0.5, 2.0)
DELAY_MAX_S = 0.05


@lru_cache(maxsize=8)
def kernels(n, h):
    """Convolution kernels of a least-squares cubic over n samples (n odd, h [s]): its value,
    slope and second derivative at the middle sample. scipy.signal.savgol_coeffs(n, 3,
    deriv=d, delta=h) to the last bit (tests/test_hil.py), without importing scipy.signal:
    0.65 s at every start of a process that may run a control loop."""
    x = np.arange(n // 2, -(n // 2) - 1, -1.0)  # reversed, as np.convolve applies a kernel
    A = x ** np.arange(4).reshape(-1, 1)
    out = []
    for d in (0, 1, 2):
        y = np.zeros(4)
        y[d] = math.factorial(d) / h ** d
        out.append(np.linalg.lstsq(A, y, rcond=None)[0])
    return tuple(out)


def derivatives(x, h):
    """(x, v, a) of a sampled motion (h [s]) from a local cubic (Savitzky-Golay) over
    SMOOTH_S: the measurement's noise is not differentiated raw. Only where a whole window
    fits: SMOOTH_S / 2 fewer samples at each end (savgol_filter's fitted edges cost 0.3 ms
    each, three times per fit: a stall of the control tick the adaptive fit runs in)."""
    n = max(5, int(round(SMOOTH_S / h)) | 1)
    if len(x) < n:
        return x, np.gradient(x, h), np.zeros_like(x)
    return tuple(np.convolve(x, k, mode="valid") for k in kernels(n, h))


def fit(commands, measured, forces, h, with_force=True):
    """(coefficients [a0, a1, a2, a3], offset) with command[k] = offset + a0 x + a1 v +
    a2 a + a3 F, the motion (x, v, a) measured one tick later (when the command has been
    acted on) and F this tick (a3 = 0 without with_force); None without enough motion to
    fit (its RMS velocity under 1 mm/s)."""
    c, m, f = (np.asarray(a, float) for a in (commands, measured, forces))
    if len(c) < 50:
        return None
    x, v, a = derivatives(m, h)
    k = (len(m) - len(x)) // 2  # the samples derivatives() leaves out at each end
    x, v, a, c, f = x[1:], v[1:], a[1:], c[k:len(m) - k - 1], f[k:len(m) - k - 1]
    if np.sqrt(np.mean(v ** 2)) < 1e-3:
        return None
    cols = [x - x.mean(), v, a] + ([f - f.mean()] if with_force else [])
    A = np.column_stack(cols)
    scale = np.maximum(np.sqrt(np.mean(A ** 2, axis=0)), 1e-12)
    sol, *_ = np.linalg.lstsq(A / scale, c - c.mean(), rcond=None)
    coef = np.zeros(4)
    coef[:len(sol)] = sol / scale
    # the constant: the command's mean less what the coefficients explain of it
    return coef, c.mean() - coef[0] * x.mean() - coef[3] * f.mean()


class NoCompensation:
    name = "none"

    def __init__(self, delay_s=0.0, period=1e-3):
        self.delay_s = delay_s

    def command(self, x, v, a, F):
        return x

    def observe(self, x_cmd, x_meas, F):
        pass


class Polynomial:
    """Extrapolation over the estimated delay: x + d v + d^2/2 a."""
    name = "polynomial"

    def __init__(self, delay_s, period=1e-3):
        self.delay_s = delay_s

    def command(self, x, v, a, F):
        d = self.delay_s
        return x + d * v + 0.5 * d * d * a

    def observe(self, x_cmd, x_meas, F):
        pass


class Adaptive:
    """Adaptive time series with a force term: starts as the polynomial over delay_s,
    then re-fits its coefficients every UPDATE_S from the last WINDOW_S."""
    name = "adaptive"

    def __init__(self, delay_s, period=1e-3, start=None):
        """start: (coefficients, offset) of a fit made before (a probe's), else the
        polynomial over delay_s."""
        self.h = period
        self.coef = np.array([1.0, delay_s, 0.5 * delay_s ** 2, 0.0])
        self.offset = 0.0
        if start is not None and _plausible(start[0]):
            self.coef, self.offset = np.asarray(start[0], float), float(start[1])
        n = int(round(WINDOW_S / period))
        self.c, self.m, self.f = deque(maxlen=n), deque(maxlen=n), deque(maxlen=n)
        self.every = max(1, int(round(UPDATE_S / period)))
        self.ticks = 0
        self.fits = 0

    @property
    def delay_s(self):
        return float(self.coef[1] / self.coef[0])

    def command(self, x, v, a, F):
        a0, a1, a2, a3 = self.coef
        return self.offset + a0 * x + a1 * v + a2 * a + a3 * F

    def observe(self, x_cmd, x_meas, F):
        self.c.append(x_cmd)
        self.m.append(x_meas)
        self.f.append(F)
        self.ticks += 1
        if self.ticks % self.every == 0 and len(self.c) == self.c.maxlen:
            self._update()

    def _update(self):
        r = fit(self.c, self.m, self.f, self.h)
        if r is None:
            return
        coef, offset = r
        if not _plausible(coef):
            return  # not an actuator's inverse (too little motion, a transient): keep the last
        self.coef, self.offset = coef, offset
        self.fits += 1


def _plausible(coef):
    return A0[0] <= coef[0] <= A0[1] and 0.0 <= coef[1] / coef[0] <= DELAY_MAX_S


COMPENSATORS = {c.name: c for c in (NoCompensation, Polynomial, Adaptive)}


def make(name, delay_s, period, start=None):
    """A compensator by name; start: a fit made before, for the adaptive one."""
    return Adaptive(delay_s, period, start) if name == Adaptive.name else COMPENSATORS[name](delay_s, period)
