"""`dyno identify RECORDING... [--damper D] [--out MODEL.json] [--truth PRESET|MODEL.json]
[--json] [--report DIR]`: the damper model from recordings (models/identify/), with the
round-trip comparison against a known damper when --truth is given."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from models import damper as dm
from commands import identify_mr
from commands.arguments import FILE, FOLDER, batch_options, overwrite, writes
from views.identification import clean, description, identified, text
from records import source_filter
from rig.errors import Refused, RigError, UsageError


def add(sub):
    """The `dyno identify` command's arguments."""
    idf = sub.add_parser("identify", help="damper model from recordings (thesis chapter 4)")
    idf.add_argument("recordings", nargs="*", metavar="RECORDING", help="MCAP files (dyno run or dyno import)")
    idf.add_argument("--damper", default=None,
                     help="description giving layout and geometry (default: the damper the recording names)")
    writes(idf, "--out", FILE, default=None, help="model JSON (default: RECORDING.model.json)")
    idf.add_argument("--truth", default=None, help="known damper (preset or JSON) to compare with")
    idf.add_argument("--segment", action="append", metavar="NAME", help="fit these segments only (repeatable)")
    idf.add_argument("--json", action="store_true", help="results as JSON on stdout")
    writes(idf, "--report", FOLDER, default=None, metavar="DIR", help="HTML report with loops and held-out errors")
    idf.add_argument("--keep-poor", action="store_true",
                     help="write a model whose held-out error exceeds the limit docs/cli.md states (refused "
                          "otherwise), marked poor in its name, its JSON and the run index")
    identify_mr.add(idf)
    overwrite(idf, "--out, --report's files and --batch's outputs")
    batch_options(idf, "identify", "FILE.model.json")
    idf.set_defaults(command="identify")


def _one(task):  # --batch: (name, {"model": damper dict, "summary": ...} or None, error or None) of one recording
    from records.reader import load_recording
    name, data, desc, keep_poor = task
    from commands import batch
    with batch.unpacked(name, data) as path:
        try:  # as a single identification: a poor model is refused, or kept marked poor (--keep-poor)
            channels, events, meta = load_recording(path)
            d = dm.from_dict(desc) if desc is not None else description(None, meta)
            res, doc = identified(channels, events, d, [name], lambda m: None, source_filter.of(meta), keep_poor)
        except (UsageError, RigError, Refused, dm.DamperError) as e:
            return name, None, str(e).replace(str(path), name)
    return name, {"model": dm.to_dict(res.damper), "summary": clean(doc)}, None


def _row(name, doc, error):
    if doc is None:
        return {"recording": name, "error": error}
    s = doc["summary"]
    return {"recording": name, "error": "", "heldout_nrmse": s["heldout_nrmse"],
            **{e["name"]: e["value"] for e in s["estimates"]}}


def run(args):
    from records.data import drives, only
    from records.files import existing_files, filled, output_file, output_folder, written
    from records.reader import merged
    if args.model == "spencer" or args.coil or args.holdout:
        return identify_mr.run(args)
    if getattr(args, "batch", None):
        from commands import batch
        if args.recordings or args.out or args.report or args.truth:
            raise UsageError("--batch writes FILE.model.json beside each recording and one summary: RECORDING, "
                           "--out, --report and --truth are for a single identification")
        desc = dm.to_dict(dm.load(args.damper)) if args.damper else None
        args.summary = args.summary or "identify-summary.csv"
        # FILE.model.json is the damper model, as `dyno identify FILE` writes it (dyno report overlays it)
        return batch.run(args, _one, (desc, args.keep_poor), ".model.json", _row, "identify", kept=lambda d: d["model"])
    if not args.recordings:
        raise UsageError("identify: give RECORDING..., or --batch FILE...")
    for p in args.recordings:
        if not Path(p).exists():
            raise UsageError(f"{p}: no such file")
    inputs = existing_files(args.recordings, args.damper, args.truth)
    channels, events, meta = merged(args.recordings)
    if args.segment:
        try:
            events = only(events, args.segment)
        except ValueError as e:
            raise UsageError(f"--segment: {e}") from None
    if not args.damper and not meta.get("damper", {}).get("model"):
        return _minimal(args, channels, events, inputs, drives(meta), source_filter.of(meta))
    out = output_file(args.out or Path(args.recordings[0]).with_suffix(".model.json"), inputs, args.overwrite)
    if args.report:
        output_folder(args.report, inputs, args.overwrite, "--report")
    desc = description(args.damper, meta)
    truth = dm.load(args.truth) if args.truth else None
    say = (lambda m: print(m, file=sys.stderr)) if args.json else print
    res, doc = identified(channels, events, desc, args.recordings, say, source_filter.of(meta), args.keep_poor, truth)
    with written(out) as tmp:
        dm.save(res.damper, tmp)
    if args.report:
        from views.reports.identification import write
        with filled(args.report, "--report") as folder:
            index = write(res, doc, folder)
        say(f"report: {Path(args.report) / index.name}")
    from views import run_index
    values = {e["name"]: e["value"] for e in doc["estimates"] if e["identifiable"]}
    for recording in args.recordings:  # each recording's run index knows the model made of it
        say(run_index.add_model(recording, out, doc.get("heldout_nrmse"), values))
    if args.json:
        print(json.dumps(clean(doc), indent=2))
    else:
        print(text(doc))
        print(f"model: {out}")
    return 0


def _minimal(args, channels, events, inputs, driving, smoothing):
    """No damper named, no --damper: the diagnosis's baseline `minimal` with the effects it
    accepts, judged held out, as JSON (models/minimal.py reads it)."""
    from workers import threads
    from models.diagnose import diagnose
    from models.diagnose.data import DiagnoseError
    from views.identification import MINIMAL_SUFFIX, minimal_doc, minimal_text, poor
    from records.files import output_file, written
    if args.report or args.truth:
        raise UsageError("--report and --truth need a damper description: give --damper PRESET|FILE.json")
    out = output_file(args.out or Path(args.recordings[0]).with_suffix(MINIMAL_SUFFIX), inputs, args.overwrite)
    try:
        found = diagnose(channels, events, drives=driving, jobs=threads.cores(), smoothing=smoothing)
    except (DiagnoseError, dm.DamperError) as e:
        raise UsageError(f"{', '.join(map(str, args.recordings))}: {e}") from None
    base = found.baseline  # the model without effects, fitted and judged on the same cycles
    doc = minimal_doc(args.recordings, args.segment, out, base, found, channels, events)
    doc["poor"] = poor(doc["heldout_nrmse"], events, args.keep_poor, True,
                       found.noise_sd / max(np.ptp(found.data.F), 1e-9)) or None
    with written(out) as tmp:
        tmp.write_text(json.dumps(clean(doc), indent=1))
    from views import run_index
    for recording in args.recordings:
        print(run_index.add_model(recording, out, doc["heldout_nrmse"],
                                  {k: p["value"] for k, p in doc["parameters"].items() if "undetermined" not in p}),
              file=sys.stderr)
    if args.json:
        print(json.dumps(clean(doc), indent=2))
        return 0
    print(minimal_text(doc, found, args.recordings, out))
    return 0


