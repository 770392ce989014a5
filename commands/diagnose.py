"""`dyno diagnose RECORDING [--baseline minimal|PRESET|FILE.json] [--json] [--report DIR]`: where the
model misses the recording, what physics was left out, and the held-out evidence."""
from __future__ import annotations

import json
import sys
from pathlib import Path

from models.damper import DamperError, SimplifiedDamper
from models.damper import load as load_damper
from commands.arguments import BUDGET_S, FOLDER, MAX_BUDGET_S, batch_options, holdout, number, overwrite, writes
from rig.errors import UsageError


def add(sub):
    """The `dyno diagnose` command's arguments."""
    dg = sub.add_parser("diagnose", help="where the model misses a recording and what physics was left out")
    dg.add_argument("recording", nargs="?")
    batch_options(dg, "diagnosis", "FILE.diagnosis.json")
    dg.add_argument("--baseline", default=None,
                    help="minimal (the thesis's minimal model, fitted whole), or a damper preset or model JSON, "
                         "refitted (default: the damper the recording names, else minimal); spencer: an MR damper's "
                         "model identified on the past of --holdout tail:F (docs/mr-damper.md)")
    dg.add_argument("--json", action="store_true", help="machine-readable result")
    writes(dg, "--report", FOLDER, metavar="DIR", help="HTML report with residual maps and loops")
    overwrite(dg, "--report's files and --batch's outputs")
    dg.add_argument("--holdout", type=holdout, default="interleaved",
                    help="interleaved (default: alternate cycles or blocks) or tail:FRACTION (a time split: fit on "
                         "the first 1-2F, choose on the next F, report on the last F)")
    dg.add_argument("--next", action="store_true",
                    help="also propose the sines that would best tell apart what it could not (minimal baseline)")
    dg.add_argument("--budget", type=number(0, MAX_BUDGET_S, above=0), default=None, metavar="SECONDS",
                    help="--next: rig time the proposals may take (default 120)")
    dg.add_argument("--rig", default=None, help="--next: rig config whose limits the proposals keep (default virtual)")
    dg.add_argument("--repeats", type=number(1, 50, integer=True), default=1, metavar="N",
                    help="check the verdict by hand: diagnose N copies of the recording, each with its force rescaled "
                         "by 1 +- k 1e-9 and its own bootstrap draws, and say how often each effect is named (N times "
                         "the time; docs/diagnosis.md)")
    dg.add_argument("--no-screen", dest="screening", action="store_false",
                    help="fit every candidate in full, none ruled out by the screen (its values still reported: "
                         "the screen's audit, docs/diagnosis.md)")
    dg.set_defaults(command="diagnose")


def _baseline(name):
    """(name, damper model) of --baseline, or None for the minimal model."""
    if name in (None, "minimal"):
        return None
    if name == "spencer":  # an MR damper's model, identified on the recording itself (models/diagnose/from_spencer.py)
        return name, name
    try:
        model = load_damper(name)
    except (DamperError, OSError, ValueError) as e:
        raise UsageError(f"--baseline {name}: {e}") from None
    if isinstance(model, SimplifiedDamper):
        raise UsageError(f"--baseline {name}: a simplified model has no gas spring or friction to refit; "
                         f"give a full damper model")
    return Path(name).stem, model


def run(args):
    from workers import threads
    from models.diagnose import design, diagnose
    from models.diagnose.data import DiagnoseError
    from models.diagnose.words import repeats_text, summary
    from records import source_filter
    from records.data import drives
    from records.files import existing_files, filled, output_folder
    from records.reader import load_recording
    from views.reports.diagnosis import described, own_baseline, report, to_json
    if getattr(args, "batch", None):
        for flag, given in (("--next", getattr(args, "next", False)), ("--budget", args.budget is not None),
                            ("--report", args.report)):
            if given:  # a batch writes each file's JSON and a summary; the rest is one recording's
                raise UsageError(f"{flag}: not with --batch (`dyno diagnose FILE {flag} ...` does it for one file)")
    baseline = _baseline(args.baseline)
    if getattr(args, "batch", None):
        if args.baseline == "spencer":
            raise UsageError("--baseline spencer: one recording at a time, not with --batch")
        from models.damper import to_dict
        from commands import diagnose_batch
        return diagnose_batch.run(args, baseline and (baseline[0], to_dict(baseline[1])) or args.baseline)
    if args.recording is None:
        raise UsageError("diagnose: give a RECORDING, or --batch FILE...")
    if getattr(args, "next", False) and args.baseline not in (None, "minimal"):
        raise UsageError("--next designs from the minimal baseline: drop --baseline")
    if args.budget is not None and not getattr(args, "next", False):
        raise UsageError("--budget: the rig time of --next's proposals; give --next with it")
    budget = BUDGET_S if args.budget is None else args.budget
    if getattr(args, "next", False):  # the rig config read before the diagnosis, not after it
        from commands import next_test
        limits = next_test.limits(args.rig)
    if args.report:
        output_folder(args.report, existing_files(args.recording, args.baseline), args.overwrite, "--report")
    ch, events, meta = load_recording(args.recording)
    say = (lambda s: print(s, file=sys.stderr)) if not args.json else (lambda s: None)
    if args.baseline is None and not getattr(args, "next", False):  # --next designs from the minimal model
        baseline, said = own_baseline(meta, args.holdout)
        if said:
            say(said)
    kw = dict(baseline=baseline, holdout=args.holdout, drives=drives(meta), jobs=threads.cores(),
              smoothing=source_filter.of(meta), screening=args.screening)
    try:
        res = diagnose(ch, events, progress=say, **kw)
    except (DiagnoseError, DamperError) as e:
        raise UsageError(f"{args.recording}: {e}") from None
    if baseline is None:
        res.described = described(res, meta)
    again = None
    if args.repeats > 1:
        from models.diagnose import repeated
        say(f"repeating the diagnosis on {args.repeats - 1} perturbed copies")
        again = repeated(res, ch, events, args.repeats, **kw)
    if args.report:
        with filled(args.report, "--report") as folder:
            page = report(res, folder)
        say(f"report: {Path(args.report) / page.name}")
    from views import run_index
    named = res.named()
    findings = [{"effect": s.effect, "nature": s.nature, "named": s.effect in named,
                 "parameters": {k: float(v) for k, v in s.parameters.items()}}
                for s in res.steps if s.effect in res.accepted]
    say(run_index.add_diagnosis(args.recording, res.baseline.name, res.accepted, findings, res.left_over.within_noise))
    props = None
    if getattr(args, "next", False):
        props = design.propose(res, limits, budget)
    if args.json:
        print(json.dumps({**to_json(res), **({"next": next_test.to_json(props)} if props is not None else {}),
                          **({"repeats": again} if again else {})}, indent=1))
    else:
        print(summary(res))
        if again:
            print(repeats_text(again))
        if props is not None:
            print("\n" + next_test.text(props, res, limits, budget))
        print("\nCandidates (held-out error, p, gain in noise variances):\n" + _candidates(res.candidates))
    return 0


def _candidates(candidates):
    """One line per candidate tried: its round, held-out error, p and gain, or what its screen gained."""
    return "\n".join(f"  round {c.round} {c.effect:32s}   screened out: a linear step gains {c.screen:.2g}" if c.screened
                     else f"  round {c.round} {c.effect:32s} {100 * c.nrmse_heldout:7.3f} %  p = {c.p_value:<7.2g}"
                     f"{c.relevance:+8.2f}" for c in candidates)

