"""The standard sequence on one damper, one recording: static, low-speed, the sine
matrix and a temperature sweep (thesis chapter 2), with settings that keep it to a few
minutes on the virtual rig. Each part's parameters are its own protocol's."""
from __future__ import annotations

from dataclasses import dataclass, field

from protocols.library import low_speed, sine_matrix, static, temperature_sweep

NAME = "standard"
PARTS = (static, low_speed, sine_matrix, temperature_sweep)


@dataclass
class Params:
    static_points: int = 7
    low_speed_freqs_hz: list[float] = field(default_factory=lambda: [0.05])
    amplitudes_mm: list[float] = field(default_factory=lambda: [12.7, 6.4, 3.2, 1.6])
    freqs_hz: list[float] = field(default_factory=lambda: [1.0, 2.0, 4.0, 8.0, 16.0])
    targets_c: list[float] = field(default_factory=lambda: [60.0, 45.0, 35.0])


def _parts(p: Params):
    # holds of at least 10 s: long enough to see the gas's heat exchange decay and
    # extrapolate it (identify_static.settled), which the charge estimate needs
    return ((static, static.Params(points=p.static_points, dwell_min_s=10.0)),
            (low_speed, low_speed.Params(freqs_hz=list(p.low_speed_freqs_hz))),
            (sine_matrix, sine_matrix.Params(amplitudes_mm=list(p.amplitudes_mm), freqs_hz=list(p.freqs_hz))),
            (temperature_sweep, temperature_sweep.Params(targets_c=list(p.targets_c))))


def check(p: Params, rig):
    return [s for module, params in _parts(p) for s in module.check(params, rig)]


def plan(p: Params, rig):
    for module, params in _parts(p):
        for seg in module.plan(params, rig):
            seg.params = {**seg.params, "protocol": module.NAME}
            yield seg
