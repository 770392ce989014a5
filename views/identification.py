"""A recording's damper model as `dyno identify` writes it: the identification into a
damper description (models/identify/), or, where the recording names none, the model that
needs none (the diagnosis's baseline with the effects it accepts); their JSON documents and
their words."""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from models import damper as dm
from rig.errors import Refused, UsageError

MINIMAL_SUFFIX = ".minimal.json"  # not .model.json: report overlays that as a full damper model


def description(arg, meta):
    """The damper description: --damper, else the one the recording names."""
    if arg:
        return dm.load(arg)
    text = meta.get("damper", {}).get("model")
    if not text:
        raise dm.DamperError("the recording names no damper: give --damper PRESET|FILE.json for its layout and "
                             "geometry")
    return dm.from_dict(json.loads(text))


def model_of(channels, events, desc, names, say, smoothing=None):
    """The identification (models/identify) of a recording's data into the layout and
    geometry of desc, through its source's moving average (smoothing); RigError when
    nothing can be identified."""
    from models.identify import IdentifyError, identify
    if desc.layout == "simplified":
        raise dm.DamperError(f"{desc.name}: a simplified model has no layout or geometry to identify into")
    say(f"identify: {desc.layout} with the geometry of '{desc.name}' (layout, geometry, T0 and T_ref are taken "
        f"from the description; everything else from the data)")
    try:
        res = identify(channels, events, desc, progress=say, smoothing=smoothing)
    except IdentifyError as e:
        raise UsageError(str(e)) from None
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as e:  # a fit that cannot proceed
        raise UsageError(f"identification failed: {e}") from None
    if not any(str(v).startswith("done") for v in res.steps.values()):
        raise UsageError(f"nothing to identify in {', '.join(names)}: no static holds, low-speed or sine "
                       f"segments (no model written)")
    res.damper.name = f"{desc.name}-identified"
    res.damper.description = f"identified by dyno identify from {', '.join(Path(p).name for p in names)}"
    return res


def identified(channels, events, desc, recordings, say, smoothing, keep_poor, truth=None):
    """(identification, its document): model_of, marked poor where its held-out error says so
    and kept (poor), compared with the truth's damper where one is given."""
    res = model_of(channels, events, desc, recordings, say, smoothing)
    said = poor(res.heldout_nrmse, events, keep_poor)
    if said:
        res.damper.name += "-poor"
        res.damper.description += f"; POOR, kept with --keep-poor: {said}"
    doc = {**summary(res), "poor": said or None}
    if truth is not None:
        from models.identify.compare import compare
        T = float(np.mean([s.T for s in res.train + res.test])) if res.train else 293.15
        doc.update(compare(res, truth, T))
    return res, doc


def poor(nrmse, events, keep_poor, minimal=False, noise=None) -> str:
    """"" for a model that predicts what it was not fitted on (held-out error within
    POOR_NRMSE); else the sentence saying it does not, kept with --keep-poor, Refused
    (exit 1, nothing written) without it."""
    from models.identify.result import POOR_NRMSE
    if not (nrmse is not None and math.isfinite(nrmse) and nrmse > POOR_NRMSE):
        return ""
    from models.identify.result import poor_sentence
    said = poor_sentence(nrmse, events, minimal, noise)
    if not keep_poor:
        raise Refused(f"identify: {said}; no model written (--keep-poor writes it, marked poor)")
    return said


def minimal_doc(recordings, segments, out, base, found, channels, events):
    """The minimal model's JSON: the baseline's values, or the diagnosis's final model when it
    accepted effects (their forms built on this recording: `source`)."""
    from models.diagnose import friction_outside_physics, undetermined
    from models.diagnose.candidates import Model
    from models.minimal import envelope
    from records.data import differing_repeats, reads_low
    d = found.data
    # the channels' alignment, fitted with the baseline, goes with the model where the
    # recording resolves it (and no accepted lag took its place): the model is then evaluated
    # along that recording as it was fitted
    model = Model(d, found.cell_found() + found.accepted)
    effects = model.effects
    values = found.final.parameters if found.accepted else base.parameters
    sd = {} if found.accepted else base.sd  # the baseline fit's deviations: not of the final model's values
    unknown = {**friction_outside_physics(model, d, values), **undetermined(model.params, values, sd)}
    fit = found.final if found.accepted else base
    return {"model": "minimal",
            "what": "per-direction valve curves (c1 v + c2 v^2 blended into C v above the crack force Fcr), a "
                    "polytropic gas force G0 with its length L, sliding friction F_c (models/diagnose/candidates.py), "
                    "and the effects the diagnosis accepted; no damper description needed",
            "recordings": [str(p) for p in recordings],
            "effects": effects,
            # of the effects, those the diagnosis named and those at the edge (docs/diagnosis.md, the words)
            "named": found.named(), "at_edge": found.at_edge(),
            # an effect's form is built on the recording it was fitted on (models/minimal.py)
            "source": [os.path.relpath(Path(p).resolve(), Path(out).resolve().parent) for p in recordings]
            if effects else [],
            "parameters": {p.name: {"value": float(values[p.name]), "unit": p.unit,
                                    "sd": finite(sd.get(p.name)),
                                    **({"undetermined": unknown[p.name]} if p.name in unknown else {})}
                           for p in model.params},
            "heldout_nrmse": fit.nrmse_heldout, "heldout_rmse_N": fit.rmse_heldout, "heldout_r2": fit.r2_heldout,
            "baseline_heldout_nrmse": base.nrmse_heldout,
            "held_out": "every other cycle (or block), fitted on the rest",
            "x_mid_m": float(np.mean(d.x)),  # the gas force's reference position [m] (Minimal.x_m)
            "identified_on": envelope(d),
            **({"segments": segments} if segments else {}),
            "repeats_differ": [{"test": test, "segments": names, "force_range_N": ranges}
                               for test, names, ranges in differing_repeats(channels, events)],
            "force_reads_low": reads_low(values, sd, float(np.ptp(d.F)), d)}


def finite(x):
    return None if x is None or not math.isfinite(x) else float(x)


def minimal_text(doc, found, recordings, path) -> str:
    """What `dyno identify` says of a minimal model (doc, of minimal_doc) written to path."""
    from records.data import repeats_sentence
    base, out = found.baseline, []
    if doc["poor"]:
        out.append(f"POOR MODEL, kept with --keep-poor: {doc['poor']}")
    if doc["force_reads_low"]:
        out.append(f"note: {doc['force_reads_low']}")
    for r in doc["repeats_differ"]:
        out.append(f"note: {repeats_sentence(r['test'], r['segments'], r['force_range_N'])}; fit each alone "
                   f"with --segment NAME ({'; '.join(r['segments'])})")
    from models.diagnose.words import said
    from models.minimal import identified_on_sentence
    timing = "".join(f", with {said(e)}" for e in doc["effects"] if e in found.cell_found())
    names = "the recordings name" if len(recordings) > 1 else "the recording names"
    out.append(f"identify: {names} no damper: the model that needs no description{timing}, held out by "
               f"cycles: {100 * base.nrmse_heldout:.2f} % of the force range (R^2 {base.r2_heldout:.3f})")
    if found.accepted:
        from models.diagnose.candidates import EFFECTS
        sizes = {e: EFFECTS[e.split(":")[0]].estimate for e in found.accepted}
        shown = [e + (f" (its {sizes[e]} not measured)" if "undetermined" in doc["parameters"].get(sizes[e], {})
                      else "") for e in found.accepted]
        out.append(f"  with the effects the diagnosis accepts ({', '.join(shown)}): "
                   f"{100 * doc['heldout_nrmse']:.2f} % (R^2 {doc['heldout_r2']:.3f})")
    for k, p in doc["parameters"].items():
        known = (f"  undetermined: {p['undetermined']}" if "undetermined" in p
                 else f"  +- {p['sd']:.3g}" if p["sd"] is not None else "")
        out.append(f"  {k:14s} {p['value']:12.5g} {p['unit']:10s}{known}")
    out.append(f"  {identified_on_sentence(doc['identified_on'])}")
    out.append(f"model: {path}")
    return "\n".join(out)


def summary(res):
    from models.identify.parameters import at_bounds
    return {"steps": res.steps,
            "estimates": [{"name": e.name, "value": e.value, "ci_low": e.ci_low, "ci_high": e.ci_high,
                           "unit": e.unit, "identifiable": e.identifiable, "note": e.note} for e in res.estimates],
            "correlated": [{"a": a, "b": b, "rho": r} for a, b, r in res.correlated],
            "heldout": [{"segment": n, "nrmse": e} for n, e in res.heldout],
            "heldout_nrmse": res.heldout_nrmse,
            # a fit that ran into its declared range: held there, not measured
            "at_bound": [{"parameter": n, "value": v, "range": list(r), "unit": u, "bound": end}
                         for n, v, r, u, end in at_bounds(res.damper)]}


def clean(o):
    """JSON has no NaN or infinity: null instead."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [clean(v) for v in o]
    if isinstance(o, (np.floating, np.integer)):
        return clean(o.item())
    return o


def text(doc):
    from models.identify.parameters import bound_sentence
    from views.reports.page import number
    lines = ["steps:"] + [f"  {k:10s} {v}" for k, v in doc["steps"].items()]
    if "parameters" in doc:
        lines.append("parameter                               identified        truth   error   95 % interval")
        for r in doc["parameters"]:
            err = "-" if r["rel_error"] is None else f"{100 * r['rel_error']:+.1f}%"
            ci = "not identifiable" if not r["identifiable"] else f"{number(r['ci_low'])} .. {number(r['ci_high'])}"
            lines.append(f"  {r['name']:36s} {number(r['identified']):>12s} {number(r['truth']):>12s} {err:>7s}   {ci}")
        c = doc["curve"]
        lines.append(f"peak force-velocity curve {c['speeds'][0]:g}-{c['speeds'][-1]:g} m/s at "
                     f"{c['T'] - 273.15:.0f} C: largest error {100 * c['max_rel_error']:.1f} %")
        if c.get("max_rel_error_tested") is not None:
            ts = c["tested_speed"]
            lines.append(f"  within the recording's speeds (compression to {ts['compression']:.2f} m/s, rebound to "
                         f"{ts['rebound']:.2f} m/s; beyond them the model extrapolates): "
                         f"{100 * c['max_rel_error_tested']:.1f} %")
    else:
        lines.append("parameter                               value           95 % interval")
        for e in doc["estimates"]:
            ci = f"not identifiable ({e['note']})" if not e["identifiable"] else \
                f"{number(e['ci_low'])} .. {number(e['ci_high'])} {e['unit']}"
            lines.append(f"  {e['name']:36s} {number(e['value']):>12s}   {ci}")
    for c in doc["correlated"]:
        lines.append(f"strongly correlated: {c['a']} and {c['b']} (rho {c['rho']:+.2f})")
    lines += [bound_sentence(b) for b in doc.get("at_bound", [])]
    lines.append(f"held-out loop NRMSE: {100 * doc['heldout_nrmse']:.2f} % (mean over "
                 f"{len(doc['heldout'])} segments never used for fitting)" if doc["heldout"] else
                 "held-out loop NRMSE: none (too few sine segments to hold one out: the fit is not validated; "
                 "record more amplitudes or frequencies)")
    return "\n".join(lines)
