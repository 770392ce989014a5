"""`dyno diagnose REC --next [--budget S] [--rig CONFIG]`: the sines that would best tell
apart what the diagnosis could not (models/diagnose/design.py), within the cell's limits,
each with why and the `dyno run` line that records it."""
from __future__ import annotations

from models.diagnose import design
from rig import config as rig_config

from protocols.discover import limits as cell_limits
from protocols.discover import next_plan


def limits(rig=None) -> design.Limits:
    """The cell's limits from its rig config (default: the virtual rig's)."""
    return cell_limits(rig_config.load(rig))


def command(p: design.Proposal, damper=None) -> str:
    """The `dyno run` line that records the proposal's sine as `dyno run discover` would."""
    q = next_plan([p]).params
    return (f"dyno run sine-matrix amplitudes_mm={q.amplitudes_mm[0]:g} freqs_hz={q.freqs_hz[0]:g} "
            f"ramp_cycles={q.ramp_cycles} settle_cycles={q.settle_cycles} record_cycles={q.record_cycles} "
            f"record_s={q.record_s:g}" + (f" --damper {damper}" if damper else ""))


def text(props, diag, limits: design.Limits, budget_s) -> str:
    if not props:
        return "Next test: " + none_why(diag, limits, budget_s)
    total = sum(p.sine.rig_s for p in props)
    lines = [f"Next test ({total:.0f} s of rig time), best first:"]
    for p in props:
        lines += [f"  - {p.why}", f"    {command(p)}"]
    return "\n".join(lines)


def none_why(diag, limits: design.Limits, budget_s) -> str:
    """Why no test is proposed: none is needed, or none the cell can run would tell."""
    rivals = design.rivals(diag)
    if not rivals:
        return "none needed: no two explanations compete and nothing is hinted at under the noise."
    what = "; ".join(r.said for r in rivals)
    if not design.feasible(limits, diag.data):
        return (f"none the cell can run, though explanations compete ({what}): no sine of the design's "
                f"(amplitudes {', '.join(f'{1e3 * a:g}' for a in design.AMPLITUDES_M)} mm) about the recording's "
                f"mean position, {1e3 * float(diag.data.x.mean()):.3g} mm from full extension, keeps within the "
                f"cell's stroke ({1e3 * limits.x_min:g} to {1e3 * limits.x_max:g} mm), its speed and the proven "
                f"envelope (--rig names your cell's limits).")
    return (f"none within {budget_s:g} s of rig time would decide between the explanations that compete ({what}); "
            f"a larger --budget may.")


def to_json(props):
    return [{"kind": "sine", "amplitude_m": p.sine.amplitude_m, "frequency_hz": p.sine.frequency_hz,
             "offset_m": p.sine.offset_m, "rig_s": p.sine.rig_s, "chosen": list(p.rival.chosen),
             "other": list(p.rival.other), "difference_rms_n": p.difference_rms_n, "ratio_to_noise": p.ratio,
             "log_likelihood_ratio_per_s": p.score, "why": p.why, "command": command(p)} for p in props]
