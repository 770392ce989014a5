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
from models.damper import DamperError, SimplifiedDamper
from models.damper import load as load_damper
from models.diagnose import quality
from models.diagnose.data import DiagnoseError
from protocols.app.arguments import BUDGET_S
from protocols.io.files import existing_files, filled, output_folder
from rig.errors import RigError

from protocols.io.reader import load_recording
from protocols.reports.peaks import recorded_damper

NAMES = {"bouc_wen": "hysteresis (Bouc-Wen)", "presliding_friction": "pre-sliding friction",
         "sensor_delay": "a timing offset of the cell", "valve_form": "the valve curve's form"}
# how a finding opens, by its nature (models/diagnose/spec.py NATURES)
# (an open term's or the valve form's sentence opens with what it is)
OPENING = {"physics": "Left out: {name}. ", "cell": "In the cell, not the damper: {name}. ", "form": "", "open": ""}


def _what(step):
    said_already = step.nature in ("open", "form") or step.effect == "interference"
    return (f"depends on {', '.join(step.depends_on)}; {step.character}"
            + ("" if said_already else f"; {step.region}; {_size(step)}"))


def said(effect):
    """An effect id ("aux_channel:aux.x") in words."""
    key = effect.split(":")[0]
    return NAMES.get(key, key.replace("_", " "))


def sentence(step, sample_s=None):
    """An accepted effect in words; sample_s: the recording's sample period [s], below
    which a lag is said as unresolved, never as channels to re-align."""
    e = step.effect
    key = e.split(":")[0]
    text, pname, factor, unit = EFFECTS[key].say
    p, ci = step.parameters, step.ci
    late = ""
    if (pname is None and key != "cavitation") or key == "interference":  # a smooth basis: by where and size
        return text.format(region=step.region, size=_size(step), hz=step.tone_hz or 0.0) + _change(step)
    if key == "cavitation":
        v = min(p["Fcav_c"], p["Fcav_r"])
        vs = f"{v:.0f}"
    elif key == "bouc_wen":
        if ":" in e:  # a channel scales it: the MR story (Spencer's phenomenological model)
            ch = e.split(":", 1)[1]
            aux = (f", as in Spencer's magnetorheological damper model: a yield-stress fluid whose yield force "
                   f"follows {ch}, {p[f'alpha_u:{ch}']:.3g} N per unit, through a first-order lag of "
                   f"{1e3 * p[f'eta:{ch}']:.3g} ms, as an MR damper's follows its coil current, which lags the "
                   f"driver's voltage.")
        else:  # no channel drives it: what gives way in any damper, not an MR story
            aux = (": something stiff that gives way at each reversal, which a valve curve cannot follow around the "
                   "loops (a seal or bush that deforms before it slides, trapped air; a yield-stress fluid only in "
                   "a damper that has one).")
        return text.format(v=f"{p['alpha_bw']:.3g}", xy=f"{1e3 * p['x_y']:.3g}", aux=aux) + _change(step)
    elif key == "aux_channel":
        ch = e.split(":", 1)[1]
        name = f"lag:{ch}"
        vs = f"{p[name] * factor:.1f}"
        return text.format(ch=ch, v=vs, u=unit) + _change(step)
    elif key == "compressibility":
        k = 1.0 / max(p[pname], 1e-30)
        lo, hi = (1.0 / max(c, 1e-30) for c in ci[pname][::-1])
        vs = f"{k / 1e6:.3g} ({max(lo, 0) / 1e6:.3g} to {hi / 1e6:.3g})"
    elif key == "free_play" and p[pname] < 1e-6:
        return (f"The force dips towards zero for less than a sample each time it changes sign: a clearance of "
                f"roughly {p[pname] * 1e6:.2g} um crossed that fast (at this sample rate its size is uncertain by a "
                f"factor of two or three), in the damper's mounts or bearings. Check the rod-end and eye bushes."
                + _change(step))
    else:
        v = p[pname] * factor
        lo, hi = (c * factor for c in ci[pname])
        if key == "sensor_delay":
            late = ("force reading lags the displacement" if v < 0
                    else "displacement reading lags the force")
            # the size of the lag; an interval across zero starts at zero
            v, lo, hi = abs(v), (0.0 if lo * hi < 0 else min(abs(lo), abs(hi))), max(abs(lo), abs(hi))
            if sample_s and v < sample_s * factor:
                return (f"The {late} by {v:.2g} {unit} ({v / (sample_s * factor):.2g} of a sample period): "
                        f"below one sample, unresolved at this rate and no reason to re-align the channels; it "
                        f"may stand for anything that shifts the loop a little in time." + _change(step))
        vs = f"{v:.3g} ({lo:.3g} to {hi:.3g})"
    return text.format(v=vs, u=unit, late=late) + _change(step)


def rivals_sentence(step):
    """An effect the recording cannot tell from others: the group, what they share, the
    one the model carries, and no mechanism's story."""
    names = [said(step.effect)] + [said(e) for e, _, _ in step.rivals]
    group = ", ".join(names[:-1]) + " and " + names[-1]
    ps = ", ".join(f"{said(e)} {p:.2g}" for e, _, p in step.rivals)
    return (f"The recording cannot tell which physics was left out: {group} explain the same misfit about equally "
            f"here (on the held-out blocks none is significantly better than {said(step.effect)}: paired p {ps}). "
            f"What they share: it {_what(step)}. The model carries {said(step.effect)}, the largest gain of the "
            f"group, as a stand-in, not as a finding; `dyno diagnose RECORDING --next` designs the test that "
            f"separates them." + _change(step))


def _size(step):
    return f"{step.size_rms_n:.3g} N RMS, {step.size_peak_n:.3g} N at most"


def _change(step):
    return (f" Held-out error falls from {100 * step.before:.3g} % to {100 * step.after:.3g} % "
            f"of the force range (p = {step.p_value:.2g}).")


def _where(loc):
    return (f"{loc['where']}: {100 * loc['energy_share']:.0f} % of the residual energy in "
            f"{100 * loc['sample_share']:.0f} % of the samples")


def _held(res):
    h = res.holdout
    return "alternate cycles held out" if h == "interleaved" else f"the last {100 * h:.0f} % held out, never chosen on"


def summary(res):
    lines = []
    b = res.baseline
    for line in quality.describe(res.data.flags):
        lines.append(f"Data quality: {line}.")
    lines.append(f"Baseline ({b.name}): held-out error {100 * b.nrmse_heldout:.3g} % of the force range, "
                 f"R^2 {b.r2_heldout:.3f} ({_held(res)}; training {100 * b.nrmse_train:.3g} %); "
                 f"force noise {res.noise_sd:.2f} N ({res.noise_from}).")
    if "k_damping" in b.parameters:  # a damper model as the baseline: what the refit changed
        p = b.parameters
        lines.append(f"Refitted to this recording: damping x{p['k_damping']:.3f}, gas force {p['G0']:.0f} N at the "
                     f"mean position (the model: {b.model_gas_force:.0f} N) and its slope with stroke "
                     f"x{p['k_gas']:.3f}, friction x{p['k_friction']:.3f}.")
    strong = [loc for loc in res.locations if loc["concentration"] > 2.0][:3]
    if strong:
        lines.append("The residual lives " + "; ".join(_where(loc) for loc in strong) + ".")
    for s in res.steps:
        name = said(s.effect)
        if s.replaced_by:
            lines.append(f"Dropped again: {name}. {said(s.replaced_by)} explains its gain as well without it.")
        elif s.compensates:
            why = [f"its parameters trade against those of {said(e)} (correlation {c:.2f})"
                   for e, c in s.trades_with]
            why += [f"changing the form of {said(e)} (its size by direction, with speed, along the stroke or with "
                    f"its own size, or a lag) brings {100 * sh:.0f} % of its gain" for e, sh in s.form_of]
            lines.append(f"Accepted, but may be compensating the form of {', '.join(map(said, s.compensates))}: "
                         f"{name}; {'; '.join(why)}. The gain may be a different form of that effect, not physics "
                         f"of its own." + _change(s))
        elif s.effect in res.described:
            lines.append(f"In {res.described[s.effect]}'s own description, not a fault: {name}. The minimal baseline "
                         f"leaves it out and the damper model has it (`--baseline {res.described[s.effect]}` starts "
                         f"from that model)." + _change(s) + f" ({_what(s)}.)")
        elif s.rivals:
            lines.append(rivals_sentence(s))
        else:
            lines.append(OPENING[s.nature].format(name=name) + sentence(s, float(np.median(res.data.h)))
                         + f" ({_what(s)}.)")
    if res.accepted:
        f = res.final
        lines.append(f"Final: held-out error {100 * f.nrmse_heldout:.3g} % of the force range, RMSE "
                     f"{f.rmse_heldout:.3g} N, R^2 {f.r2_heldout:.3f}, {len(f.parameters)} parameters.")
    lo = res.left_over
    if lo.within_noise:
        lines.append(f"Nothing significant was left out: the held-out residual is within the force noise "
                     f"(p = {lo.p_value:.2g} that it is above it).")
    else:
        left = [loc for loc in res.remaining if loc["concentration"] > 1.5][:2]
        where = ("; it lives " + "; ".join(_where(loc) for loc in left)) if left else ", spread over the whole recording"
        lines.append(f"Still unexplained: {lo.above_noise_rms_n:.3g} N RMS above the force noise on the held-out "
                     f"cycles (p = {lo.p_value:.2g}); no effect or term tried takes it further{where}.")
    for n in res.data.notes:
        lines.append(f"Not assessed: {n}.")
    return "\n".join(lines)


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
        "may_compensate": {s.effect: s.compensates for s in res.steps if s.compensates},
        # each accepted effect or term: what it depends on, where it lives, what kind and how big
        "effects": [{"effect": s.effect, "replaced_by": s.replaced_by} if s.replaced_by else
                    {"effect": s.effect, **{k: getattr(s, k) for k in ("nature", "depends_on", "region", "character",
                                                                       "size_rms_n", "size_peak_n", "tone_hz")},
                     "rivals": [{"effect": e, "gain_noise_variances": g, "paired_p": p} for e, g, p in s.rivals],
                     "in_own_description": res.described.get(s.effect)}
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
        res = diagnose(ch, events, progress=say, baseline=baseline, holdout=args.holdout)
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
                for s in res.steps if not s.replaced_by]
    say(catalogue.add_diagnosis(args.recording, res.baseline.name, res.accepted, findings, res.left_over.within_noise))
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

