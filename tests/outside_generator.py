"""A second recording generator, written apart from the diagnosis and the virtual plant:
a damper as a plain force law sampled on a sine matrix, with what a real cell adds
(issue 29, item 5). Nothing here imports models/ or sim_backend/: it stands for data we
did not make.

force = valves(v) + gas(x) + F_c sgn(v) [+ extra(x, v, t, f)]   (N, compression positive)

The cell: every channel sampled at `rate`; white or coloured (first-order) noise on force,
displacement and velocity; the force through an optional first-order load-cell filter and
quantised to 16 bits over +-range; the force channel's clock offset from the motion's by
`misalign` seconds. Written as MCAP with dyno's topic layout (docs/recording.md) by the
mcap library alone (tests/mcap_files.py)."""
import math

import numpy as np

AMPLITUDES_M = (0.0032, 0.0064, 0.0127)
FREQS_HZ = (1.0, 4.0, 10.0)
X_MID = 0.035  # m
F_RANGE = 10_000.0  # N: the load cell's full scale, quantised to 16 bits over +-F_RANGE


def valves(v, law="quadratic"):
    """Damping force [N] from velocity [m/s]: three laws, none of them our baseline's form."""
    if law == "quadratic":  # orifice + bleed
        return np.where(v > 0, 2500.0, 5000.0) * v + np.where(v > 0, 4000.0, 9000.0) * v * np.abs(v)
    if law == "digressive":  # blow-off: a knee at 0.1 m/s
        return np.where(v > 0, 900.0, 1800.0) * np.tanh(v / 0.1) + np.where(v > 0, 1200.0, 2400.0) * v
    if law == "linear":
        return np.where(v > 0, 3000.0, 6000.0) * v
    raise ValueError(law)


def gas(x):
    """Gas force [N]: isothermal (our baseline takes 1.38), 300 N at mid-stroke, 80 mm of gas."""
    return 300.0 * 0.08 / (0.08 - (x - X_MID))


def noise(rng, n, sigma, colour):
    """White, or first-order coloured (pole at 0.95 per sample), scaled to sigma."""
    w = rng.normal(0.0, sigma, n)
    if colour == "white":
        return w
    out = np.empty(n)
    acc = 0.0
    for i in range(n):
        acc = 0.95 * acc + w[i]
        out[i] = acc
    return out * sigma / max(np.std(out), 1e-12)


def record(path, rate=5000.0, friction=60.0, law="quadratic", colour="white", loadcell_hz=None, misalign=0.0,
           quantise=True, sigma_F=1.5, sigma_x=5e-6, sigma_v=2e-3, extra=None, extra_rms=None, seed=0, cycles=8):
    """Write a sine-matrix recording to path; returns path. extra(x, v, t, f) -> N (f the
    segment's frequency [Hz] at each sample) adds physics the catalogue may not hold; extra_rms [N], when given, scales it to that RMS
    over the recording."""
    rng = np.random.default_rng(seed)
    h = 1.0 / rate
    t_all, x_all, v_all, F_all, E_all, events = [], [], [], [], [], []
    t0 = 0.0
    for A in AMPLITUDES_M:
        for f in FREQS_HZ:
            if 2 * math.pi * f * A > 1.2:
                continue
            # one cycle ramping in, one settling, `cycles` recorded, one ramping out: the
            # motion is continuous, as an actuator's is; the events cover the recorded cycles
            n = int(round((cycles + 3) / f * rate))
            t = t0 + np.arange(n) * h
            w = 2 * math.pi * f

            def motion(tt, t0=t0, A=A, w=w, f=f):
                u = (tt - t0) * f  # cycles since the start
                env = A * np.clip(np.minimum(u, cycles + 3 - u), 0.0, 1.0)
                denv = A * f * np.where(u < 1, 1.0, np.where(u > cycles + 2, -1.0, 0.0))
                ph = w * (tt - t0)
                return X_MID + env * np.sin(ph), env * w * np.cos(ph) + denv * np.sin(ph)
            x, v = motion(t)
            ts = t - misalign  # the force channel's clock runs `misalign` behind the motion's
            xs, vs = motion(ts)
            F = valves(vs, law) + gas(xs) + friction * np.sign(vs)
            E_all.append(extra(xs, vs, ts, np.full(n, f)) if extra is not None else np.zeros(n))
            name = f"sine {A * 1e3:g} mm {f:g} Hz"
            events += [{"t": float(t0 + 2 / f), "kind": "segment_start", "segment": name,
                        "params": {"kind": "sine", "freq_hz": f, "amplitude_mm": A * 1e3, "cycles": cycles}},
                       {"t": float(t0 + (cycles + 2) / f), "kind": "segment_end", "segment": name, "params": {}}]
            t_all.append(t), x_all.append(x), v_all.append(v), F_all.append(F)
            t0 = t[-1] + h
    t, x, v, F, E = (np.concatenate(a) for a in (t_all, x_all, v_all, F_all, E_all))
    if extra_rms is not None:
        E = E * extra_rms / max(float(np.sqrt(np.mean(E ** 2))), 1e-300)
    F = F + E
    if loadcell_hz:
        a = math.exp(-2 * math.pi * loadcell_hz * h)
        out, acc = np.empty_like(F), F[0]
        for i in range(len(F)):
            acc = a * acc + (1 - a) * F[i]
            out[i] = acc
        F = out
    F = F + noise(rng, len(F), sigma_F, colour)
    if quantise:
        lsb = 2 * F_RANGE / 65536
        F = np.round(F / lsb) * lsb
    x = x + noise(rng, len(x), sigma_x, colour)
    v = v + noise(rng, len(v), sigma_v, colour)
    _write(path, t, {"force": (F, "N"), "x": (x, "m"), "v": (v, "m/s")}, events)
    return path


def _write(path, t, channels, events):
    from tests.mcap_files import write
    batches = {name: [{"t": t[i:i + 1000].tolist(), "value": values[i:i + 1000].tolist(), "unit": unit}
                      for i in range(0, len(t), 1000)] for name, (values, unit) in channels.items()}
    write(path, batches, events, {"protocol": {"name": "outside", "params": "{}"}})
