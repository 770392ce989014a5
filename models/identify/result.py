"""What identification returns, and the error it raises."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from models.damper import Damper


@dataclass
class Identified:
    damper: Damper
    estimates: list = field(default_factory=list)  # [Estimate]
    steps: dict = field(default_factory=dict)  # step -> "done ..." | "skipped: ..."
    correlated: list = field(default_factory=list)  # [(name, name, rho)]
    heldout: list = field(default_factory=list)  # [(segment name, nrmse)]
    train: list = field(default_factory=list)  # [Segment]
    test: list = field(default_factory=list)  # [Segment]
    structures: dict = field(default_factory=dict)  # (path, direction) -> (structure, params, K, K fitted)

    def add(self, *estimates):
        """Record estimates; one a later step refines (the compressible fit refits the
        friction's level found at the reversals) replaces the earlier, which its note keeps."""
        for e in estimates:
            old = next((o for o in self.estimates if o.name == e.name), None)
            if old is None:
                self.estimates.append(e)
                continue
            was = f"{old.value:.4g}" + (" (not identifiable)" if not old.identifiable else "")
            e.note = "; ".join(filter(None, [e.note, f"before the compressible fit {was}"]))
            self.estimates[self.estimates.index(old)] = e

    @property
    def heldout_nrmse(self):
        return float(np.mean([e for _, e in self.heldout])) if self.heldout else float("nan")


class IdentifyError(ValueError):
    """The recording cannot give a model (say what is missing)."""


# a model whose error on what it was not fitted on (held-out cycles or segments) exceeds this
# share of the force range is no model: refused, or kept only when asked and marked poor
# (the shared real files' own models hold out 0.15-5 %; a wired run's two-segment fit 50 %)
POOR_NRMSE = 0.10


def poor_sentence(nrmse, events, minimal=False, noise=None) -> str:
    """Why a model with held-out error nrmse [share] is poor, and what the recording lacks:
    its sine tests' amplitudes, frequencies and top speed, or a quieter force when its noise
    (a share of the force range, where known) is most of that error."""
    from records.data import Test, same_tests, segments
    sines = [s for s in segments(events, kinds=("sine",)) if "amplitude_mm" in s.params]
    tests = [Test.of(s.params) for s in sines]
    groups = same_tests(tests)
    amps = same_tests([Test(t.amplitude_mm, 1.0) for t in tests])
    freqs = same_tests([Test(1.0, t.freq_hz) for t in tests])
    top = max((2e-3 * 3.141592653589793 * t.amplitude_mm * t.freq_hz for t in tests), default=0.0)
    held = ("the minimal law misses cycles it was not fitted on" if minimal else
            "the model misses the segments held out of its fit")
    what = (f"the recording holds {len(set(groups))} sine test(s) at {len(set(amps))} amplitude(s) and "
            f"{len(set(freqs))} frequency(ies), to {1e3 * top:.0f} mm/s")
    need = ("a damper description (--damper) or the physics the diagnosis names" if minimal else
            "more amplitudes and speeds, so that every held-out segment lies among fitted ones")
    if noise is not None and noise >= 0.8 * nrmse:
        what = f"the force's noise alone is {100 * noise:.1f} % of its range"
        need = "a quieter force signal (the load cell's wiring, its amplifier's filter) or many more cycles"
    return (f"{held} by {100 * nrmse:.1f} % of the force range (a model must stay within {100 * POOR_NRMSE:g} %); "
            f"{what}: it needs {need}")
