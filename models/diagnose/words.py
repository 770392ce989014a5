"""The diagnosis in sentences a damper engineer acts on: each finding opened by what kind of
thing it is, its size and held-out evidence, rivals the recording cannot tell apart, and the
summary (what `dyno diagnose` prints). Arrays and dataclasses in (models/diagnose/result.py),
text out."""
from __future__ import annotations

import numpy as np

from models.diagnose import fitting, quality, stability
from models.diagnose.candidates import EFFECTS
from models.diagnose.referees import bar, not_proven
from models.diagnose.result import Diagnosis, Step
from models.diagnose.spec import ActsOn, Nature
from records.data import reads_low, repeats_sentence

# how a finding opens, by its nature (models/diagnose/spec.py NATURES)
# (an open term's or the valve form's sentence opens with what it is)
OPENING = {"physics": "Left out: {name}. ", "cell": "In the cell, not the damper: {name}. ", "form": "", "open": ""}


def _what(step):
    # a smooth basis's sentence says its own region and size
    said_already = step.nature in (Nature.OPEN, Nature.FORM) or "{size}" in EFFECTS[step.effect.split(":")[0]].say[0]
    return (f"depends on {_on(step)}; {step.character}"
            + ("" if said_already else f"; {step.region}; {_size(step)}"))


def alternatives(step: Step) -> list[str]:
    """The variables a finding's rivals explain it by that it does not (a drift in time that
    an elastic force along the stroke explains as well depends on displacement or on time:
    the recording does not say which). A lag between the channels depends on the motion
    itself, not on the time elapsed."""
    specs = [EFFECTS[e.split(":")[0]] for e, _, _ in step.rivals]
    return [v for v in dict.fromkeys(v for s in specs if s.acts_on != ActsOn.MOTION for v in s.depends_on)
            if v not in step.depends_on]


def _on(step):
    """What a finding depends on: its own variables, or its rivals'. A lag carried in a group
    says its rivals' only: it depends on the motion itself, not on the time elapsed."""
    other = alternatives(step)
    if other and EFFECTS[step.effect.split(":")[0]].acts_on == ActsOn.MOTION:
        return ", ".join(other)
    return ", ".join(step.depends_on) + (f", or on {', '.join(other)}" if other else "")


def said(effect: str) -> str:
    """An effect id (an effect's name, or name:channel for one scaled by a channel) in words."""
    key = effect.split(":")[0]
    return EFFECTS[key].short or key.replace("_", " ")


def sentence(step: Step, sample_s: float | None = None) -> str:
    """An accepted effect in words: its own (Effect.words), else its sentence with its size
    and interval, or for a smooth basis where it lives and how large; sample_s: the
    recording's sample period [s] (a lag below it is said as unresolved)."""
    spec = EFFECTS[step.effect.split(":")[0]]
    own = spec.words(step, sample_s) if spec.words else None
    if own is not None:
        return own + _change(step)
    text, pname, factor, unit = spec.say
    if pname is None:  # a smooth basis: by where and size
        return text.format(region=step.region, size=_size(step), hz=step.tone_hz or 0.0) + _change(step)
    v = step.parameters[pname] * factor
    lo, hi = (c * factor for c in step.ci[pname])
    return text.format(v=f"{v:.3g} ({lo:.3g} to {hi:.3g})", u=unit) + _change(step)


def rivals_sentence(step: Step) -> str:
    """An effect the recording cannot tell from others: the group, what they share, the
    one the model carries, and no mechanism's story."""
    shares = step.rival_shares
    names = [said(step.effect)] + [said(e) + ("" if stability.holds(shares.get(e, 1.0)) else
                                              f" (at the edge: a rival in {stability.of(shares[e], len(step.accept_votes))})")
                                   for e, _, _ in step.rivals]
    group = ", ".join(names[:-1]) + " and " + names[-1]
    ps = ", ".join(f"{said(e)} {p:.2g}" for e, _, p in step.rivals)
    form = [said(e) for e in [step.effect] + [e for e, _, _ in step.rivals] if EFFECTS[e.split(":")[0]].nature == Nature.FORM]
    maybe = (f"; {form[0]} is the baseline's own law reshaped, so it may be no physics left out at all" if form
             else "")
    return (f"The recording cannot tell which physics was left out: {group} explain the same misfit about equally "
            f"here (on the held-out blocks none is significantly better than {said(step.effect)}: paired p {ps}"
            f"{maybe}). "
            f"What they share: it {_what(step)}. The model carries {said(step.effect)}, the largest gain of the "
            f"group, as a stand-in, not as a finding; `dyno diagnose RECORDING --next` designs the test that "
            f"separates them." + _change(step))


def small_sentence(step: Step, span: float) -> str:
    """A significant gain below the practical size: its size, and no mechanism."""
    return (f"Small, not named: a misfit that {said(step.effect)} takes up, {_rms(step, span)} "
            f"({step.relevance:.2g} force-noise variances, {100 * step.excess_share:.0f} % of the held-out error "
            f"above the noise): real on the held-out cycles but too small to say which physics it is; kept in "
            f"the model." + _change(step))


def stand_in_sentence(step: Step, span: float) -> str:
    """A mechanism a flexible model with none in it explains as well: the dependence and
    its size, and no mechanism's name."""
    judge = EFFECTS[step.stand_in[0]]
    on = _on(step) if step.depends_on else "displacement, velocity and direction"
    if "time" in judge.depends_on and "time" not in on:  # a temperature that only rose
        on += ", or on time alone"
    verb = "explains" if len(step.rivals) == 1 else "explain"
    rivals = (f"; {', '.join(said(e) for e, _, _ in step.rivals)} {verb} it about equally too" if step.rivals else "")
    return (f"Not named: the force depends on {on} beyond the baseline, {_rms(step, span)}. "
            f"{judge.what[0].upper() + judge.what[1:]} (a flexible model, no mechanism in it) explains it as well as "
            f"{said(step.effect)} on the held-out cycles (paired p {step.stand_in[1]:.2g} that {said(step.effect)} is "
            f"better){rivals}: this recording cannot tell which mechanism it is. The model carries "
            f"{said(step.effect)} as a stand-in; `dyno diagnose RECORDING --next` designs a test that can tell."
            + _change(step))


def _rms(step, span):
    """A finding's RMS force and its share of the recording's force range."""
    return f"{step.size_rms_n:.3g} N RMS" + (f", {100 * step.size_rms_n / span:.2g} % of the force range" if span > 0
                                             else "")


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


def summary(res: Diagnosis) -> str:
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
    if b.stopped:
        lines.append(f"Not converged: the baseline's fit stopped at its limit of {fitting.MAX_STEPS} steps on {b.stopped} "
                     f"fold{'s' if b.stopped > 1 else ''} of the held-out split (a step still lowered its cost by more "
                     f"than {fitting.FTOL:g} of it): its values are where the search stood.")
    low = reads_low(b.parameters, b.sd, float(np.ptp(res.data.F)), res.data)
    if low:
        lines.append(f"Offset: {low}.")
    lines.append(timing_sentence(res))
    for test, names, ranges in res.repeats:
        lines.append(f"Repeats that differ: {repeats_sentence(test, names, ranges)}; a change in time found below may "
                     f"be that (`dyno identify --segment NAME` fits each alone).")
    found = findings(res)
    if res.accepted:
        f = res.final
        found.insert(len(found) - 1, f"Final: held-out error {100 * f.nrmse_heldout:.3g} % of the force range, RMSE "
                                     f"{f.rmse_heldout:.3g} N, R^2 {f.r2_heldout:.3f}, {len(f.parameters)} parameters.")
    lines += found
    for n in res.data.notes:
        lines.append(f"Not assessed: {n}.")
    return "\n".join(lines)


def timing_sentence(res: Diagnosis) -> str:
    """The recording's one timing figure (Diagnosis.channel_timing) in words, as diagnose, the
    report and prove --on say it."""
    _, fit = res.channel_timing()
    if fit is None:
        return "Timing: force and displacement as stamped (no timing fitted)."
    what = ("the channels' alignment, fitted with the baseline within a tenth of a sample" if fit in res.baseline.cell
            else "a sensor delay, accepted")
    said_ = EFFECTS[fit.effect].words(fit, float(np.median(res.data.h)))
    return f"Timing ({what}): {said_[0].lower()}{said_[1:]}"


def findings(res: Diagnosis) -> list[str]:
    """What the diagnosis found, sentence by sentence: where the residual lives, each
    accepted effect as it is said, and what is left over (summary's middle; the live
    diagnosis's event)."""
    lines = []
    sample_s = float(np.median(res.data.h))
    strong = [loc for loc in res.locations if loc["concentration"] > 2.0][:3]
    if strong:
        lines.append("The residual lives " + "; ".join(_where(loc) for loc in strong) + ".")
    span = float(np.ptp(res.data.F)) if len(res.data.F) else 0.0
    n = len(res.judge.variants) if res.judge else 1
    for s in res.steps:
        name = said(s.effect)
        edge = stability.at_edge(s.held_in)
        if edge:  # before what it is said as: the verdict is not the data's alone
            lines.append(f"At the edge: {name} is named in {stability.of(s.held_in, n)} of the held-out blocks "
                         f"(their boundaries shifted, the bootstrap drawn anew): not a finding, and what is said of "
                         f"it next may change with the last bits of the arithmetic (docs/diagnosis.md).")
        if s.replaced_by:
            lines.append(f"Dropped again: {name}. {said(s.replaced_by)} explains its gain as well without it.")
            continue
        if s.small:
            line = small_sentence(s, span)
        elif s.stand_in:
            line = stand_in_sentence(s, span)
        elif s.compensates:
            why = [f"its parameters trade against those of {said(e)} (correlation {c:.2f})"
                   for e, c in s.trades_with]
            why += [f"changing the form of {said(e)} (its size by direction, with speed, along the stroke or with "
                    f"its own size, or a lag) brings {100 * sh:.0f} % of its gain" for e, sh in s.form_of]
            line = (f"Accepted, but may be compensating the form of {', '.join(map(said, s.compensates))}: "
                    f"{name}; {'; '.join(why)}. The gain may be a different form of that effect, not physics "
                    f"of its own." + _change(s))
        elif s.effect in res.described:
            line = (f"In {res.described[s.effect]}'s own description, not a fault: {name}. The minimal baseline "
                    f"leaves it out and the damper model has it (`--baseline {res.described[s.effect]}` starts "
                    f"from that model)." + _change(s) + f" ({_what(s)}.)")
        elif s.rivals:
            line = rivals_sentence(s)
        else:
            line = OPENING[s.nature].format(name=name) + sentence(s, sample_s) + f" ({_what(s)}.)"
        lines.append(line + (f" Named in {stability.of(s.held_in, n)}." if stability.holds(s.held_in) else ""))
    lo = res.left_over
    if stability.at_edge(lo.within_share):
        lines.append(f"At the edge: what is left is within the force noise in {stability.of(lo.within_share, n)}.")
    if lo.within_noise:
        lines.append(f"Nothing significant was left out: the held-out residual is within the force noise "
                     f"(p = {lo.p_value:.2g} that it is above it).")
    else:
        left = [loc for loc in res.remaining if loc["concentration"] > 1.5][:2]
        where = ("it lives " + "; ".join(_where(loc) for loc in left)) if left else "spread over the whole recording"
        near = short_of_the_bar(res)
        lines.append(f"Still unexplained: {lo.above_noise_rms_n:.3g} N RMS above the force noise on the held-out "
                     f"cycles (p = {lo.p_value:.2g}); {'' if near else 'no effect or term tried takes it further; '}"
                     f"{where}.")
        lines += [near] if near else []
    return lines


def short_of_the_bar(res: Diagnosis) -> str:
    """The "Not proven" sentence of referees.not_proven, or "" if none."""
    tried, near = not_proven(res.candidates)
    if not near:
        return ""
    named = ", ".join(f"{said(c.effect)} to {100 * c.nrmse_heldout:.2f} %" for c in near[:4])
    more = f" and {len(near) - 4} more" if len(near) > 4 else ""
    before = res.steps[-1].after if res.steps else res.baseline.nrmse_heldout
    return (f"Not proven: {len(near)} of the {tried} effects tried lower the held-out error from "
            f"{100 * before:.2f} % ({named}{more}), p = {min(c.p_value for c in near):.2g} at best, "
            f"short of the bar for {tried} tried (p < {bar(tried):.2g}). The recording cannot tell whether any of them "
            f"is real; a longer recording of the same test (more cycles) can.")


def repeats_text(again: dict) -> str:
    """`--repeats N`'s count in words: how often each effect was named, or at the edge."""
    n = again["n"]
    said_ = "; ".join(f"{said(e)} named in {round(s * n)} of {n}, at the edge in {round(again['at_edge'][e] * n)}"
                      for e, s in again["named"].items())
    copies = f"{n - 1} cop{'y' if n == 2 else 'ies'}"
    return (f"Diagnosed {n} times (this recording and {copies} with the force x (1 +- k 1e-9) and other draws): "
            f"{said_ or 'nothing named or at the edge'}.")
