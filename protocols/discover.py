"""The dyno plans its own next test (issue 31): run an opening plan, diagnose what it
recorded, run the sines that best tell apart what the diagnosis could not
(models/diagnose/design.py) on the same cell into the same recording, diagnose again, and
stop when nothing is left unsure or the budget of rig time is spent.

Every round is in the recording as events: a `next_test` per sine (its reason in the
message) before it runs, and a `diagnosis` after each diagnosis (what it named, what it
was unsure of), so the live view, the report and a reader of the file see each round.
Each run has its run_start and run_end; the recording ends with a `verdict` (what was found,
what is still unresolved, why it stopped) and a last run_end, segment "discover", once the
last diagnosis is made.
Between rounds the actuator holds where the last sine left it (mid-stroke).
"""
from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass, field

from records.events import Findings, NextTest, RunEnd, DiscoveryVerdict
from models.diagnose import design, diagnose
from models.diagnose.words import said
from rig.loop import describe
from rig.pacing import normal_priority
from protocols.library import sine_matrix
from protocols.plan import Plan
from protocols.runner import Kept, RunResult, run_plan
from protocols import proven

MAX_ROUNDS = 2  # a design that keeps asking for more would otherwise spend the budget on one rival


@dataclass
class Round:
    accepted: list  # what the diagnosis named, in order
    unsure: list  # the rivals it could not tell apart, in words
    ran: list = field(default_factory=list)  # the sines run next: {amplitude_mm, freq_hz, rig_s, why}
    settled: list = field(default_factory=list)  # rivals of the round before that this round's data decided


@dataclass
class Discovery:
    rounds: list  # [Round], the opening's diagnosis first
    diagnosis: object  # the last Diagnosis (models/diagnose/result.py); None if none could be made
    spent_s: float  # rig time of the sines the design asked for [s]
    runs: list  # [RunResult] of the opening and each round
    verdict: str = ""  # found, unresolved and why it stopped, in sentences (verdict())

    @property
    def result(self) -> RunResult:
        """The runs as one: the last one's ending and measures, every tick counted."""
        last = self.runs[-1]
        return dataclasses.replace(last, ticks=sum(r.ticks for r in self.runs),
                                   overruns=sum(r.overruns for r in self.runs),
                                   duration_s=sum(r.duration_s for r in self.runs),
                                   lateness_s=[x for r in self.runs for x in r.lateness_s],
                                   missed=sum(r.missed for r in self.runs))


def limits(config) -> design.Limits:
    """The cell's limits from its rig config, and the proven envelope: the amplitudes and
    peak speeds of the plan the diagnosis is proven clean on nulls with
    (protocols/proven.toml)."""
    L = config.limits
    plan = proven.opening()[1]
    a_min = 1e-3 * min(plan["amplitudes_mm"])
    a_max = 1e-3 * max(plan["amplitudes_mm"])
    return design.Limits(L["x_min"], L["x_max"], L["velocity_max"], L["force_max"],
                         L.get("frequency_max", math.inf), amplitude_min=a_min,
                         velocity_min=2 * math.pi * min(plan["freqs_hz"]) * a_min, amplitude_max=a_max,
                         velocity_proven=2 * math.pi * max(plan["freqs_hz"]) * a_max)


def next_plan(proposals) -> Plan:
    """The proposals' sines as one plan: each ramped in, settled and recorded as the design
    counted them (design.Sine.rig_s)."""
    return Plan(sine_matrix, sine_matrix.Params(
        amplitudes_mm=[1e3 * p.sine.amplitude_m for p in proposals], freqs_hz=[p.sine.frequency_hz for p in proposals],
        ramp_cycles=design.RAMP_CYCLES, settle_cycles=design.SETTLE_CYCLES, record_cycles=design.MIN_CYCLES,
        record_s=design.MIN_S, paired=True))


def _tell(observers, e):
    """An event to every observer between runs (no run's observer thread is going)."""
    for o in observers:
        try:
            getattr(o, "event", lambda *a: None)(e)
        except Exception as e:  # noqa: BLE001 - a failing observer is reported, the others still told
            print(f"dyno: {type(o).__name__.lower()}: {e}", file=sys.stderr)


def verdict(rounds, stopped, spent_s, budget_s) -> str:
    """What a discovery ends with, as a test engineer reads it."""
    last = rounds[-1] if rounds else Round([], [])
    found = ", ".join(map(said, last.accepted)) or "nothing beyond the baseline"
    unsure = ("; ".join(last.unsure) + ".") if last.unsure else "nothing."
    return (f"Found: {found}. Still unresolved: {unsure} Stopped: {stopped}. Rig time of its own tests: "
            f"{spent_s:.1f} of {budget_s:g} s.")


def discover(opening: Plan, cell, observers=(), budget_s=120.0, say=None, max_rounds=MAX_ROUNDS) -> Discovery:
    """Run `opening` on the cell, then rounds of designed sines within budget_s of rig time.
    say(line): a line per round for the operator."""
    say = say or (lambda line: None)
    kept = Kept()
    observers = [o for o in observers if o is not None] + [kept]
    lim = limits(cell.config)
    runs = [run_plan(opening, cell, observers)]
    rounds, spent, before, tried = [], 0.0, {}, set()
    diag = None
    while True:
        try:
            with normal_priority():  # the cell holds meanwhile: no run's deadline waits for it
                diag = diagnose(kept.arrays(), kept.events,
                                drives=[n for n, c in cell.config.channels.items() if getattr(c, "drives", "")])
            rv = {design.key(r): r for r in design.rivals(diag)}
            last = runs[-1].fault or len(rounds) + 1 > max_rounds
            proposals = [] if last else design.propose(diag, lim, budget_s - spent, tried)
        except Exception as e:  # noqa: BLE001 - what is recorded stays; the dyno stops asking
            why = f"round {len(rounds) + 1}: diagnosis failed: {describe(e)}"
            _tell(observers, Findings(cell.rig.clock(), "", {"round": len(rounds) + 1}, why))
            say(f"{why}; no further tests")
            stopped = f"the diagnosis failed ({describe(e)})"
            break
        now = Round(diag.named(), [r.said for r in rv.values()],
                    settled=[r.said for k, r in before.items() if k not in rv])
        rounds.append(now)
        t = cell.rig.clock()
        _tell(observers, Findings(t, "", {"round": len(rounds), "accepted": now.accepted, "unsure": now.unsure,
                                           "settled": now.settled},
                                   f"round {len(rounds)}: named {', '.join(now.accepted) or 'nothing'}; "
                                   f"unsure of {len(now.unsure)}"
                                   + (f"; settled {len(now.settled)}" if now.settled else "")))
        say(f"round {len(rounds)}: named {', '.join(now.accepted) or 'nothing'}"
            + "".join(f"\n  unsure: {u}" for u in now.unsure) + "".join(f"\n  settled: {s}" for s in now.settled))
        if not proposals:
            stopped = (f"the run ended: {runs[-1].fault}" if runs[-1].fault else
                       f"the round limit of its own tests ({max_rounds})" if last else
                       "nothing was left unsure" if not now.unsure else
                       f"no test separates what is unresolved within the {budget_s - spent:.1f} s of budget left, the "
                       f"cell's limits and the envelope the diagnosis is proven on")
            break
        for p in proposals:
            s = p.sine
            now.ran.append({"amplitude_mm": 1e3 * s.amplitude_m, "freq_hz": s.frequency_hz, "rig_s": s.rig_s,
                            "why": p.why})
            _tell(observers, NextTest(t, f"sine {1e3 * s.amplitude_m:g} mm {s.frequency_hz:g} Hz",
                                      {"round": len(rounds), "amplitude_mm": 1e3 * s.amplitude_m,
                                       "freq_hz": s.frequency_hz, "rig_s": s.rig_s, "chosen": list(p.rival.chosen),
                                       "other": list(p.rival.other), "ratio_to_noise": p.ratio}, p.why))
            say(f"  next: {p.why}")
        spent += sum(p.sine.rig_s for p in proposals)
        tried |= {(design.key(p.rival), p.sine) for p in proposals}
        before = rv
        runs.append(run_plan(next_plan(proposals), cell, observers))
    said = verdict(rounds, stopped, spent, budget_s)
    _tell(observers, DiscoveryVerdict(cell.rig.clock(), "discover",
                             {"found": rounds[-1].accepted if rounds else [],
                              "unresolved": rounds[-1].unsure if rounds else [],
                              "stopped": stopped, "spent_s": spent, "budget_s": budget_s}, said))
    say(f"verdict: {said}")
    # the recording ends as every recording does: with the run's end and how it ended
    fault = runs[-1].fault
    _tell(observers, RunEnd(cell.rig.clock(), "discover", {"rounds": len(rounds), "added_s": spent},
                            fault or "completed"))
    return Discovery(rounds, diag, spent, runs, said)
