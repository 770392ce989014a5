"""The model that needs no damper description (`dyno identify` without --damper writes it as
RECORDING.minimal.json): per-direction valve curves, a polytropic gas force and sliding
friction (models/diagnose/candidates.py, eqs 3.30, 3.19, 3.3), with the effects the
diagnosis accepted on that recording, read back so that `check` and `report` can use it as
a reference along any recording's motion. SI: m, m/s, N.

An effect's form may be built on the recording it was fitted on (a spline's knots along its
stroke, the mean of an auxiliary channel it scales): a model with effects names that
recording (`source`) and is evaluated along a whole recording at once (`along`)."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from models.damper import DamperError, read_text
from models.damper import load as load_damper
from models.diagnose.candidates import EFFECTS, VALVES, Minimal, Model
from models.diagnose.data import DiagnoseError, prepare

KIND = "minimal"  # the JSON's "model"
NEEDED = VALVES + ("G0", "L", "F_c")


@dataclass
class MinimalModel:
    name: str
    parameters: dict  # {name: value in SI}
    x_mid_m: float | None = None  # the gas force's reference position [m]; None: the motion's mean
    effects: list = field(default_factory=list)  # the diagnosis's effect ids (candidates.EFFECTS), in order
    source: list = field(default_factory=list)  # the recordings the effects were fitted on (paths)
    identified_on: dict = field(default_factory=dict)  # envelope(): the motion it was fitted on ({}: not said)

    def force(self, x, v):
        """Force [N] along displacement x [m] and velocity v [m/s] (compression positive):
        the diagnosis's baseline with these values (candidates.Minimal)."""
        x, v = np.asarray(x, float), np.asarray(v, float)
        Fd, Fg, Ff, _ = Minimal(SimpleNamespace(x=x), self.x_mid_m).parts(None, self.parameters, x, v, 0.0)
        return Fd + Fg + Ff

    def simulate(self, t, x, v, T=None):
        """The force along measured motion, shaped as a full model's simulation (.force)."""
        return SimpleNamespace(force=self.force(x, v))

    def along(self, fitted_on, recording, smoothing=None):
        """(t [s], force [N]) along a recording's prepared motion (models/diagnose/data.py),
        the effects included, through the moving average its source applied (smoothing:
        records/source_filter.py); fitted_on and recording: (channels, events) of the source
        (None without effects) and of the recording. DamperError when the recording lacks
        what an effect reads."""
        try:
            d = prepare(*recording, smoothing=smoothing)
            ref = d if fitted_on is None else prepare(*fitted_on)
            model = Model(ref, self.effects, base=Minimal(ref, self.x_mid_m))
            return d.t, model.force(d, self.parameters)
        except DiagnoseError as e:
            raise DamperError(f"{self.name}: {e}") from None
        except KeyError as e:  # an effect's auxiliary channel or temperature
            raise DamperError(f"{self.name}: its effects read {e}, which the recording does not carry") from None


def load(path) -> MinimalModel:
    """A minimal model's JSON; DamperError names what is wrong with it."""
    try:
        doc = json.loads(read_text(Path(path)))
        values = {k: float(doc["parameters"][k]["value"]) for k in NEEDED}
    except KeyError as e:
        raise DamperError(f"{Path(path).name}: not a minimal model: no parameter {e}") from None
    except (TypeError, ValueError) as e:
        raise DamperError(f"{Path(path).name}: not a minimal model ({e})") from None
    if not all(np.isfinite(list(values.values()))):
        raise DamperError(f"{Path(path).name}: a parameter is not a finite number")
    x_mid = doc.get("x_mid_m")
    effects = [str(e) for e in doc.get("effects", [])]
    unknown = [e for e in effects if e.split(":")[0] not in EFFECTS]
    if unknown:
        raise DamperError(f"{Path(path).name}: effects not in this version's catalogue: {', '.join(unknown)}")
    try:
        values.update({k: float(p["value"]) for k, p in doc["parameters"].items() if k not in values})
    except (TypeError, ValueError, KeyError) as e:
        raise DamperError(f"{Path(path).name}: an effect's parameter is not a number ({e})") from None
    return MinimalModel(Path(path).name, values, None if x_mid is None else float(x_mid), effects,
                        [str(Path(path).parent / s) for s in doc.get("source", [])] if effects else [],
                        doc.get("identified_on") if isinstance(doc.get("identified_on"), dict) else {})


REACH = 0.05  # a run this share beyond the envelope a model was identified on is outside it


def envelope(d) -> dict:
    """The motion a model was fitted on (a diagnosis's Data): its sine segments' frequencies
    [Hz] and amplitudes [m] (lowest, highest; None without a periodic segment) and its top
    speed [m/s]: where its force was measured, not extrapolated."""
    seg = [(f, 0.5 * float(np.ptp(d.x[d.segment == i]))) for i, (_, f) in enumerate(d.segments)
           if f is not None and np.any(d.segment == i)]
    span = (lambda a: [float(min(a)), float(max(a))] if a else None)
    return {"freq_hz": span([f for f, _ in seg]), "amplitude_m": span([a for _, a in seg]),
            "speed_m_s": float(np.max(np.abs(d.v))) if len(d.v) else 0.0}


def _span(lo, hi, k=1.0) -> str:
    return f"{k * lo:.3g}" if f"{k * lo:.3g}" == f"{k * hi:.3g}" else f"{k * lo:.3g}-{k * hi:.3g}"


def identified_on_sentence(identified_on: dict) -> str:
    """Where a model was measured (envelope), in words."""
    f, a, top = (identified_on.get(k) for k in ("freq_hz", "amplitude_m", "speed_m_s"))
    parts = ([f"{_span(*f)} Hz"] if f else []) + ([f"amplitudes {_span(*a, 1e3)} mm"] if a else []) \
        + ([f"speeds to {1e3 * top:.3g} mm/s"] if top else [])
    return f"identified on {', '.join(parts)}: beyond, its force is extrapolated" if parts else ""


def outside(identified_on: dict, freqs_hz, amplitudes_m, speed_m_s) -> str:
    """The sentence saying where a run's motion lies outside what a model was identified on
    (envelope), or "": there its force is the model's extrapolation, not a measurement."""
    out = []
    for key, values, unit, k in (("freq_hz", freqs_hz, "Hz", 1.0), ("amplitude_m", amplitudes_m, "mm", 1e3)):
        lo, hi = identified_on.get(key) or (None, None)
        far = sorted({round(k * v, 3) for v in values if lo is not None and np.isfinite(v) and not
                      lo * (1 - REACH) <= v <= hi * (1 + REACH)})
        if far:
            out.append(f"{', '.join(f'{v:g}' for v in far)} {unit} (it was identified on {_span(lo, hi, k)} {unit})")
    top = identified_on.get("speed_m_s")
    if top and np.isfinite(speed_m_s) and speed_m_s > top * (1 + REACH):
        out.append(f"speeds to {1e3 * speed_m_s:.3g} mm/s (it reached {1e3 * top:.3g} mm/s)")
    return "" if not out else ("outside what the model was identified on, its force is extrapolated there: this "
                               "run's " + "; ".join(out))


def is_minimal(path) -> bool:
    try:  # a FIFO or device named .json is no model: never opened (it would block)
        return Path(path).is_file() and json.loads(Path(path).read_text()).get("model") == KIND
    except (OSError, ValueError, AttributeError):
        return False


def load_reference(name_or_path):
    """A reference model: a minimal model's JSON, or what models.damper.load reads (a
    preset's name or a full damper's JSON)."""
    s = str(name_or_path)
    return load(s) if s.endswith(".json") and is_minimal(s) else load_damper(s)
