"""Static test (thesis 2.3.1.2): hold discrete displacements across the stroke, reached at
the end of a compression stroke and of an extension stroke, each until the force settles.
The mean of the two is the gas force, half their difference the static friction
(eqs 3.7, 3.1)."""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from protocols.plan import ParamError, RigInfo, Segment

NAME = "static"


@dataclass
class Params:
    points: int = 9  # displacements, evenly over the usable stroke
    approach_mm: float = 2.0  # overtravel each approach comes from
    speed_mm_s: float = 5.0  # moves between points
    dwell_min_s: float = 1.0
    dwell_max_s: float = 30.0
    settle_window_s: float = 1.0  # settled: mean force of the last window within settle_n of the one before
    # 0.2 N per second: the gas is within about 1 N of isothermal (eq 3.7 assumes it) once
    # its heat exchange slows to this, for any exponential settling of a few seconds
    settle_n: float = 0.2


def check(p: Params, rig: RigInfo):
    if not 2 <= p.points <= 200:
        raise ParamError(f"points: 2 to 200, got {p.points}")
    for name in ("approach_mm", "speed_mm_s", "dwell_min_s", "dwell_max_s", "settle_window_s", "settle_n"):
        if not getattr(p, name) > 0:
            raise ParamError(f"{name}: must be positive, got {getattr(p, name):g}")
    if p.speed_mm_s / 1e3 > rig.v_max:
        raise ParamError(f"speed_mm_s: {p.speed_mm_s:g} mm/s is above the rig's {rig.v_max:g} m/s")
    if p.dwell_max_s < p.dwell_min_s:
        raise ParamError("dwell_max_s: must not be below dwell_min_s")
    lo, hi = positions(p, rig)[[0, -1]]
    if not lo < hi:
        raise ParamError(f"approach_mm: {p.approach_mm:g} mm leaves no stroke to hold in (usable "
                         f"{rig.x_min * 1e3:.1f}..{rig.x_max * 1e3:.1f} mm, each approach needs it plus 2 mm "
                         f"at both ends)")
    return []


def positions(p, rig):
    margin = p.approach_mm / 1e3 + 0.002  # the approach stays 2 mm inside the limits
    return np.linspace(rig.x_min + margin, rig.x_max - margin, p.points)


def _move(a, b, speed):
    T = max(abs(b - a) / speed, 1e-3)
    return T, (lambda t: a + (b - a) * min(t / T, 1.0))


def settled(p):
    """until() for a dwell: the mean force over the last window differs from the window
    before by less than settle_n (means, so the load cell's noise does not count)."""
    old, new = deque(), deque()  # (t, force) of the window before last, and of the last
    sums = [0.0, 0.0]
    start = []

    def until(readings):
        f = readings.get("force")
        if f is None:
            return False
        if not start:
            start.append(f.t)
        new.append((f.t, f.value))
        sums[1] += f.value
        mid = f.t - p.settle_window_s
        while new and new[0][0] < mid:  # running sums: this runs every loop tick
            t, v = new.popleft()
            old.append((t, v))
            sums[0] += v
            sums[1] -= v
        while old and old[0][0] < mid - p.settle_window_s:
            sums[0] -= old.popleft()[1]
        if f.t - start[0] < max(p.dwell_min_s, 2 * p.settle_window_s):
            return False
        return bool(old) and abs(sums[1] / len(new) - sums[0] / len(old)) < p.settle_n
    return until


def plan(p: Params, rig: RigInfo):
    speed, d = p.speed_mm_s / 1e3, p.approach_mm / 1e3
    x = rig.x_mid
    # the last move into each hold is a compression stroke (from below) or an extension
    # stroke (from above): the seal holds the friction of that direction
    for direction, sign in (("compression stroke", +1), ("extension stroke", -1)):
        for xp in positions(p, rig):
            start = xp - sign * d
            for target, what in ((start, "approach"), (xp, "settle")):
                T, f = _move(x, target, speed)
                yield Segment(f"{what} {xp * 1e3:.1f} mm {direction}", {}, T, f, False)
                x = target
            yield Segment(f"hold {xp * 1e3:.1f} mm {direction}", {"x_mm": round(xp * 1e3, 3), "approach": direction},
                          p.dwell_max_s, lambda t, xp=xp: xp, True, settled(p), kind="hold")
    T, f = _move(x, rig.x_mid, speed)
    yield Segment("return to mid-stroke", {}, T, f, False)
