"""`dyno diagnose REC --next [--budget S] [--rig CONFIG]`: the sines that would best tell
apart what the diagnosis could not (models/diagnose/design.py), within the cell's limits,
each with why and the `dyno run` line that records it."""
from __future__ import annotations

import math

from models.diagnose import design
from rig import config as rig_config


def limits(rig=None) -> design.Limits:
    """The cell's limits from its rig config (default: the virtual rig's)."""
    L = rig_config.load(rig).limits
    return design.Limits(L["x_min"], L["x_max"], L["velocity_max"], L["force_max"],
                         L.get("frequency_max", math.inf))


def command(p: design.Proposal, damper=None) -> str:
    """The `dyno run` line that records the proposal's sine."""
    s = p.sine
    cycles = s.cycles - design.SETTLE_CYCLES  # the recorder settles and ramps on its own
    return (f"dyno run sine-matrix amplitudes_mm={1e3 * s.amplitude_m:g} freqs_hz={s.frequency_hz:g} "
            f"record_cycles={cycles}" + (f" --damper {damper}" if damper else ""))


def text(props) -> str:
    if not props:
        return "Next test: none needed: no two explanations compete and nothing is hinted at under the noise."
    total = sum(p.sine.duration_s for p in props)
    lines = [f"Next test ({total:.0f} s of rig time), best first:"]
    for p in props:
        lines += [f"  - {p.why}", f"    {command(p)}"]
    return "\n".join(lines)


def to_json(props):
    return [{"kind": "sine", "amplitude_m": p.sine.amplitude_m, "frequency_hz": p.sine.frequency_hz,
             "offset_m": p.sine.offset_m, "duration_s": p.sine.duration_s, "chosen": list(p.rival.chosen),
             "other": list(p.rival.other), "difference_rms_n": p.difference_rms_n, "ratio_to_noise": p.ratio,
             "log_likelihood_ratio_per_s": p.score, "why": p.why, "command": command(p)} for p in props]
