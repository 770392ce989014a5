"""What identification returns, and the error it raises."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from models.damper import Damper


@dataclass
class Result:
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
