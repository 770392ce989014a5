"""`dyno diagnose RECORDING [--baseline minimal|PRESET|FILE.json] [--json] [--report DIR]`: where the
model misses the recording, what physics was left out, and the held-out evidence."""
from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from models.diagnose import diagnose
from models.diagnose import design
from models.diagnose.candidates import EFFECTS
from models.diagnose.words import summary
from models.damper import DamperError, SimplifiedDamper
from models.damper import load as load_damper
from models.diagnose.data import DiagnoseError
from models.recording import drives
from protocols.app.arguments import BUDGET_S
from protocols.io.files import existing_files, filled, output_folder
from rig.errors import RigError

from protocols.io.reader import load_recording
from protocols.reports.peaks import recorded_damper

def to_json(res):
    def num(v):
        return float(v) if np.isfinite(v) else None
    b = res.baseline
    held = ("nrmse_heldout", "rmse_heldout", "r2_heldout")
    return {
        "holdout": res.holdout if res.holdout == "interleaved" else f"tail:{res.holdout:g}",
        "quality": [{"channel": f.channel, "kind": f.kind, "t0": num(f.t0), "t1": num(f.t1), "samples": f.samples,
                     "message": f.message} for f in res.data.flags],
        "baseline": {"name": b.name, "parameters": {k: num(v) for k, v in b.parameters.items()},
                     "nrmse_train": b.nrmse_train, **{k: getattr(b, k) for k in held}},
        "noise_sd": res.noise_sd, "noise_from": res.noise_from,
        "locations": res.locations,
        "remaining": res.remaining,
        "candidates": [{"effect": c.effect, "round": c.round,
                        "parameters": {k: num(v) for k, v in c.parameters.items()},
                        "ci": {k: [num(a), num(z)] for k, (a, z) in c.ci.items()},
                        **{k: getattr(c, k) for k in held}, "p_value": c.p_value,
                        "gain_noise_variances": c.relevance} for c in res.candidates],
        "accepted": res.accepted,
        "named": res.named(),
        "may_compensate": {s.effect: s.compensates for s in res.steps if s.compensates},
        # each accepted effect or term: what it depends on, where it lives, what kind and how big
        "effects": [{"effect": s.effect, "replaced_by": s.replaced_by} if s.replaced_by else
                    {"effect": s.effect, **{k: getattr(s, k) for k in ("nature", "depends_on", "region", "character",
                                                                       "size_rms_n", "size_peak_n", "tone_hz")},
                     "rivals": [{"effect": e, "gain_noise_variances": g, "paired_p": p} for e, g, p in s.rivals],
                     "in_own_description": res.described.get(s.effect),
                     # below the practical size: kept in the model, not named (docs/diagnosis.md)
                     "small": s.small, "gain_noise_variances": s.relevance, "excess_share": s.excess_share,
                     # a flexible surface with no mechanism explained as much: not named
                     "stand_in": {"term": s.stand_in[0], "paired_p": s.stand_in[1]} if s.stand_in else None}
                    for s in res.steps],
        "left_over": dataclasses.asdict(res.left_over),
        "final": {**{k: getattr(res.final, k) for k in held},
                  "parameters": {k: num(v) for k, v in res.final.parameters.items()}},
        "not_assessed": res.data.notes,
        "summary": summary(res),
    }


def report(res, out_dir: Path):
    from protocols.reports.page import Page, save
    from protocols.reports.plots import plt
    out_dir.mkdir(parents=True, exist_ok=True)
    d = res.data
    stages = [("baseline", res.baseline.residual)] + [(f"+ {s.effect}", s.residual_after) for s in res.steps]
    held = res.held_out  # the residual of a fit that never saw the sample: only there
    fig, axes = plt.subplots(len(stages), 3, figsize=(13, 3.2 * len(stages)), squeeze=False)
    for row, (name, r) in zip(axes, stages):
        row[0].set_title(name, loc="left", fontsize=9)  # the stage: a long effect name fits across, not up
        for ax, (xv, lab) in zip(row, [(d.v, "velocity [m/s]"), (d.x * 1e3, "displacement [mm]"), (d.t, "time [s]")]):
            ax.plot(xv[held], r[held], ",", alpha=0.5)
            ax.set_xlabel(lab)
            ax.set_ylabel("held-out residual [N]")
    save(fig, out_dir / "residuals.png")
    base = d.F - res.baseline.residual
    if d.periodic:  # the held-out cycles of the segment with the largest force range
        seg = int(np.argmax([np.ptp(d.F[(d.segment == s) & held]) if np.any((d.segment == s) & held) else -1.0
                             for s in range(len(d.segments))]))
        k = (d.segment == seg) & held
        title = d.segments[seg][0]
    else:  # motion that does not repeat: the first second reported, loops would be a tangle
        t0 = float(d.t[res.reported][0])
        k = res.reported & (d.t >= t0) & (d.t < t0 + 1.0)
        title = f"held out, {t0:.1f}-{t0 + 1.0:.1f} s"
    fig, ax = plt.subplots(1, 3, figsize=(16, 4.5))
    for a, xv, lab in zip(ax, (d.t, d.x * 1e3, d.v), ("time [s]", "displacement [mm]", "velocity [m/s]")):
        a.plot(xv[k], base[k], "C1", lw=0.7, label="baseline")
        a.plot(xv[k], res.final.force[k], "C2", lw=0.7, label="with accepted effects")
        a.plot(xv[k], d.F[k], "k", lw=0.9, label="measured", zorder=3)
        a.set_xlabel(lab)
    ax[0].set_ylabel("force [N]")
    ax[0].legend()
    ax[1].set_title(title)
    save(fig, out_dir / "loops.png")
    page = Page("Diagnosis")
    for line in summary(res).splitlines():
        page.paragraph(line)
    page.figure("Residual maps, before and after each accepted effect", "residuals.png")
    page.figure("Loops", "loops.png")
    page.heading("Candidates")
    page.table(("effect", "round", "held-out error", "p", "gain [noise variances]"),
               [(c.effect, c.round, f"{100 * c.nrmse_heldout:.3f} %", f"{c.p_value:.4f}",
                 f"{c.relevance:+.2f}") for c in res.candidates])
    return page.write(out_dir)


def run(args):
    baseline = None
    if args.baseline != "minimal":
        try:
            model = load_damper(args.baseline)
        except (DamperError, OSError, ValueError) as e:
            raise RigError(f"--baseline {args.baseline}: {e}") from None
        if isinstance(model, SimplifiedDamper):
            raise RigError(f"--baseline {args.baseline}: a simplified model has no gas spring or friction to refit; "
                           f"give a full damper model")
        baseline = (Path(args.baseline).stem, model)
    if getattr(args, "batch", None):
        from models.damper import to_dict
        from protocols.app import diagnose_batch
        return diagnose_batch.run(args, baseline and (baseline[0], to_dict(baseline[1])))
    if args.recording is None:
        raise RigError("diagnose: give a RECORDING, or --batch FILE...")
    if getattr(args, "next", False) and baseline is not None:
        raise RigError("--next designs from the minimal baseline: drop --baseline")
    if args.budget is not None and not getattr(args, "next", False):
        raise RigError("--budget: the rig time of --next's proposals; give --next with it")
    budget = BUDGET_S if args.budget is None else args.budget
    if getattr(args, "next", False):  # the rig config read before the diagnosis, not after it
        from protocols.app import next_test
        limits = next_test.limits(args.rig)
    if args.report:
        output_folder(args.report, existing_files(args.recording, args.baseline), args.overwrite, "--report")
    ch, events, meta = load_recording(args.recording)
    say = (lambda s: print(s, file=sys.stderr)) if not args.json else (lambda s: None)
    try:
        res = diagnose(ch, events, progress=say, baseline=baseline, holdout=args.holdout, drives=drives(meta))
    except (DiagnoseError, DamperError) as e:
        raise RigError(f"{args.recording}: {e}") from None
    own = recorded_damper(meta)
    if own is not None and baseline is None:  # physics the recording's own damper has is no fault of it
        res.described = {s.effect: own.name for s in res.steps
                         if EFFECTS[s.effect.split(":")[0]].described and EFFECTS[s.effect.split(":")[0]].described(own)}
    if args.report:
        with filled(args.report, "--report") as folder:
            page = report(res, folder)
        say(f"report: {Path(args.report) / page.name}")
    from protocols import catalogue
    findings = [{"effect": s.effect, "nature": s.nature, "parameters": {k: float(v) for k, v in s.parameters.items()}}
                for s in res.steps if s.effect in res.named()]
    say(catalogue.add_diagnosis(args.recording, res.baseline.name, res.named(), findings, res.left_over.within_noise))
    props = None
    if getattr(args, "next", False):
        props = design.propose(res, limits, budget)
    if args.json:
        print(json.dumps({**to_json(res), **({"next": next_test.to_json(props)} if props is not None else {})},
                         indent=1))
    else:
        print(summary(res))
        if props is not None:
            print("\n" + next_test.text(props))
        print("\nCandidates (held-out error, p, gain in noise variances):")
        for c in res.candidates:
            print(f"  round {c.round} {c.effect:32s} {100 * c.nrmse_heldout:7.3f} %  p = {c.p_value:<7.2g}"
                  f"{c.relevance:+8.2f}")
    return 0

