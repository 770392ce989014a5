"""The moving average a recording's source passed its force and displacement through before
writing the file, as declared at import (`dyno import --smoothed 0.1period`): a model compared
with such a recording is passed through the same filter, or the filter's rounding of the
force at each reversal is fitted as physics (a hysteresis, a lag) whose size then changes
with the test's period, where the filter's does (docs/cli.md, importing).

A centred moving average (MATLAB's movmean): a causal one delays force and displacement
alike, so the model driven by the recorded displacement sees the same delay. The recorded
displacement drives the model as it is: a sine's amplitude is 1.6 % low behind a tenth of a
period's average, which the valve coefficients take up. Its window is a share of each sine
segment's period, or a time [s]."""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

RUN_KEY = "smoothed"  # the recording's run metadata: Smoothing.text()
_FORM = re.compile(r"^\s*([0-9.eE+-]+)\s*(period|periods|s|ms)\s*$")


def unbroken(t: np.ndarray, h: float) -> list[tuple[int, int]]:
    """(first, end) sample of each stretch of times t [s] that no gap longer than 1.5
    samples of h [s] breaks: a filter never averages across a hole."""
    cuts = [0, *(np.flatnonzero(np.diff(t) > 1.5 * h) + 1).tolist(), len(t)]
    return list(zip(cuts[:-1], cuts[1:]))


@dataclass(frozen=True)
class Smoothing:
    width: float  # a share of the test period (per_period), else seconds
    per_period: bool

    def text(self) -> str:
        return f"{self.width:g} period" if self.per_period else f"{self.width:g} s"

    def samples(self, h: float, freq_hz: float | None) -> int:
        """The window in samples at spacing h [s] on a segment of freq_hz (None: motion that
        does not repeat, where a share of a period is no window: 1, no filter)."""
        if self.per_period:
            return 1 if not freq_hz else max(1, int(round(self.width / (freq_hz * h))))
        return max(1, int(round(self.width / h)))

    def reach(self, freq_hz: float) -> float:
        """[s] the window reaches either side of a sample on a test at freq_hz [Hz]: within
        it of a file's ends the source averaged what the file does not hold."""
        return 0.5 * (self.width / freq_hz if self.per_period else self.width)

    def apply(self, y, t, h: float, freq_hz: float | None, stretches=None, whole_cycles=False):
        """y [any unit] on times t [s] through the window, stretch by stretch: a gap longer
        than 1.5 samples starts a new one (the filter never averages across a hole).
        stretches: unbroken(t, h), given where the same times are filtered again and again.
        whole_cycles: y is whole cycles of periodic motion, unbroken: the window reaches past
        an end into the cycle's other end, as the source's reached into the next cycle (held
        at its end value instead, a model's force at a reversal was half a window off the
        source's, and a friction fitted 35 % low on a segment that began at one)."""
        from scipy.ndimage import uniform_filter1d  # not at import: the CLI's parser reads this module
        n = self.samples(h, freq_hz)
        y = np.asarray(y, float)
        if n < 2 or len(y) < 2:
            return y
        out = np.empty_like(y)
        pieces = stretches or unbroken(t, h)
        mode = "wrap" if whole_cycles and len(pieces) == 1 else "nearest"
        for a, b in pieces:
            uniform_filter1d(y[a:b], min(n, b - a), output=out[a:b], mode=mode)
        return out


@dataclass(frozen=True)
class LowPass:
    """A DAQ's low-pass on the force alone (`dyno import --filtered force=butter:2:15Hz`):
    Butterworth or Bessel (phase-normalised) of `order` with its cut-off [Hz], causal
    (the force delayed against the displacement, as a DAQ's filter does: at 15 Hz a
    2nd-order Butterworth delays a 1 Hz force by about 15 ms) or zero-phase (filtered
    forwards and back, as offline post-processing does). The model's force goes through it;
    the recorded displacement drives the model as it is (it was not filtered)."""
    kind: str  # "butter" or "bessel"
    order: int
    cutoff_hz: float
    zero_phase: bool = False
    per_period = False

    def text(self) -> str:
        return f"{self.kind}:{self.order}:{self.cutoff_hz:g}Hz" + (":zero-phase" if self.zero_phase else "")

    def reach(self, freq_hz: float) -> float:
        """0: a DAQ's filter runs from the file's first sample (a zero-phase one's ends are
        the file's too)."""
        return 0.0

    def apply(self, y, t, h: float, freq_hz: float | None = None, stretches=None, whole_cycles=False):
        """y [any unit] on times t [s] through the filter, stretch by stretch (a gap longer
        than 1.5 samples starts a new one, at rest at its first value; stretches as Smoothing's;
        whole_cycles: not used, a DAQ's filter runs from where it started)."""
        from scipy import signal  # not at import: the CLI's parser reads this module
        y = np.asarray(y, float)
        if len(y) < 2 or self.cutoff_hz >= 0.49 / h:
            return y
        design = signal.butter if self.kind == "butter" else signal.bessel
        sos = design(self.order, self.cutoff_hz, fs=1.0 / h, output="sos",
                     **({} if self.kind == "butter" else {"norm": "phase"}))
        out = np.empty_like(y)
        for a, b in stretches or unbroken(t, h):
            if self.zero_phase and b - a > 3 * (2 * len(sos) + 1):
                out[a:b] = signal.sosfiltfilt(sos, y[a:b])
            else:
                out[a:b] = signal.sosfilt(sos, y[a:b], zi=signal.sosfilt_zi(sos) * y[a])[0]
        return out


_LOWPASS = re.compile(r"^\s*(butter|bessel):(\d+):([0-9.eE+-]+)\s*hz(:zero-phase|:causal)?\s*$", re.I)


def parse_filtered(text: str) -> LowPass:
    """'force=butter:2:15Hz' (causal), ':zero-phase' appended for one run forwards and back,
    bessel likewise; ValueError saying the form."""
    channel, _, spec = str(text).partition("=")
    m = _LOWPASS.match(spec)
    if channel.strip() != "force" or not m:
        raise ValueError(f"{text!r}: expected force=butter:ORDER:CUTOFFHz or force=bessel:ORDER:CUTOFFHz, "
                         f"':zero-phase' appended for a filter run forwards and back (e.g. force=butter:2:15Hz)")
    order, fc = int(m.group(2)), float(m.group(3))
    if not (1 <= order <= 8 and np.isfinite(fc) and fc > 0):
        raise ValueError(f"{text!r}: an order of 1 to 8 and a cut-off above 0 Hz")
    return LowPass(m.group(1).lower(), order, fc, (m.group(4) or "").lower() == ":zero-phase")


def parse(text: str) -> Smoothing | LowPass:
    """'0.1period' / '0.1 period' (a share of each sine's period), '20ms' or '0.02s'; or a
    low-pass as the metadata keeps it ('butter:2:15Hz'); ValueError saying the form."""
    if _LOWPASS.match(str(text)):
        return parse_filtered(f"force={text}")
    m = _FORM.match(str(text))
    try:
        width = float(m.group(1)) if m else np.nan
    except ValueError:
        width = np.nan
    if not m or not np.isfinite(width) or width <= 0:
        raise ValueError(f"{text!r}: expected the moving average's width, as a share of the test period "
                         f"(0.1period) or a time (20ms, 0.02s)")
    unit = m.group(2)
    if unit.startswith("period"):
        if width > 1:
            raise ValueError(f"{text!r}: a moving average longer than the test period leaves no cycle")
        return Smoothing(width, True)
    return Smoothing(width * (1e-3 if unit == "ms" else 1.0), False)


def of(meta: dict) -> Smoothing | LowPass | None:
    """The source's filter a recording's metadata (load_recording's) declares, or None."""
    text = meta.get("run", {}).get(RUN_KEY)
    return parse(text) if text else None
