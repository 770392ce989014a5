"""Road inputs for the quarter car (thesis 6.2: steps and harmonics; ISO 8608 random
roads as the stochastic analysis the thesis recommends). Arrays in, arrays out: m, s."""
from __future__ import annotations

import numpy as np

# ISO 8608 displacement PSD at n0 = 0.1 cycles/m, class mean values [m^3]
ISO8608_GD0 = {c: 16e-6 * 4**i for i, c in enumerate("ABCDEFGH")}
N0 = 0.1  # cycles/m
BLOCK = 1024  # samples per block of an evenly spaced road (iso8608)


def step(t, amplitude, t0=0.0):
    """Step of `amplitude` [m] (positive up) at t0 (6.2: +-2.5 and +5 cm)."""
    return np.where(np.asarray(t) >= t0, amplitude, 0.0)


def square_edge(t, peak_to_peak, t_edge):
    """One edge of a square wave [m]: -peak_to_peak / 2 before t_edge, +peak_to_peak / 2
    after (thesis line 713: steps of 1.27, 2.54 and 5.08 cm peak to peak at 0.1 Hz)."""
    return np.where(np.asarray(t) >= t_edge, 0.5, -0.5) * peak_to_peak


def harmonic(t, amplitude, freq):
    """(y, v): sine of peak amplitude [m] at freq [Hz] (6.2: 0.32 and 1.27 cm)."""
    w = 2 * np.pi * freq
    return amplitude * np.sin(w * np.asarray(t)), amplitude * w * np.cos(w * np.asarray(t))


def iso8608(t, speed, road_class="C", seed=0, n_band=(0.01, 10.0), n_lines=2000):
    """(y, v): a random road of ISO 8608 class A-H driven at speed [m/s].

    Sum of sinusoids with random phases whose amplitudes follow the class PSD
    G_d(n) = G_d(n0) (n/n0)^-2 over the spatial-frequency band n_band [cycles/m]."""
    if road_class not in ISO8608_GD0:
        raise ValueError(f"road class must be one of A-H, got {road_class!r}")
    if not speed > 0:
        raise ValueError(f"speed must be positive, got {speed}")
    rng = np.random.default_rng(seed)
    edges = np.geomspace(n_band[0], n_band[1], n_lines + 1)
    n = np.sqrt(edges[:-1] * edges[1:])
    amp = np.sqrt(2 * ISO8608_GD0[road_class] * (n / N0) ** -2 * np.diff(edges))
    phase = rng.uniform(0, 2 * np.pi, n_lines)
    s = speed * np.asarray(t, float)
    w = 2 * np.pi * n  # rad/m
    y, v = np.zeros_like(s), np.zeros_like(s)
    ds = np.diff(s)
    if len(s) > 1 and np.allclose(ds, ds[0], rtol=1e-9, atol=0.0):
        # evenly spaced: each block of BLOCK samples is the first block's phases turned by
        # the block's start, cos(a + b) = cos a cos b - sin a sin b, so the sines and cosines
        # of len(t) x n_lines phases are those of BLOCK x n_lines, and the rest is products
        b = np.outer(np.arange(min(BLOCK, len(s))) * ds[0], w)
        cos_b, sin_b = np.cos(b), np.sin(b)
        for k in range(0, len(s), BLOCK):
            m = min(BLOCK, len(s) - k)
            a = w * s[k] + phase
            ca, sa = amp * np.cos(a), amp * np.sin(a)
            y[k:k + m] = cos_b[:m] @ ca - sin_b[:m] @ sa
            v[k:k + m] = -(cos_b[:m] @ (sa * w * speed) + sin_b[:m] @ (ca * w * speed))
        return y, v
    for k in range(0, n_lines, 100):  # chunks keep memory at 100 x len(t)
        arg = np.outer(s, w[k:k + 100]) + phase[k:k + 100]
        y += np.cos(arg) @ amp[k:k + 100]
        v -= np.sin(arg) @ (amp[k:k + 100] * w[k:k + 100] * speed)
    return y, v


def iso8608_variance(road_class, n_band=(0.01, 10.0)):
    """Closed-form road variance over the band: integral of G_d [m^2]."""
    a, b = n_band
    return ISO8608_GD0[road_class] * N0**2 * (1 / a - 1 / b)


def sweep(t, f0, f1, amplitude):
    """(y, v): a logarithmic sine sweep of peak amplitude [m] from f0 to f1 [Hz] over t
    (equal time per octave, as transmissibility measurements use)."""
    t = np.asarray(t, float)
    T = t[-1] - t[0]
    k = np.log(f1 / f0) / T
    phase = 2 * np.pi * f0 * np.expm1(k * (t - t[0])) / k
    f = f0 * np.exp(k * (t - t[0]))
    return amplitude * np.sin(phase), amplitude * 2 * np.pi * f * np.cos(phase)


def faded(t, y, fade_s):
    """y faded in and out over fade_s [s] with half-cosine windows: a road that starts and
    ends at rest (no velocity step at either end)."""
    t = np.asarray(t, float)
    w = np.ones_like(t)
    a, b = t - t[0], t[-1] - t
    w = np.where(a < fade_s, 0.5 - 0.5 * np.cos(np.pi * a / fade_s), w)
    w = np.where(b < fade_s, 0.5 - 0.5 * np.cos(np.pi * b / fade_s), w)
    return y * w
