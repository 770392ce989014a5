"""The proof on a real recording (`dyno prove --on RECORDING`): each catalogue effect and
each fault of the cell hidden at stated sizes in copies of the user's own file
(models/diagnose/hiding.py), every copy and the untouched one diagnosed, and the file's
detection table: named, in a group, said as a dependence, or missed; the size found
against the size hidden; the smallest size found per effect. Sizes are RMS contributions
in % of the recording's force range (its peak to peak).

A copy counts against its own untouched twin (the heat ramp's copy against the untouched
file with the same ramp): a name the untouched file already carries is the file's own
physics, and the row says so ("also on the untouched").
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.diagnose.hiding import HiddenInFile, catalogue, copy, sized, with_heat

SIZES = (1.0, 3.0)  # % of the force range, RMS: the default ladder
ROUNDS = 4  # the diagnosis's own rounds at most (models.diagnose.diagnose's max_effects)
TAKEN = 0.1  # of the hidden force's mean square: a baseline whose error grew by less took it up


@dataclass(frozen=True)
class CopyTask:
    """One copy to diagnose: the recording's channels with hidden at value (None: untouched)."""
    label: str
    channels: dict
    events: list
    options: dict  # diagnose's keywords (drives, smoothing)
    hidden: str | None = None


@dataclass
class Seen:
    """What the diagnosis of one copy said, picklable: its names, steps and timing."""
    named: list
    steps: list  # [(effect, rivals, depends_on, parameters, size_rms_n)], steps not dropped
    timing: str  # the recording's one timing figure in words (models/diagnose/words.timing_sentence)
    lag_s: float  # the first round's lag candidate [s]: what a hidden lag is measured by against the untouched copy's
    noise_sd: float
    within_noise: bool
    before: float
    after: float
    base: dict  # the baseline's values on this copy (with the cell's alignment)
    not_proven: list = ()  # the last round's candidates short of the bar (referees.not_proven)


@dataclass
class FileRow:
    """One hidden effect at one size, and what the diagnosis of its copy said."""
    hidden: str
    size: float  # % of the force range, RMS
    value: float | None  # in the effect's shown unit; None: it cannot reach this size here
    rms_n: float  # N, RMS added
    outcome: str  # named / in a group / as a dependence / not proven / in the baseline / missed / cannot hide
    said_as: str  # the finding that counts, with its group
    found_value: float | None  # in the shown unit (a lag: against the untouched copy's own, Seen.lag_s)
    also_untouched: bool  # the untouched copy names it already, or holds it in a group
    named: list = ()  # everything the copy's diagnosis named
    steps: list = ()  # Seen.steps of the copy


def diagnose_copy(task: CopyTask) -> Seen:
    """Diagnose one copy (one process: the copies themselves run in parallel)."""
    from models.diagnose import diagnose
    from models.diagnose.candidates import EFFECTS
    from models.diagnose.referees import TIMING, not_proven
    from models.diagnose.words import timing_sentence
    r = diagnose(task.channels, task.events, jobs=1, **task.options)
    steps = [(s.effect, [e for e, _, _ in s.rivals], list(s.depends_on), dict(s.parameters), s.size_rms_n)
             for s in r.steps if not s.replaced_by]
    # a hidden lag's size: a lag accepted, else the first round's lag candidate (a rival or
    # not, it measures the loop's delay, the file's own included: the untouched copy's is taken
    # off), else the model's timing
    tau_of = EFFECTS[TIMING].estimate
    lag = next((c.parameters[tau_of] for c in r.candidates if c.round == 1 and c.effect == TIMING), None)
    tau = next((p[tau_of] for e, _, _, p, _ in steps if e == TIMING), lag if lag is not None else r.channel_timing()[0])
    return Seen(r.named(), steps, timing_sentence(r), float(tau), r.noise_sd, r.left_over.within_noise, r.baseline.nrmse_heldout,
                r.final.nrmse_heldout, dict(r.baseline.parameters), [c.effect for c in not_proven(r.candidates)[1]])


def judged(h: HiddenInFile, seen: Seen, null: Seen, size, value, rms, span) -> FileRow:
    """The row of h hidden at value in a copy the diagnosis saw as seen (null: its untouched
    twin; span: the force range [N]). Missed, it may be said short of the bar ("not
    proven"), or be taken up by the baseline's own refit: its held-out error grew by less
    than TAKEN of the hidden force's square (an oil mass at one frequency is a spring)."""
    found = set(h.found)
    held = {_key(e) for e in null.named}
    steps = {_key(e): (rv, dep, p) for e, rv, dep, p, _ in seen.steps}
    named = [_key(e) for e in seen.named if _key(e) in found]
    group = next(([_key(e), *map(_key, rv)] for e, rv, *_ in seen.steps if found & {_key(e), *map(_key, rv)}), None)
    dep = next((e for e in seen.named if _key(e) not in held
                and set(steps.get(_key(e), ((), (), {}))[1]) & set(h.dependence)), None)
    out, said, est = "missed", "", None
    if named:
        out, said = "named", ", ".join([named[0], *map(_key, steps.get(named[0], ((),))[0])])
        est = _estimate(h, steps.get(named[0], ((), (), {}))[2], seen, null)
    elif group:
        out, said, est = "in a group", ", ".join(group), _estimate(h, {}, seen, null)
    elif dep:
        out, said = "as a dependence", f"{dep} ({', '.join(h.dependence)})"
    elif found & set(map(_key, seen.not_proven)):
        out, said = "not proven", ", ".join(e for e in seen.not_proven if _key(e) in found)
    elif seen.before ** 2 - null.before ** 2 < TAKEN * (rms / span) ** 2:
        out = "in the baseline"
    carried = held | {_key(e) for e, rv, *_ in null.steps for e in [e, *rv]}
    return FileRow(h.name, size, h.shown(value), rms, out, said, est, bool(found & carried), seen.named, seen.steps)


def _key(e):
    """An effect id's catalogue name (bouc_wen:aux.x -> bouc_wen)."""
    return e.split(":")[0]


def _estimate(h: HiddenInFile, params, seen: Seen, null: Seen):
    """The size the diagnosis found, in h's shown unit, where it measures h's own value: a
    lag against the untouched copy's first-round lag (Seen.lag_s; a later force reads negative)."""
    if h.fault == "delay":
        return h.factor * (null.lag_s - seen.lag_s)
    if h.param in params:
        return h.shown(params[h.param])
    return None


def run_on(path, names=None, sizes=SIZES, pool=None, say=lambda s: None, rounds=ROUNDS):
    """(rows, nulls {label: Seen}, force range [N], stopped) of the proof on the recording at
    path; rounds: the diagnoses' rounds at most (the diagnosis's own by default). An
    operator's stop (Ctrl-C, SIGTERM) while the copies are diagnosed keeps the rows done,
    the rest marked "stopped" (stopped True); before, it is raised."""
    from records import source_filter
    from models.diagnose.data import prepare
    from models.physics.simulate import warm as warm_kernels
    from workers.pool import run_all
    from records.data import drives
    from records.reader import load_recording
    ch, ev, meta = load_recording(path)
    options = {"drives": drives(meta), "smoothing": source_filter.of(meta)}
    hidden = catalogue()
    unknown = [n for n in (names or ()) if n not in hidden]
    if unknown:
        raise ValueError(f"{unknown[0]!r}: not something prove --on hides (known: {', '.join(hidden)})")
    chosen = [hidden[n] for n in (names or hidden)]
    heat = with_heat(ch)
    warm = heat is not ch and any(h.temperature for h in chosen)
    say(f"{path}: diagnosing the untouched recording{' (and a copy with the heat ramp)' if warm else ''}")
    told = {**options, "max_effects": rounds}
    nulls = run_all(diagnose_copy, [CopyTask("untouched", ch, ev, told)]
                    + ([CopyTask("untouched, heat ramp", heat, ev, told)] if warm else []), pool, warm=warm_kernels)
    d = prepare(ch, ev, **options)
    base = nulls[0].base
    span = float(np.ptp(d.F))
    tasks, pending = [], []
    for h in chosen:
        src = heat if h.temperature else ch
        dh = prepare(src, ev, **options) if h.temperature else d
        for s in sizes:
            value, rms = sized(h, src, dh, base, s / 100 * span)
            if value is None:
                pending.append((h, s, None, rms))
                continue
            tasks.append(CopyTask(f"{h.name} {s:g} %", copy(h, src, dh, base, value), ev, told, h.name))
            pending.append((h, s, value, rms))
    say(f"{len(tasks)} copies to diagnose")
    seen, stopped = {}, False
    try:
        run_all(diagnose_copy, tasks, pool, progress=True, label="prove --on", names=[t.label for t in tasks],
                warm=warm_kernels, done=seen.__setitem__)
    except KeyboardInterrupt:
        stopped = True
    rows, k = [], 0
    for h, s, value, rms in pending:
        if value is None:
            rows.append(FileRow(h.name, s, None, rms, "cannot hide", f"at most {rms:.3g} N RMS here", None, False))
            continue
        twin = nulls[1] if h.temperature and warm else nulls[0]
        rows.append(judged(h, seen[k], twin, s, value, rms, span) if k in seen else
                    FileRow(h.name, s, h.shown(value), rms, "stopped", "stopped before it was diagnosed", None, False))
        k += 1
    return rows, {"untouched": nulls[0], **({"untouched, heat ramp": nulls[1]} if warm else {})}, span, stopped


def smallest(rows):
    """{hidden: the smallest size [%] found (named, in a group or as a dependence), or None}."""
    out = {}
    for r in rows:
        hit = r.outcome in ("named", "in a group", "as a dependence")
        out.setdefault(r.hidden, None)
        if hit and (out[r.hidden] is None or r.size < out[r.hidden]):
            out[r.hidden] = r.size
    return out
