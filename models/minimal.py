"""The model that needs no damper description (`dyno identify` without --damper writes it as
RECORDING.minimal.json): per-direction valve curves, a polytropic gas force and sliding
friction (models/diagnose/candidates.py, eqs 3.30, 3.19, 3.3), read back so that `check`
and `report` can use it as a reference along any recording's motion. SI: m, m/s, N."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from models.damper import DamperError
from models.damper import load as load_damper
from models.diagnose.candidates import VALVES, Minimal

KIND = "minimal"  # the JSON's "model"
NEEDED = VALVES + ("G0", "L", "F_c")


@dataclass
class MinimalModel:
    name: str
    parameters: dict  # {name: value in SI}
    x_mid_m: float | None = None  # the gas force's reference position [m]; None: the motion's mean

    def force(self, x, v):
        """Force [N] along displacement x [m] and velocity v [m/s] (compression positive):
        the diagnosis's baseline with these values (candidates.Minimal)."""
        x, v = np.asarray(x, float), np.asarray(v, float)
        Fd, Fg, Ff, _ = Minimal(SimpleNamespace(x=x), self.x_mid_m).parts(None, self.parameters, x, v, 0.0)
        return Fd + Fg + Ff

    def simulate(self, t, x, v, T=None):
        """The force along measured motion, shaped as a full model's simulation (.force)."""
        return SimpleNamespace(force=self.force(x, v))


def load(path) -> MinimalModel:
    """A minimal model's JSON; DamperError names what is wrong with it."""
    try:
        doc = json.loads(Path(path).read_text())
        values = {k: float(doc["parameters"][k]["value"]) for k in NEEDED}
    except KeyError as e:
        raise DamperError(f"{Path(path).name}: not a minimal model: no parameter {e}") from None
    except (TypeError, ValueError) as e:
        raise DamperError(f"{Path(path).name}: not a minimal model ({e})") from None
    if not all(np.isfinite(list(values.values()))):
        raise DamperError(f"{Path(path).name}: a parameter is not a finite number")
    x_mid = doc.get("x_mid_m")
    return MinimalModel(Path(path).name, values, None if x_mid is None else float(x_mid))


def is_minimal(path) -> bool:
    try:
        return json.loads(Path(path).read_text()).get("model") == KIND
    except (OSError, ValueError, AttributeError):
        return False


def load_reference(name_or_path):
    """A reference model: a minimal model's JSON, or what models.damper.load reads (a
    preset's name or a full damper's JSON)."""
    s = str(name_or_path)
    return load(s) if s.endswith(".json") and is_minimal(s) else load_damper(s)
