"""A recording as plain data, and the helpers every analysis of one shares.

channels: {name: (t [s], values [SI])}; events: the recording's events
(records/events.py, docs/recording.md). A segment's kind is written into its params by the runner
(`protocols/plan.py`); recordings made before that are read by inferring it from the
params' keys (`segment_kind`), in this one place.
"""
from __future__ import annotations

import json
import re
import warnings
from typing import NamedTuple

import numpy as np

from records.events import Event, SegmentEnd, SegmentStart

# a recording's channels as load_recording gives them: {name: (t [s], values [SI])}
Channels = dict[str, tuple[np.ndarray, np.ndarray]]

# what a segment of motion is; the analyses choose segments by these
# road: motion a virtual car or a replayed history asks for (hardware-in-the-loop, replay);
# sweep, ramp, dwell, random: what records/segmentation.py finds in another dyno's program
KINDS = ("hold", "low-speed", "sine", "step", "rest", "warm-up", "transition", "road", "sweep", "ramp", "dwell",
         "random")
LOW_SPEED_HZ = 0.5  # recordings without kinds: cycling at or below this was the low-speed test


def segment_kind(params: dict) -> str:
    """The kind of a segment from its params (inferred for recordings without one)."""
    if params.get("kind") in KINDS:
        return params["kind"]
    if "x_mm" in params:
        return "hold"
    if "step_mm" in params:
        return "step"
    if "until_c" in params:
        return "warm-up"
    if "cycles" in params and "freq_hz" in params:
        return "low-speed" if params["freq_hz"] <= LOW_SPEED_HZ else "sine"
    if "target_c" in params:
        return "rest"
    return "transition"


class Span(NamedTuple):
    """A segment of a recording: its name, parameters (with its kind) and time span [s]."""
    name: str
    params: dict
    t0: float
    t1: float

    @property
    def kind(self) -> str:
        return self.params["kind"]


def segments(events: list[Event], measured: bool = True, kinds: tuple | list | None = None) -> list[Span]:
    """The recording's segments: measured ones only by default (measured=False: all), of
    the given kinds if any. params carry their "kind"."""
    out, open_ = [], None
    for e in events:
        if isinstance(e, SegmentStart):
            open_ = e
        elif isinstance(e, SegmentEnd) and open_ is not None and open_.segment == e.segment:
            span = Span(open_.segment, {**open_.params, "kind": segment_kind(open_.params)}, open_.t, e.t)
            if (not measured or open_.measured) and (kinds is None or span.kind in kinds):
                out.append(span)
            open_ = None
    return out


def only(events: list[Event], names: list[str]) -> list[Event]:
    """The events with only the named segments' starts and ends kept (ValueError names an
    unknown segment and the recording's own)."""
    known = [s.name for s in segments(events, measured=False)]
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"no segment {unknown[0]!r} in the recording (its segments: {', '.join(known) or 'none'})")
    return [e for e in events if not isinstance(e, (SegmentStart, SegmentEnd)) or e.segment in names]


# Two sine segments are one test (a test repeated within a run, the same test in runs
# compared) when their amplitudes lie within SAME_TEST_AMPLITUDE of the larger, their
# frequencies within SAME_TEST_FREQUENCY, and their target temperatures within SAME_TEST_K
# (or neither is a temperature test). An imported run's amplitude and frequency are estimated
# from a few cycles (0.252 and 0.254 Hz for one 0.25 Hz test); the steps of a test matrix lie
# far wider apart (12.7 / 6.4 mm, 1 / 4 / 12 Hz, 20 / 45 / 80 C) - a choice, docs/recording.md
SAME_TEST_AMPLITUDE = 0.05
SAME_TEST_FREQUENCY = 0.02
SAME_TEST_K = 2.5


def near(a: float, b: float, share: float) -> bool:
    """a and b within `share` of the larger."""
    return abs(a - b) <= share * max(abs(a), abs(b))


class Test(NamedTuple):
    """What a sine test is, as two runs or two repeats are matched by: never its name,
    which carries an estimate's digits."""
    amplitude_mm: float
    freq_hz: float
    target_c: float | None = None  # a temperature sweep's target [C]

    @classmethod
    def of(cls, params: dict) -> Test:
        target = params.get("target_c")
        return cls(float(params["amplitude_mm"]), float(params["freq_hz"]),
                   None if target is None or not np.isfinite(target) else float(target))

    def same(self, other: Test) -> bool:
        if (self.target_c is None) != (other.target_c is None):
            return False
        return (near(self.amplitude_mm, other.amplitude_mm, SAME_TEST_AMPLITUDE)
                and near(self.freq_hz, other.freq_hz, SAME_TEST_FREQUENCY)
                and (self.target_c is None or abs(self.target_c - other.target_c) <= SAME_TEST_K))

    def __str__(self):
        return f"{self.amplitude_mm:g} mm {self.freq_hz:g} Hz" + ("" if self.target_c is None else
                                                                   f" at {self.target_c:g} C")


def same_tests(tests: list[Test]) -> list[int]:
    """The group of each test in order: the index of the first earlier test it is the same
    test as (Test.same), else its own."""
    out = []
    for i, t in enumerate(tests):
        out.append(next((out[j] for j in range(i) if out[j] == j and tests[j].same(t)), i))
    return out


REPEATS_DIFFER = 0.15  # repeats of one test whose force ranges differ by more were not one damper


def differing_repeats(channels: Channels, events: list[Event]) -> list[tuple[str, list[str], list[float]]]:
    """[(test, [segment names], [force range, N])] of the sine tests run more than once
    (Test.same) whose force ranges (1 to 99 %) differ by more than REPEATS_DIFFER: something
    the recording does not carry changed between them (a coil current, an adjuster, the
    oil's temperature), and one model cannot follow them all."""
    t, F = channels["force"]
    spans = []
    for span in segments(events, kinds=("sine",)):
        k = (t >= span.t0) & (t <= span.t1)
        if k.sum() > 10 and "amplitude_mm" in span.params:
            spans.append((span, float(np.ptp(np.percentile(F[k], [1, 99])))))
    return [(re.sub(r" \(\d+\)$", "", spans[g[0]][0].name), [spans[i][0].name for i in g], [spans[i][1] for i in g])
            for g in differing([Test.of(s.params) for s, _ in spans], [r for _, r in spans])]


def differing(tests: list[Test], ranges: list[float]) -> list[list[int]]:
    """The groups of indices of tests run more than once (Test.same) whose force ranges [N]
    differ by more than REPEATS_DIFFER, in order."""
    groups = {}
    for i, g in enumerate(same_tests(tests)):
        groups.setdefault(g, []).append(i)
    return [g for g in groups.values()
            if len(g) > 1 and max(ranges[i] for i in g) > (1 + REPEATS_DIFFER) * min(ranges[i] for i in g)]


def repeats_sentence(test: str, names: list[str], ranges: list[float]) -> str:
    """A differing_repeats() entry in words (what identify and diagnose say)."""
    return (f"{test} was run {len(names)} times and its force range went from {min(ranges):.0f} to "
            f"{max(ranges):.0f} N: something the recording does not carry changed between them (a coil current, an "
            f"adjuster, warm-up), and one model cannot follow them all")


LOW_SHARE = 0.1  # of the force range: a gas force fitted further below zero is the force's zero, not the fit's bias


def reads_low(parameters: dict, sd: dict, force_range: float, data=None) -> str | None:
    """The sentence saying the force reads low, or None: a gas spring pushes the rod out
    (positive here, eq 3.19), so a gas force below zero is the force's zero moved: a load
    cell's offset the file kept (a raw channel's zero not removed), or its mean removed by
    the source. The gas force is the force at the stroke's turning points (records/
    gas_force.at_turns) of data (t [s], x [m], F [N]) when it has them, else the fit's at
    the motion's mean position (G0 [N]), whose constant a sine cannot tell from x^2 and |v|.
    Said beyond LOW_SHARE of the force range [N] (the UTFSM sine files, their means
    removed, fit G0 within 8 % of theirs either way) and beyond its interval (twice the
    fit's deviation). The recording cannot tell the rest of an offset from a gas force."""
    from records.gas_force import at_turns
    with np.errstate(all="ignore"):
        gas = at_turns(data.t, data.x, data.F) if data is not None else None
    if gas is not None:
        level, top, how = gas.level, gas.level + gas.half_width, (f"the force at the stroke's turning points "
                                                                   f"(friction cancelled) reads {gas.text()}")
    else:
        level = float(parameters.get("G0", np.nan))
        s = (sd or {}).get("G0")
        top = level + 2 * s if s is not None else level
        how = f"the gas force fitted is {level:.0f} N"
    if not (-level > LOW_SHARE * force_range and np.isfinite(top) and top < 0):
        return None
    return (f"{how}, below zero, which no gas spring gives (it pushes the rod out): the force reads at least "
            f"{-top:.0f} N low: a load cell's offset the file kept (raw volts whose zero was not removed?) or its mean "
            f"removed by the source; import it again with --offset force={-top:.0f} (in N; as much in another mapped "
            f"unit) to remove that much (the recording cannot tell the rest of an offset from a gas force)")


def missing(channels: Channels, names: list[str]) -> list[str]:
    """Those of `names` the recording lacks (or has fewer than 2 samples of)."""
    return [n for n in names if n not in channels or len(channels[n][0]) < 2]


GAP_PERIODS = 5  # stamps further apart than this many sample periods: samples are missing there


def gaps(t: np.ndarray, period: float | None = None) -> list[tuple[float, float]]:
    """[(t_start, t_end)] of the gaps in a channel's stamps [s] (period: its sample period,
    the median spacing by default): a stalled loop or lost frames. Interpolating across one
    makes data that was never measured."""
    d = np.diff(t)
    if period is None:
        period = float(np.median(d)) if len(d) else 0.0
    k = np.nonzero(d > GAP_PERIODS * period)[0]
    return [(t[i], t[i + 1]) for i in k]


def at(channels: Channels, name: str, t: np.ndarray) -> np.ndarray:
    """A channel interpolated at times t [s]."""
    tc, vc = channels[name]
    return np.interp(t, tc, vc)


def smoothing_cutoff(h: float, freq: float) -> float:
    """smooth's cut-off [Hz] at sample period h [s] for a test at freq [Hz]."""
    return min(max(10.0 * freq, 20.0), 0.2 / h)


def smooth(y: np.ndarray, h: float, freq: float) -> np.ndarray:
    """The motion a model is driven with: zero-phase low-pass at ten times the test
    frequency (at least 20 Hz, at most 0.4 x Nyquist). The transducers' noise would
    otherwise flip the sign of the model's friction and put noise into its damping
    force, which the measured force does not have. h: sample period [s]."""
    fc = smoothing_cutoff(h, freq)
    if len(y) < 30:
        return y
    from scipy.signal import butter, filtfilt  # here: scipy.signal takes a second to import
    b, a = butter(2, fc * 2 * h)
    return filtfilt(b, a, y)


SIGN_SHARE = 0.2  # net work against the work done either way: below this a recording cannot tell its sign


def other_sign(x: np.ndarray, F: np.ndarray, t: np.ndarray | None = None) -> str | None:
    """The sentence saying a recording is in the other sign convention, or None (flips
    says when and which)."""
    return sign_sentence(flips(x, F, t))


def sign_sentence(said: tuple | None) -> str | None:
    """flips' answer in words, or None."""
    if said is None:
        return None
    work, flip, gas = said
    head = (f"the damper would give back {-work:.3g} J over this recording (the integral of F dx is negative), which "
            f"a passive damper cannot: force or displacement is in the other sign convention (dyno's: both positive "
            f"in compression)")
    if flip:
        return f"{head}; import it again with --flip {flip}: {_why(gas)}"
    return (f"{head}; cannot tell which channel: " + (
        f"the force at the stroke's turning points (friction cancelled) reads {gas.text()} as recorded, which does "
        f"not say its sign" if gas else "the motion has too few turning points to read its gas force") +
        "; settle it with a static push (press the rod in: the force must read positive) or the rod's direction (the "
        "displacement must rise as the rod goes in), then import again with --flip force or --flip displacement")


def _why(gas) -> str:
    """Why flips advises the flip it gives: the gas force at the turning points, beyond its interval."""
    return (f"the force at the stroke's turning points, where the valves give none and friction cancels, reads "
            f"{gas.text()} as recorded; a gas spring's is above zero (it pushes the rod out, compression positive), "
            f"so the " + ("force is counted the other way" if gas.below_zero else
                          "force is right and the displacement is counted the other way"))


def flips(x: np.ndarray, F: np.ndarray, t: np.ndarray | None = None) -> tuple[float, str, object] | None:
    """(work [J], the flip to give or "" when the recording cannot tell which, the gas force
    read at the turning points: records/gas_force.GasForce or None) when a recording is in
    the other sign convention, or None. A passive damper dissipates: over whole cycles the
    work done on it, the integral of F dx [J], is positive with force and displacement both
    positive in compression (ours). Negative work, a clear share of all the work, means one
    of the two is counted the other way (tension positive, or displacement from the other
    end); dissipation cannot say which. The gas force does: at the turning points
    (gas_force.at_turns) it is the same whichever way the displacement counts, and a gas
    spring's is above zero; beyond its 95 % interval it names the channel, within it
    neither is named. The work of the force's part that depends on position alone (a gas
    spring's: a cubic in x fitted to F) is left out first: on a path that does not close
    (a static test's moves, a run so far) it is energy stored or given back, not
    dissipated. Scale-free: raw volts with positive gains tell the sign as well. t [s]:
    the samples' times (their index without it)."""
    from records.gas_force import at_turns
    x, F = np.asarray(x, float), np.asarray(F, float)
    if len(x) != len(F):
        return None
    t = np.arange(len(x), dtype=float) if t is None else np.asarray(t, float)
    ok = np.isfinite(x) & np.isfinite(F) & np.isfinite(t)
    x, F, t = x[ok], F[ok], t[ok]
    if len(x) < 3:
        return None
    with warnings.catch_warnings(), np.errstate(over="ignore", invalid="ignore"):  # values no sensor gives
        warnings.simplefilter("ignore", np.exceptions.RankWarning)  # a few points: any cubic will do
        try:
            Fd = F - np.polyval(np.polyfit(u := (x - np.mean(x)) / np.ptp(x), F, 3), u) if np.ptp(x) > 0 else F
        except np.linalg.LinAlgError:  # the cubic's fit overflowed (a fuzzed table's 1e308s): no sign from it
            return None
        dW = 0.5 * (Fd[1:] + Fd[:-1]) * np.diff(x)
        W, A = float(np.sum(dW)), float(np.sum(np.abs(dW)))
    if not (np.isfinite(A) and A > 0 and W < -SIGN_SHARE * A):
        return None
    with np.errstate(all="ignore"):
        gas = at_turns(t, x, F)
    flip = "" if gas is None else "force" if gas.below_zero else "displacement" if gas.above_zero else ""
    return W, flip, gas


VELOCITY_FOLLOWS = 0.9  # correlation of a velocity's integral with the displacement: below it nothing is said
VELOCITY_SCALE = 2.0  # the velocity's integral over the displacement by more than this (or less than its inverse)


def velocity_disagrees(t: np.ndarray, x: np.ndarray, v: np.ndarray) -> str | None:
    """The sentence saying a velocity channel [m/s] is not the rate of change of the
    displacement [m] it was recorded with, or None: counted the other way (an LVT wired
    rebound positive) or in another unit. Its integral is compared with the displacement
    (integrating keeps the comparison free of the noise a derivative of the displacement
    would add; a linear drift, an integrated offset, is allowed for)."""
    t, x, v = (np.asarray(a, float) for a in (t, x, v))
    ok = np.isfinite(t) & np.isfinite(x) & np.isfinite(v)
    t, x, v = t[ok], x[ok], v[ok]
    if len(t) < 16 or not np.ptp(x) > 0:
        return None
    s = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))))  # m: the velocity integrated
    basis = np.column_stack([s, np.ones_like(t), t - t[0]])
    with np.errstate(all="ignore"):
        coef = np.linalg.lstsq(basis, x, rcond=None)[0]
        k, r = float(coef[0]), float(np.corrcoef(basis @ coef, x)[0, 1])
    if not abs(r) >= VELOCITY_FOLLOWS or not np.isfinite(k):
        return None
    if k < 0:
        return ("it falls as the displacement rises: the velocity is counted the other way from the displacement "
                "(rebound positive); import it again with --flip velocity")
    if not 1 / VELOCITY_SCALE <= k <= VELOCITY_SCALE:
        return (f"the displacement changes {k:.3g} times as fast as the velocity says: check the velocity's and the "
                f"displacement's units")
    return None


BELOW_EXTENSION_M = 5e-4  # m: a displacement further below zero is not noise about full extension


def below_extension(x: np.ndarray, unit: str = "mm", scale: float = 1e-3) -> str | None:
    """The sentence saying a displacement [m] reads below zero, which measured from full
    extension it cannot, or None: its zero is elsewhere. The --offset it gives is in the
    column's mapped unit (scale: that unit in m)."""
    lo, hi = float(np.nanmin(x)), float(np.nanmax(x))
    if not lo < -BELOW_EXTENSION_M:
        return None
    return (f"it reads {1e3 * lo:.3g} to {1e3 * hi:.3g} mm, below zero, which measured from full extension it cannot: "
            f"its zero is elsewhere (an LVDT zeroed mid-stroke, or the mean removed); --offset displacement="
            f"{-lo / scale:.4g} (in {unit}) puts the most extended reading at zero (full extension may lie further "
            f"out: the recording cannot tell); what reads a position along the damper's stroke (identify --damper) "
            f"needs it")


def sign_problem(channels: Channels) -> str | None:
    """other_sign of a recording's channels {name: (t, values)}: the force on the
    displacement's clock."""
    if "x" not in channels or "force" not in channels or len(channels["x"][0]) < 3:
        return None
    tF, F = channels["force"]
    tx, x = channels["x"]
    return other_sign(x, np.interp(tx, tF, F) if len(tF) > 1 else np.full_like(x, np.nan), tx)


def drives(meta: dict, kind: str = "") -> list[str]:
    """The aux.* channels a recording says drive the damper (its calibration's `drives`:
    an MR coil's current, an adjuster's command), from load_recording's metadata; kind:
    only those whose `drives` starts with it ("coil": an MR damper's coil)."""
    out = []
    for name, text in meta.get("calibration", {}).items():
        try:
            said = json.loads(text).get("drives")
        except (ValueError, AttributeError):
            continue
        if said and said.startswith(kind):
            out.append(name)
    return out
