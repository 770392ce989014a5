"""A diagnosis (models/diagnose/) as its JSON document and its report page: residual maps
before and after each accepted effect, and the loops."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from models.diagnose.referees import not_proven
from models.diagnose.words import summary
from records.data import reads_low


def own_baseline(meta, holdout="interleaved"):
    """(baseline, what to say of it) when none is given: the damper the recording says it was
    made with (its own physics in the model from the start, refitted); else, where it declares
    an MR damper's coil and the split is in time, Spencer's MR model (docs/mr-damper.md); else
    None, the minimal model."""
    from models.diagnose.from_spencer import NAME as SPENCER
    from views.reports.peaks import recorded_damper
    from records.data import drives
    own = recorded_damper(meta)
    if own is not None:
        return (own.name, own), (f"baseline: {own.name}, the damper the recording names, refitted (--baseline "
                                 f"minimal for the thesis's minimal model)")
    if not drives(meta, "coil"):
        return None, ""
    if holdout == "interleaved":
        return None, "a coil drive is declared: --holdout tail:F starts from Spencer's MR model (docs/mr-damper.md)"
    return (SPENCER, SPENCER), "baseline: Spencer's MR model, the recording's coil declared (--baseline minimal for the thesis's)"


def described(res, meta):
    """{effect: damper} of the accepted effects the recording's own damper has in its
    description (Effect.described): on the minimal baseline, no fault of that damper."""
    from models.diagnose.candidates import EFFECTS
    from views.reports.peaks import recorded_damper
    own = recorded_damper(meta)
    spec = (lambda e: EFFECTS[e.split(":")[0]].described)
    return {} if own is None else {s.effect: own.name for s in res.steps if spec(s.effect) and spec(s.effect)(own)}


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
                     "nrmse_train": b.nrmse_train, **{k: getattr(b, k) for k in held},
                     "folds_not_converged": b.stopped,
                     # the cell's timing, fitted with it (never a candidate)
                     "cell": [{"effect": c.effect, "parameters": {k: num(v) for k, v in c.parameters.items()},
                               "ci": {k: [num(a), num(z)] for k, (a, z) in c.ci.items()}, "resolved": c.resolved}
                              for c in b.cell]},
        "noise_sd": res.noise_sd, "noise_from": res.noise_from,
        "locations": res.locations,
        "remaining": res.remaining,
        "candidates": [{"effect": c.effect, "round": c.round,
                        "parameters": {k: num(v) for k, v in c.parameters.items()},
                        "ci": {k: [num(a), num(z)] for k, (a, z) in c.ci.items()},
                        **{k: getattr(c, k) for k in held}, "p_value": c.p_value,
                        "gain_noise_variances": c.relevance, "accept_share": c.accept_share,
                        # ruled out by the screen, not fitted (models/diagnose/screen.py): its gain is the screen's
                        "screened": c.screened, "screen_noise_variances": num(c.screen)}
                       for c in res.candidates],
        "accepted": res.accepted,
        "named": res.named(),
        # named in some held-out judgements, fewer than stability.HELD: said so, never as a name
        "at_edge": res.at_edge(),
        "judgements": len(res.judge.variants),
        # lower the held-out error but short of the round's bar: the recording cannot tell
        "not_proven": [c.effect for c in not_proven(res.candidates)[1]],
        "may_compensate": {s.effect: s.compensates for s in res.steps if s.compensates},
        # each accepted effect or term: what it depends on, where it lives, what kind and how big
        "effects": [{"effect": s.effect, "replaced_by": s.replaced_by} if s.replaced_by else
                    {"effect": s.effect, **{k: getattr(s, k) for k in ("nature", "depends_on", "region", "character",
                                                                       "size_rms_n", "size_peak_n", "tone_hz")},
                     "rivals": [{"effect": e, "gain_noise_variances": g, "paired_p": p,
                                 "held_in": s.rival_shares.get(e)} for e, g, p in s.rivals],
                     # how firmly (models/diagnose/stability.py): the share of the held-out
                     # judgements in which it is named, accepted, and a stand-in explains as much
                     "held_in": s.held_in, "accept_share": s.accept_share, "stand_in_share": s.stand_in_share,
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
        "repeats_differ": [{"test": test, "segments": names, "force_range_N": ranges}
                           for test, names, ranges in res.repeats],
        "force_reads_low": reads_low(res.baseline.parameters, res.baseline.sd, float(np.ptp(res.data.F))),
        "summary": summary(res),
    }


def report(res, out_dir: Path):
    from views.reports.page import Page, save
    from views.reports.plots import plt
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
        seg = int(np.argmax([np.ptp(d.F[(d.segment == s) & held]) if f and np.any((d.segment == s) & held) else -1.0
                             for s, (_, f) in enumerate(d.segments)]))
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
               [(c.effect, c.round, "screened out" if c.screened else f"{100 * c.nrmse_heldout:.3f} %",
                 "-" if c.screened else f"{c.p_value:.4f}",
                 f"screened: {c.screen:.2g}" if c.screened else f"{c.relevance:+.2f}") for c in res.candidates])
    return page.write(out_dir)
