"""The proof of the diagnosis (`dyno prove`, commands/prove.py): effects hidden in the
plain virtual rig (sim_backend/plain.toml) at a calibrated size, recorded, diagnosed and
counted. Here: the calibration on the direct cell, the matrix of runs and one recorded and
diagnosed run (with its next tests, given a budget); what they count: proof/table.py.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
import math
import tempfile
from contextlib import closing
from pathlib import Path

import numpy as np

from records.events import RunEnd
from models.diagnose.candidates import EFFECTS
from models.diagnose.spec import Nature
from models.physics.simulate import warm
from workers.pool import run_all
from records.data import segments
from rig import config as rig_config
from rig.errors import RigError
from sim_backend.effects import HIDDEN, scaled
from sim_backend.options import PlantOptions, plain_cell

from protocols import cell, runner
from protocols.plan import Plan

from proof.table import Outcome, key


def prove_plan(override=None) -> Plan:
    """The plan the diagnosis is proven on (protocols/proven.toml), or its protocol with
    `override` for parameters."""
    from protocols.library import PROTOCOLS
    from protocols.proven import opening
    protocol, params = opening()
    module = PROTOCOLS[protocol]
    return Plan(module, module.Params(**(override or params)))


def offline_recording(effects=None, seed=0, rate_hz=1000.0, params=None):
    """The plain plant driven by the prove plan (or `params` of the prove protocol) on the
    direct cell (no wires), sampled at rate_hz: (channels {name: (t, values)}, events,
    measured mask of the force samples). For calibration and the diagnosis benchmark;
    prove itself records through the wires. RigError if the run tripped."""
    name, plant_params, _ = plain_cell()
    cfg = rig_config.at_rate(rig_config.load("virtual"), rate_hz)
    kept = runner.Kept()
    with cell.direct(cfg, name, PlantOptions(name, effects or {}, plant_params, seed)) as c:
        result = runner.run_plan(prove_plan(params), c, [kept])
    if result.fault:
        raise RigError(f"offline run with {effects or 'no effects'}: {result.fault}")
    channels = kept.arrays()
    t = channels["force"][0]
    measured = np.zeros(len(t), bool)
    for _, _, t0, t1 in segments(kept.events):
        measured |= (t > t0) & (t <= t1)
    return channels, kept.events, measured


def offline_force(effects, seed=0):
    """(force as measured, measured-segment mask) of offline_recording."""
    ch, _, rec = offline_recording(effects, seed)
    return ch["force"][1], rec


def contribution(effect, value, seed=0, null=None, form=None):
    """RMS [N] of what the effect (in the plant's `form`, default None) adds to the
    measured force (same noise seed, so the noise cancels), or what follows from the null
    alone where the effect says so (Hidden.without_run: a lag of the motion readings)."""
    F0, rec = null if null is not None else offline_force({}, seed)
    d = HIDDEN[effect].without_run(value, np.arange(len(F0)) * 1e-3, F0)
    if d is None:
        try:
            F1, _ = offline_force({effect: value, **({"forms": {effect: form}} if form else {})}, seed)
        except RigError:  # so large the run tripped: far above any target
            return math.inf
        d = F1 - F0
    return float(np.sqrt(np.mean(d[rec] ** 2)))


def calibrate_one(task):
    """(value, its contribution [N]): the largest VALUE of effect e in `form` whose
    contribution is at most `target`, by bisection on a log scale."""
    e, form, target = task
    null = offline_force({}, 0)
    lo, hi = HIDDEN[e].weakest, 1e3  # strengths about the guess
    for _ in range(12):
        s = math.sqrt(lo * hi)
        c = contribution(e, scaled(e, HIDDEN[e].guess, s), 0, null, form)
        lo, hi = (s, hi) if c < target else (lo, s)
    value = float(f"{scaled(e, HIDDEN[e].guess, lo):.4g}")
    return value, contribution(e, value, 0, null, form)


def calibrate(target, progress, effects=None, forms=False, pool=None):
    """{EFFECT or EFFECT:FORM: value} with contribution == target, in the default form of
    each effect (and in every other form, forms=True)."""
    keys = [(e, f) for e in HIDDEN if not effects or e in effects
            for f in [None, *(HIDDEN[e].forms if forms else ())]]
    names = [key(e, f) for e, f in keys]
    results = run_all(calibrate_one, [(e, f, target) for e, f in keys], pool, progress=True, label="calibrate",
                      names=names, warm=warm)
    for n, (e, _), (v, c) in zip(names, keys, results):
        progress(f"{n} = {v:g} {HIDDEN[e].unit} (contribution {c:.2f} N)")
    return {n: v for n, (v, _) in zip(names, results)}




@dataclass(frozen=True)
class ProveTask:
    """One prove run: what is hidden in the plain cell, how strong, on which seed, noise
    and rate; the user's own force law (--open) and the next tests' rig time (--adaptive)."""
    effect: str | None  # a catalogue effect, a pair "a+b", or None: a null
    form: str | None  # the plant's form of it (sim_backend/effects/), None: the default
    size: float  # times the noise floor
    values: dict | None  # {effect: VALUE} hidden
    seed: int
    noise: float  # the sensors' noise, times the plain cell's
    rate: float  # Hz
    extra: str | None = None  # a force law of the user's own (sim_backend/extra.py)
    budget_s: float = 0.0  # rig time of the next tests discover may run after the plan

    @property
    def name(self):
        what = "open" if self.extra else f"{self.effect or 'null'} {self.form or ''} x{self.size:g}"
        return f"{what} noise x{self.noise:g} {self.rate:g} Hz seed {self.seed}"


def matrix(asked, all_forms, sizes, noise, rates, seeds, budget, concealed):
    """(effects, [ProveTask], beyond) of `dyno prove --effects ASKED`: each effect (ALL:
    every one; A+B: two hidden together; EFFECT:FORM: that form only; null: nothing hidden;
    None: all and the nulls), in its other forms too with all_forms, at each size (times its
    concealed value's noise floor), noise level and rate, on each seed, with a null per seed
    to measure contributions against. beyond: [(row, why)] of the rows the plant cannot take
    at their size and noise, left out (a matrix of sizes and noise levels has some; none is
    run); UsageError names what cannot be proven, and a matrix with nothing left to hide."""
    from sim_backend.effects import EffectError, parse
    from rig.errors import UsageError
    named = ([n for e in asked.split(",") for n in (HIDDEN if e == "ALL" else [e])] if asked
             else list(HIDDEN) + ["null"])
    effects = list(dict.fromkeys(e.partition(":")[0] for e in named))
    variants = list(dict.fromkeys((e.partition(":")[0], e.partition(":")[2] or None) for e in named))
    bad = [f"{e}:{f}" for e, f in variants if f and e in HIDDEN and f not in HIDDEN[e].forms]
    if bad:
        raise UsageError(f"--effects: {bad[0]}: no such form (sim_backend/effects/ FORMS)")
    unknown = [e for e in effects if e != "null" and not set(e.split("+")) <= set(HIDDEN)]
    if unknown:
        raise UsageError(f"--effects: unknown effect {unknown[0]!r} (known: {', '.join(HIDDEN)}, null, and pairs "
                         f"A+B hidden together)")
    if not all(200.0 <= r <= 10000.0 for r in rates):
        raise UsageError(f"--rates: the virtual cell runs at 200-10000 Hz, not {', '.join(f'{r:g}' for r in rates)}")
    if all_forms:
        variants = [v for e in effects for v in [(e, None)] + [(e, f) for f in (HIDDEN[e].forms if e in HIDDEN
                                                                                  else ())]]
    for e, form in variants:  # each form at its own noise floor
        for part in (e.split("+") if e != "null" else ()):
            if key(part, form) not in concealed:
                raise UsageError(f"no concealed value for {key(part, form)!r} in sim_backend/plain.toml "
                                 f"(run dyno prove --calibrate{' --forms all' if form else ''})")
    tasks = []
    for seed in range(seeds):
        for level, rate in [(n, r) for n in noise for r in rates]:
            for e, form in variants:
                for size in ([1.0] if e == "null" else sizes):  # a multiple of the noise floor at this level
                    values = None if e == "null" else {
                        p: scaled(p, concealed[key(p, form)], size * level) for p in e.split("+")}
                    tasks.append(ProveTask(None if e == "null" else e, form, size, values, seed, level, rate,
                                           budget_s=budget))
            if "null" not in effects:  # the contribution is measured against the null of the same seed
                tasks.append(ProveTask(None, None, 1.0, None, seed, level, rate, budget_s=budget))
    beyond, kept = {}, []
    for t in tasks:  # a size the plant cannot take is left out before any run
        try:
            parse([f"{e}{':' + t.form if t.form else ''}={v}" for e, v in (t.values or {}).items()])
            kept.append(t)
        except EffectError as err:
            row = f"{t.effect}{':' + t.form if t.form else ''} x{t.size:g} at noise x{t.noise:g}"
            beyond.setdefault(row, f"--sizes {t.size:g}: {err}")
    if beyond and all(t.effect is None for t in kept):
        raise UsageError(next(iter(beyond.values())))
    return effects, kept, list(beyond.items())


def run_tasks(tasks, pool, label, keep=None, say=lambda s: None):
    """[run_task(t) for t in tasks] on the pool. keep: a folder (proof/keep.py) where
    each result is kept as it comes in, and from which a task already run is taken."""
    from proof import keep as kept
    got = [kept.load(keep, t) if keep else None for t in tasks]
    todo = [i for i, r in enumerate(got) if r is None]
    if len(todo) < len(tasks):
        say(f"{label}: {len(tasks) - len(todo)} of {len(tasks)} runs kept in {keep}, not run again")
    finished = []

    def done(j, r):
        finished.append(j)
        if keep:
            kept.save(keep, tasks[todo[j]], r)
    try:
        new = run_all(run_task, [tasks[i] for i in todo], pool, progress=True, label=label,
                      names=[tasks[i].name for i in todo], done=done, warm=warm)
    except KeyboardInterrupt:  # an operator's stop: say what of the work survives it
        ran = len(tasks) - len(todo) + len(finished)
        say(f"{label}: stopped; {ran} of {len(tasks)} runs done, "
            + (f"kept in {keep}: the same command goes on from there" if keep
               else "none kept (--keep DIR keeps each run as it ends)"))
        raise
    for i, r in zip(todo, new):
        got[i] = r
    return got


def run_task(task: ProveTask) -> Outcome:
    """Record one prove run through the wire protocols (and, given a budget, the next tests
    it asks for: protocols/discover.py), diagnose it."""
    with tempfile.TemporaryDirectory(prefix="dyno-prove-") as folder:  # on the worker's own disk
        return _recorded(task, folder)


def _recorded(task: ProveTask, folder):
    from models.damper import load as load_damper
    from models.diagnose import diagnose
    from protocols.discover import discover
    from records.reader import load_recording
    from protocols.recorded import for_run
    from sim_backend.options import plant_options
    effect, form, size, values, seed, noise, rate = (task.effect, task.form, task.size, task.values, task.seed,
                                                     task.noise, task.rate)
    extra, budget_s = task.extra, task.budget_s
    out = Path(folder) / f"{effect or 'null'}-{form or 'default'}-{size:g}-{noise:g}-{rate:g}-{seed}.mcap"
    specs = ([f"{e}{':' + form if form else ''}={v}" for e, v in (values or {}).items()]
             + ([f"extra:{extra}"] if extra else []))
    plant = plant_options(None, specs, plain=True, seed=seed, noise=noise)
    damper = load_damper(plant.damper)
    plan = prove_plan()
    with cell.embedded(damper, rig_config.at_rate(rig_config.load("virtual"), rate), plant=plant) as c:
        with closing(for_run(out, c, plan, overwrite=True)) as rec:
            found = discover(plan, c, [rec], budget_s) if budget_s else None
            if found is None:  # a run that tripped is diagnosed on what it recorded, as a user's would be
                runner.run_plan(plan, c, [rec])
    ch, ev, _ = load_recording(out)
    r = found.diagnosis if found else diagnose(ch, ev)
    rounds = found.rounds if found else []
    hidden = set(effect.split("+")) if effect else set()
    # the channels' alignment within a sample, fitted with the baseline, is a lag too small to
    # be a candidate: it stands for a hidden sensor delay (the effect that supersedes it)
    first = _first([_covered(e) for e in r.cell_found()] + r.named(), hidden)
    group = _group(r, hidden)
    est = None
    if first and effect and first == effect:  # a single effect (a pair's name has a "+")
        est = own_estimate(r, first)
    t, F = ch["force"]
    # the prove plan's segments: the contribution is measured there, against the null of the
    # same seed (the next tests differ from run to run)
    opening_end = next(e.t for e in ev if isinstance(e, RunEnd))
    measured = np.zeros(len(t), bool)
    for _, _, t0, t1 in segments(ev):
        if t1 <= opening_end:
            measured |= (t >= t0) & (t < t1)
    # what the caller needs travels back with the result: the workers share no disk
    # an effect accepted beside the hidden ones: said as left-out physics, or as "may be
    # compensating the form of" an earlier one (docs/diagnosis.md)
    # a timing offset of the cell or the valve curve's form is no claim of physics
    # (models/diagnose/spec.py NATURES): not counted against a null or as an extra
    # physics below the practical size is kept in the model but not named: no claim
    claims = [e for e in r.named() if EFFECTS[e.split(":")[0]].nature in (Nature.PHYSICS, Nature.OPEN)]
    extra = [s for s in r.steps if s.effect.split(":")[0] not in hidden and s.effect in claims]
    return Outcome(
        effect=effect, form=form, size=size, noise=noise, rate=rate, seed=seed,
        rounds=[dataclasses.asdict(x) for x in rounds], added_s=found.spent_s if found else 0.0,
        # the opening's diagnosis: what the prove plan alone named, on the same recording
        # (with the channels' alignment of the last: every round fits it with the baseline)
        first_opening=_first([_covered(e) for e in r.cell_found()] + rounds[0].accepted, hidden) if rounds else first,
        accepted=r.accepted, claims=claims, first=first, group=group, noise_sd=r.noise_sd,
        found=[{k: getattr(s, k) for k in ("effect", "nature", "depends_on", "region", "size_rms_n", "relevance",
                                           "excess_share", "held_in")} for s in r.steps if not s.replaced_by],
        within_noise=r.left_over.within_noise, rmse=(r.baseline.rmse_heldout, r.final.rmse_heldout),
        extra_left_out=any(not s.compensates for s in extra), extra_compensating=any(s.compensates for s in extra),
        force_t=t, force=F, measured=measured, estimate=est,
        before=r.baseline.nrmse_heldout, after=r.final.nrmse_heldout)


def own_estimate(r, first):
    """The value the diagnosis found for the effect it named first (its spec's estimate), or
    None where the effect has no one value (friction along the bore: a shape along the
    stroke). An accepted lag's own estimate before the alignment it took the place of."""
    fits = [(s.effect, s.parameters) for s in r.steps] + [(c.effect, c.parameters) for c in r.baseline.cell]
    return next(p.get(EFFECTS[e.split(":")[0]].estimate) for e, p in fits if _covered(e).split(":")[0] == first)


def _first(accepted, hidden):
    """The first effect named that counts: the valve curve's form and the cell's own timing
    (the plant's, on every null) do not take the first place unless the row hides them."""
    named = [e for e in accepted if EFFECTS[e.split(":")[0]].nature not in (Nature.FORM, Nature.CELL) or e.split(":")[0] in hidden]
    return named[0].split(":")[0] if named else None


def _covered(e):
    """The effect that supersedes e (the lag the channels' alignment is at a larger scale), or e."""
    return next((n for n, s in EFFECTS.items() if s.supersedes == e), e)


def _group(r, hidden):
    """The first finding that counts (as _first, small ones aside), with what the recording
    cannot tell from it: its rivals, when it is said as a group or a flexible stand-in
    explained it as well. [effect names]"""
    cell = [_covered(c) for c in r.cell_found() if _covered(c) in hidden]  # fitted with the baseline: no rivals
    if cell:
        return cell[:1]
    for s in r.steps:
        key = s.effect.split(":")[0]
        if s.replaced_by or s.small or (EFFECTS[key].nature in (Nature.FORM, Nature.CELL) and key not in hidden):
            continue
        return [key] + [e.split(":")[0] for e, _, _ in s.rivals]
    return []


def open_tasks(expr, seeds, level, rate):
    """`dyno prove --open EXPR`'s runs: on each seed, a null and the user's own physics
    (sim_backend/extra.py) hidden; UsageError names a law that cannot be compiled."""
    from sim_backend.effects import EffectError, parse
    from rig.errors import UsageError
    try:
        parse([f"extra:{expr}"])
    except EffectError as e:
        raise UsageError(str(e).replace("--effect extra:", "--open ")) from None
    return [t for seed in range(seeds) for t in (ProveTask(None, None, 1.0, None, seed, level, rate),
                                                 ProveTask(None, None, 1.0, None, seed, level, rate, expr))]
