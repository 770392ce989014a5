"""`dyno identify RECORDING --model spencer [--coil aux.NAME] [--holdout tail:F]`: Spencer's
MR damper model (models/mr/) identified from a recording with the coil's command in it,
judged on the record's last F as published work splits it; written as JSON."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from rig.errors import UsageError

SUFFIX = ".spencer.json"
CHANNEL = {"x": "displacement"}  # a recording's channel names, as an engineer says them


def add(idf):
    """identify's options for the MR model."""
    idf.add_argument("--model", choices=("hydraulic", "spencer"), default="hydraulic",
                     help="spencer: an MR damper's phenomenological model (Spencer 1997; commands/identify_mr.py)")
    idf.add_argument("--coil", default=None, help="spencer: the coil's command channel (default: the one aux channel)")
    idf.add_argument("--holdout", default=None, help="spencer: tail:F, judged on the record's last F (default "
                     "tail:0.15), or none")


def run(args):
    from models.diagnose.quality import at_rail, check, describe, excluded, within
    from models.mr.identify import identify
    from records.data import drives
    from records.files import existing_files, filled, output_file, output_folder, written
    from records.reader import merged
    if args.model != "spencer":
        raise UsageError("--coil and --holdout are for --model spencer")
    if len(args.recordings) != 1 or getattr(args, "batch", None) or args.truth or args.damper:
        raise UsageError("--model spencer: give one RECORDING (no --batch, --truth or --damper)")
    path = args.recordings[0]
    holdout = _tail(args.holdout)  # a bad split named before any file is looked at
    if not Path(path).exists():
        raise UsageError(f"{path}: no such file")
    out = output_file(args.out or Path(path).with_suffix(SUFFIX), existing_files(path), args.overwrite)
    if args.report:
        output_folder(args.report, existing_files(path), args.overwrite, "--report")
    channels, _, meta = merged([path])
    coil = args.coil or _coil(channels, drives(meta))
    for name in ("force", "x", coil):
        if name not in channels:
            raise UsageError(f"{path}: no {CHANNEL.get(name, name)} channel (--model spencer needs force, displacement and the coil's "
                             f"command{'' if args.coil else ': name it with --coil aux.NAME'})")
    t = channels["force"][0]
    on = lambda name: np.interp(t, *channels[name])
    x = on("x")
    xd = on("v") if "v" in channels else np.gradient(x, t)
    # the channels the model reads checked whole; the aux readings for a rail only (a glitch in
    # one the model does not read is no reason to leave a sample out; a rail is: the rig left its range)
    commands = [coil, *drives(meta)]
    reading = lambda n: n.startswith("aux.") and n not in commands
    flags = (check({n: c for n, c in channels.items() if not reading(n)})
             + at_rail({n: c for n, c in channels.items() if reading(n)}))
    judged = ~within(t, excluded(flags))
    say = (lambda m: print(m, file=sys.stderr)) if args.json else print
    if flags:
        say(f"left out of the fit and the judgement: {'; '.join(describe(flags))}")
    command = on(coil)
    fitted = identify(t, x, xd, command, channels["force"][1], holdout, judged, say)
    doc = {"model": "spencer-1997", "recording": str(path), "coil": coil, "holdout_tail": holdout,
           "parameters": {e.name: {"value": e.value, "unit": e.unit, "ci95": list(e.ci), "determined": e.determined}
                          for e in fitted.estimates},
           "train_rmse_N": fitted.train_rmse, "stages": [{"stage": s, "train_rmse_N": r} for s, r in fitted.stages],
           "heldout": None if fitted.held is None else vars(fitted.held)}
    with written(out) as tmp:
        tmp.write_text(json.dumps(doc, indent=1, default=float))
    if args.report:
        from views.reports.mr import write
        with filled(args.report, "--report") as folder:
            write(fitted, t, xd, command, channels["force"][1], judged, folder, Path(path).name)
        say(f"report: {Path(args.report) / 'index.md'}")
    if args.json:
        print(json.dumps(doc, indent=2, default=float))
        return 0
    print(f"Spencer's MR model (1997) on {path}, the coil's command {coil}:")
    print(f"{'parameter':10s} {'value':>12s} {'95 % interval':>27s}  unit")
    for e in fitted.estimates:
        said = f"{e.ci[0]:12.4g} .. {e.ci[1]:<12.4g}" if e.determined else f"{'not determined':>27s}"
        print(f"{e.name:10s} {e.value:12.4g} {said}  {e.unit}")
    print(f"training RMSE {fitted.train_rmse:.1f} N")
    if fitted.held:
        h = fitted.held
        print(f"held out (the last {100 * holdout:g} %, from {h.from_s:.2f} s, {h.samples} samples judged): "
              f"RMSE {h.rmse:.1f} N, R^2 {h.r2:.4f}; {100 * h.worst_share:.0f} % of its squared error in "
              f"{h.worst_s[0]:.2f}-{h.worst_s[1]:.2f} s")
    print(f"model: {out}")
    return 0


def _coil(channels, driving):
    """The coil's command: the one aux channel the recording says drives the damper, else its only aux channel."""
    aux = driving or [n for n in channels if n.startswith("aux.")]
    if len(aux) != 1:
        raise UsageError(f"--model spencer: name the coil's command with --coil (aux channels: "
                         f"{', '.join(n for n in channels if n.startswith('aux.')) or 'none'})")
    return aux[0]


def _tail(text):
    """--holdout tail:F -> F (0 < F < 0.5); none -> 0 (fitted on the whole record)."""
    if text in (None, "none"):
        return 0.0 if text == "none" else 0.15
    try:
        f = float(text.removeprefix("tail:"))
    except ValueError:
        f = float("nan")
    if not text.startswith("tail:") or not 0 < f < 0.5:
        raise UsageError(f"--holdout {text}: give tail:F with 0 < F < 0.5 (the record's last share), or none")
    return f
