"""The dynamic (sine) segments of a recording as the compressible fit uses them."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.damper import T_STD
from records.data import at, gaps, missing, smooth, smoothing_cutoff
from records.segmentation import cut

WARMUP_S = 0.1  # simulated before a segment's scored part (chamber pressures settle in ms)
# a gap longer than this share of a cycle leaves its segment out: resampled across it, a sine
# is off by up to (2 pi share)^2 / 8 of its amplitude (1.2 % at 5 %); a shorter one is harmless
GAP_CYCLE_SHARE = 0.05
# A loop that stalls holds the actuator, which then jumps to where the sine has gone: motion
# the model's drive (the displacement low-passed, records/data.smooth) cannot follow, and the
# force answers it. A segment whose displacement leaves its drive by more than JUMP_SHARE of
# its amplitude and JUMP_NOISE times the deviation's own scatter is left out. Measured: a wired
# run's 20 ms stall at 3.2 mm 2 Hz 8.5 % and 54 times (its held-out error 0.078 against 0.007
# without the segment); the real recordings in tests/data and the UTFSM raw exports (chirps
# included) at most 8.7 % at 13 times, or 22 times at 0.02 %; the embedded rig 0.6 % at 4 times
JUMP_SHARE = 0.02
JUMP_NOISE = 25.0
MIN_SEGMENTS = 3  # fewer sine segments than this: each is cut into groups of its cycles
GROUPS = 6  # ... at most this many, of at least two cycles each


def by_cycles(span):
    """A long sine segment as consecutive groups of its whole cycles (the valves are fitted
    on some and judged on others: held-out cycles); the segment itself when it has fewer
    than four cycles. A segment spans whole cycles of its frequency (records/segmentation.py)."""
    name, params, t0, t1 = span
    f = params.get("freq_hz") or 0.0
    n = int(round((t1 - t0) * f))
    if n < 4:
        return [span]
    out = []
    for part in np.array_split(np.arange(n), min(GROUPS, n // 2)):
        out.append((f"{name} cycles {part[0] + 1}-{part[-1] + 1}", {**params, "cycles": len(part)},
                    t0 + part[0] / f, t0 + (part[-1] + 1) / f))
    return out


@dataclass
class Resampled:
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
    smoothing: object = None  # the source's moving average (models/source_filter.Smoothing): a model goes through it

    @property
    def freq(self):
        return float(self.params.get("freq_hz", 0.0))


def dynamic_segments(channels, events, left_out=None, smoothing=None):
    """The sine segments (sine matrix, temperature sweep, imported cycling) as Segments,
    each with the moving average its source applied (smoothing, or None). Left out (left_out:
    {name: why}): one with a gap in its force or displacement record longer than
    GAP_CYCLE_SHARE of its cycle (resampled across it, the segment would be data never
    measured) and one whose motion jumps (its drive would not be the motion measured)."""
    left_out = {} if left_out is None else left_out
    spans = [s for s in cut(channels, events) if s.kind == "sine"]
    if 0 < len(spans) < MIN_SEGMENTS:  # a crank dyno's run of one stroke: its cycles held out in groups
        spans = [part for span in spans for part in by_cycles(span)]
    tf = channels["force"][0]
    h = float(np.median(np.diff(tf)))
    holes = gaps(tf) + gaps(channels["x"][0])
    out = []
    for name, params, t0, t1 in spans:
        start = max(t0 - WARMUP_S, tf[0])
        longest = GAP_CYCLE_SHARE / params["freq_hz"] if params.get("freq_hz") else 0.0
        hole = next(((a, b) for a, b in holes if a < t1 and b > start and b - a > longest), None)
        if hole:
            left_out[name] = (f"a gap of {1e3 * (hole[1] - hole[0]):.0f} ms in its record at {hole[0]:.3f} s, "
                              f"over {100 * GAP_CYCLE_SHARE:g} % of a cycle (a stalled loop or lost frames)")
            continue
        t = np.arange(start, t1, h)
        if len(t) < 20:
            continue
        f = params.get("freq_hz", 1.0)
        measured = at(channels, "x", t)
        x = smooth(measured, h, f)
        jump = _jump(t, measured, x, start, t0, t1, smoothing_cutoff(h, f))
        if jump:
            left_out[name] = jump
            continue
        v = smooth(at(channels, "v", t) if "v" in channels else np.gradient(x, t), h, f)
        T = float(at(channels, "T_body", t).mean()) if "T_body" in channels else T_STD
        P = at(channels, "P_gas", t) if "P_gas" in channels else None
        seg = Resampled(name, params, t, x, v, at(channels, "force", t), T, P, int(np.searchsorted(t, t0)),
                      smoothing=smoothing)
        if P is not None:
            tp, pv = channels["P_gas"]
            k = (tp >= t0) & (tp <= t1)
            seg.tP, seg.P = tp[k], pv[k]
            if not missing(channels, ("P1", "P2")) and k.sum() > 4:
                seg.chambers = {"t": seg.tP, "x": np.interp(seg.tP, t, x), "v": np.interp(seg.tP, t, v),
                                "P_gas": seg.P, "P1": at(channels, "P1", seg.tP), "P2": at(channels, "P2", seg.tP)}
        out.append(seg)
    return out


def _jump(t, measured, drive, start, t0, t1, fc):
    """Why the measured displacement is not its drive (JUMP_SHARE, JUMP_NOISE), or None. Not
    judged within 1 / fc of the segment's ends: the filter's edges, and the kink where one test
    of a file joins the next (its speed steps), are no stall."""
    k = (t >= max(t0, start) + 1.0 / fc) & (t <= t1 - 1.0 / fc)
    if k.sum() < 20:
        return None
    r = (measured - drive)[k]
    scatter = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    i = int(np.argmax(np.abs(r)))
    amplitude = float(np.ptp(measured[k])) / 2
    if abs(r[i]) > JUMP_SHARE * amplitude and abs(r[i]) > JUMP_NOISE * scatter:
        return (f"its displacement jumps {1e3 * abs(r[i]):.2g} mm off its smooth motion at {t[k][i]:.3f} s "
                f"(the actuator held while the loop stalled?): the model, driven by the smooth motion, "
                f"cannot follow it")
    return None
