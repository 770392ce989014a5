"""What a protocol is: typed parameters with the thesis's defaults, a pre-flight check,
and a plan that yields segments of motion. The runner executes the segments.

    @dataclass
    class Params: ...                       # defaults from the thesis
    def check(p, rig) -> [(segment, why skipped)]   # raise ParamError to refuse
    def plan(p, rig) -> Iterator[Segment]
"""
from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass
from typing import Callable

import numpy as np

from rig.errors import UsageError


# predicted force and gas pressure must stay below this share of the rig's limits: the
# damper model is a prediction, and a real damper differs from it
MARGIN = 0.95


class ParamError(UsageError):
    """A protocol parameter that cannot be run; the message names it."""


@dataclass
class Segment:
    name: str
    params: dict
    duration: float  # s; the most it can take when `until` is given
    x: Callable[[float], float]  # seconds into the segment -> setpoint [m]
    record: bool = True  # a measurement (True) or a transition (ramp, wait)
    until: Callable[[dict], bool] | None = None  # ends it early on the readings
    target: tuple[str, float] | None = None  # (reading, value) `until` waits for: a wait of unknown length
    # a cycling that `until` ends early runs on to its next whole cycle of this length [s],
    # so the segment after it starts in phase (no setpoint jump)
    cycle: float | None = None
    # what the motion is (records.data.KINDS), written into the events so analyses
    # choose segments by it and not by their params' keys
    kind: str = "transition"
    # closed loop: an object whose setpoint(t, ts, readings) replaces x on the rig (x stays the
    # prediction the pre-flight checks); optionally channels() -> {name: (t, values)} of
    # its own to record, units {name: unit}, and after() -> (channels, measures) called
    # once the rig is safe
    control: object | None = None


@dataclass(frozen=True)
class Plan:
    """A protocol (its module: NAME, Params, check, plan) with the parameters to run it
    with: what protocols.runner.run_plan executes."""
    module: object
    params: object

    @property
    def name(self):
        return self.module.NAME


# a real-time loop's stall: ticks skipped (a gap over STALL_PERIODS periods) held the setpoint,
# and what the rig measures for SETTLE_S after does not repeat (over the wires, errors 2-3
# times those elsewhere). A closed loop with more than STALLED_SHARE of its ticks there (a
# clean host: 11-17 %) tells more of the host than of the rig
STALL_PERIODS = 1.5
SETTLE_S = 0.01
STALLED_SHARE = 0.2


def after_stall(ts, h, settle_s=SETTLE_S):
    """Which of a closed loop's ticks fall within settle_s after a stall of the control loop
    (ts: each tick's time [s]; h: the loop's period [s])."""
    ts = np.asarray(ts, float)
    stall = np.r_[False, np.diff(ts) > STALL_PERIODS * h]
    since = ts - np.maximum.accumulate(np.where(stall, ts, -np.inf))
    return since < settle_s


def stalled(ts, h):
    """The share of a closed loop's ticks within SETTLE_S after a stall of the control loop."""
    return float(np.mean(after_stall(ts, h))) if len(ts) else 0.0


def said_stalled(m):
    """The words a closed loop's summary adds when its host did not keep real time."""
    share = m.get("stalled", 0.0)
    if share <= STALLED_SHARE:
        return ""
    return f" ({100 * share:.0f} % of its ticks just after a stall of the control loop: this host did not keep real time)"


def drain(log):
    """A closed-loop control's channels() from its log {name: ([t], [values])}, emptied."""
    out = {n: (np.array(t), np.array(v)) for n, (t, v) in log.items()}
    for t, v in log.values():
        t.clear()
        v.clear()
    return out


@dataclass
class RigInfo:
    """What a plan needs to know of the rig and the damper under test (SI)."""
    x_mid: float
    x_min: float
    x_max: float
    v_max: float
    f_max: float
    force_max: float
    T_max: float
    T_ambient: float
    peak_force: Callable[[float], float] | None = None  # damper model: velocity -> |force|
    # damper model: (t, x, v, T or None) -> (force [N], gas pressure [Pa] or None), per sample
    response: Callable | None = None
    gas_max: float = 0.0  # Pa, the rig's gas pressure limit (0: none)
    conductance: float | None = None  # W/K, the damper's heat path to the cell air, if known
    damper: object | None = None  # the damper model (models.damper), if any
    rate_hz: float = 1000.0  # the control loop's rate


def sine_peaks(rig: RigInfo, amplitude, freq, T=None):
    """(peak |force| [N], peak gas pressure [Pa], mean power dissipated [W]) the damper
    model predicts for a steady sine of `amplitude` [m] at `freq` [Hz] about mid-stroke at
    T [K] (None: see RigInfo.response); zeros without a model."""
    import numpy as np
    if rig.response is None:
        return 0.0, 0.0, 0.0
    t = np.linspace(0.0, 1.0 / freq, 257)
    x = rig.x_mid + amplitude * np.sin(2 * np.pi * freq * t)
    v = 2 * np.pi * freq * amplitude * np.cos(2 * np.pi * freq * t)
    force, gas = rig.response(t, x, v, T)
    power = float(np.mean((force * v)[:-1]))  # force and velocity positive in compression
    return float(np.max(np.abs(force))), float(np.max(gas)) if gas is not None else 0.0, power


# a parameter this close to zero or this large, in its unit (mm, Hz, s, C, a count), is a typing mistake
TINY, HUGE = 1e-9, 1e9


def parse(cls, pairs):
    """A Params dataclass from CLI "name=value" strings; lists as comma-separated."""
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    kwargs = {}
    for pair in pairs:
        name, eq, text = pair.partition("=")
        if not eq:
            raise ParamError(f"{pair!r}: parameters are name=value")
        if name not in names:
            raise ParamError(f"{name}: unknown parameter (known: {', '.join(sorted(names))})")
        if name in kwargs:
            raise ParamError(f"{name}: given twice "
                             f"({name}={kwargs[name] if not isinstance(kwargs[name], list) else ','.join(f'{v:g}' for v in kwargs[name])} and {pair})")
        kind = hints[name]
        try:
            if typing.get_origin(kind) in (list, tuple):
                items = text.split(",")
                if not text.strip():
                    raise ParamError(f"{name}: needs at least one value")
                if any(not v.strip() for v in items):
                    raise ParamError(f"{name}: {text!r} has an empty item: give values separated by single commas")
                kwargs[name] = [float(v) for v in items]
            elif kind is bool:
                if text.lower() not in ("true", "false"):
                    raise ParamError(f"{name}: {text!r} is not true or false")
                kwargs[name] = text.lower() == "true"
            elif kind is int:
                try:
                    kwargs[name] = int(text)
                except ValueError:
                    float(text)  # no number at all: said as such below
                    raise ParamError(f"{name}: {text!r} is not a whole number (a count: write it as digits, "
                                     f"such as 2)") from None
            elif kind is str:
                kwargs[name] = text
            else:
                kwargs[name] = float(text)
        except ValueError:
            raise ParamError(f"{name}: {text!r} is not a number") from None
        values = kwargs[name] if isinstance(kwargs[name], list) else [kwargs[name]]
        if kind in (str, bool):
            continue
        if not all(abs(v) < 1e15 if isinstance(v, int) else math.isfinite(v) for v in values):
            raise ParamError(f"{name}: {text[:40]!r} is not a finite number")
        if any(0 < abs(v) < TINY or abs(v) > HUGE for v in values):  # 1e-320 Hz: an
            raise ParamError(f"{name}: {text[:40]!r} is no setting (give 0 or {TINY:g}..{HUGE:g})")  # overflow
    return cls(**kwargs)


def positive(name, values):
    for v in values if isinstance(values, (list, tuple)) else [values]:
        if not v > 0:
            raise ParamError(f"{name}: must be positive, got {v:g}")


def ramp_in(amplitude, freq, cycles, x_mid):
    """A sine whose amplitude grows linearly over `cycles`: no velocity step at start."""
    T = cycles / freq
    return lambda t: x_mid + amplitude * min(t / T, 1.0) * math.sin(2 * math.pi * freq * t)


def as_dict(p):
    return {k: (list(v) if isinstance(v, (list, tuple)) else v) for k, v in dataclasses.asdict(p).items()}


def rig_info(cfg, damper):
    """RigInfo for the plans: the damper's mid-stroke (or the safe position without a
    model), the rig's limits, the damper model's response for the pre-flight check."""
    import numpy as np

    from models.physics.simulate import simulate
    L = cfg.limits
    peak = response = None
    x_mid, x_min, x_max = cfg.safe_position, L["x_min"], L["x_max"]
    ambient = cfg.thermal.get("ambient", 293.15)
    if damper is not None and getattr(damper, "layout", "") != "simplified":
        x_mid = damper.mid_stroke
        # never plan into the damper's own end stops: 2 mm inside its stroke at most
        x_min, x_max = max(x_min, 0.002), min(x_max, damper.geometry.stroke - 0.002)
        temps = (ambient, damper.temperature.T_ref)  # cold or at its reference: the larger force

        def peak_force(v, d=damper):
            r = [simulate(d, np.array([0.0, 1.0]), np.array([d.mid_stroke] * 2), v=np.array([v, -v]),
                          T=T, compressible=False) for T in temps]
            return float(max(np.max(np.abs(x.force)) for x in r))

        def response(t, x, v, T, d=damper):
            """Force and gas pressure along a motion at T [K], or (T None) the worse force
            of cold and reference and the gas of a damper that has not warmed."""
            runs = [simulate(d, t, x, v=v, T=Ti, compressible=False, x_e=d.mid_stroke)
                    for Ti in ((T,) if T is not None else temps)]
            worst = max(runs, key=lambda r: np.max(np.abs(r.force)))
            return worst.force, runs[0].P_gas
        peak = peak_force
    return RigInfo(x_mid, x_min, x_max, L["velocity_max"], L.get("frequency_max", 50.0),
                   L["force_max"], L["temperature_max"], ambient, peak, response, L["gas_pressure_max"],
                   cfg.thermal.get("conductance"), damper, cfg.rate_hz)
