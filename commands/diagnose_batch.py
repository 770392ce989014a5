"""`dyno diagnose --batch`: one diagnosis per recording (commands/batch.py), written
as FILE.diagnosis.json, a summary row each."""
from __future__ import annotations

from rig.errors import RigError, UsageError

from commands import batch


def _one(task):
    """(name, JSON result or None, error message or None) of one recording's bytes."""
    name, data, baseline, holdout, screening = task
    from models.damper import DamperError, from_dict
    from models.diagnose import diagnose
    from models.diagnose.data import DiagnoseError
    from views.reports.diagnosis import own_baseline, to_json
    from records import source_filter
    from records.data import drives
    from records.reader import load_recording
    with batch.unpacked(name, data) as path:
        try:
            ch, events, meta = load_recording(path)
            if baseline is None:  # the damper the recording names, if any
                base = own_baseline(meta, holdout)[0]
            else:
                base = None if baseline == "minimal" else (baseline[0], from_dict(baseline[1]))
            res = diagnose(ch, events, progress=lambda s: None, baseline=base, holdout=holdout, drives=drives(meta),
                           smoothing=source_filter.of(meta), screening=screening)
        except (UsageError, RigError, DiagnoseError, DamperError) as e:
            return name, None, str(e).replace(str(path), name)
    return name, to_json(res), None


def _row(name, doc, error):
    if doc is None:
        return {"recording": name, "error": error}
    held = (lambda part, k: doc[part][k])
    return {"recording": name, "error": "", "baseline_nrmse_heldout": held("baseline", "nrmse_heldout"),
            "final_nrmse_heldout": held("final", "nrmse_heldout"), "final_rmse_heldout_N": held("final", "rmse_heldout"),
            "final_r2_heldout": held("final", "r2_heldout"), "accepted": ";".join(doc["accepted"]),
            # what the summary says by name; and what it carries but cannot tell from others
            "named": ";".join(doc["named"]), "cannot_tell_from": ";".join(_untold(doc)),
            "not_proven": ";".join(doc.get("not_proven", [])),
            "may_compensate": ";".join(f"{k}~{'/'.join(v)}" for k, v in doc["may_compensate"].items()),
            "left_over_within_noise": doc["left_over"]["within_noise"]}


def _untold(doc):
    """effect~other/other for each accepted effect the recording cannot tell from its rivals
    or from a flexible stand-in with no mechanism in it."""
    for e in doc["effects"]:
        others = [r["effect"] for r in e.get("rivals", [])] + ([e["stand_in"]["term"]] if e.get("stand_in") else [])
        if others:
            yield f"{e['effect']}~{'/'.join(others)}"


def run(args, baseline):
    """baseline: None (each recording's own damper, else the minimal model), "minimal" or
    (name, damper dict)."""
    args.summary = args.summary or "diagnosis-summary.csv"
    return batch.run(args, _one, (baseline, args.holdout, args.screening), ".diagnosis.json", _row, "diagnose")
