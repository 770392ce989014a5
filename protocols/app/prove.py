"""`dyno prove`: hide each catalogue effect in the plain virtual rig (sim_backend/plain.toml)
at the level where its RMS contribution to the force equals the force sensor's noise (or a
multiple, --sizes; in the plant's other forms, --forms all; two at once, A+B), record the
prove sine matrix through the wire protocols, diagnose, and count.

Detection: the effect is the first accepted (a pair: both accepted), the valve curve's form
(the baseline's own law reshaped) and the cell's timing (the plant's own, named on its
nulls too) aside unless the row hides a timing. Wrong effect: something else came first (a pair:
something else accepted). False positive: physics claimed on a null recording (no hidden
effect): a catalogue effect or a term outside it; a timing offset of the cell or the valve
curve's form is no claim of physics (models/diagnose/spec.py NATURES).
"""
from __future__ import annotations

import json
import sys

from protocols.errors import UsageError

from protocols.app.arguments import cluster_option, number, sizes

def add(sub):
    """The `dyno prove` command's arguments."""
    pv = sub.add_parser("prove", help="hide each effect in the virtual rig at the noise level and diagnose it")
    pv.add_argument("--seeds", type=number(1, 10000, integer=True), default=10,
                    help="recordings per effect (default 10)")
    pv.add_argument("--effects", help="comma-separated subset of effects, A+B for two hidden together, "
                                      "EFFECT:FORM for one of its other forms, ALL for every effect (default: all, plus nulls)")
    pv.add_argument("--forms", choices=("default", "all"), default="default",
                    help="all: each effect also in the plant's other forms (default: its calibrated form only)")
    pv.add_argument("--sizes", type=sizes, default=None,
                    help="comma-separated strengths: multiples of each concealed effect (default 1), e.g. 1,3,10")
    pv.add_argument("--noise", type=sizes, default=[1.0],
                    help="comma-separated multiples of the cell's sensor noise (default 1), e.g. 1,3,10; sizes "
                         "scale with it (x1 is the noise floor at each level)")
    pv.add_argument("--rates", type=sizes, default=[1000.0],
                    help="comma-separated loop and sampling rates [Hz] (default 1000), e.g. 1000,5000")
    pv.add_argument("--on", metavar="RECORDING",
                    help="prove on your own real recording: each effect and cell fault hidden in copies of it at "
                         "--sizes (RMS, %% of its force range; default 1,3), every copy and the untouched one "
                         "diagnosed: what a diagnosis of this file can and cannot see; --effects picks from "
                         "models/diagnose/hiding.toml (the catalogue's and lag, zero_drift, gain_drift, filter)")
    pv.add_argument("--rounds", type=number(1, 4, integer=True), default=4,
                    help="--on: each diagnosis stops after this many rounds (default 4, the diagnosis's own)")
    pv.add_argument("--open", metavar="EXPR",
                    help="hide your own physics: a force [N] in x [m], v [m/s], t [s], T [K], e.g. "
                         "'2e6*maximum(x-0.05,0)**2' (sim_backend/extra.py), against a null per seed")
    pv.add_argument("--adaptive", action="store_true",
                    help="after the prove plan, the dyno's own next tests (as dyno run discover) on the same "
                         "recording; the table gives detection by the plan alone beside it")
    pv.add_argument("--budget", type=number(0, 3600), default=120.0, metavar="SECONDS",
                    help="--adaptive: rig time the next tests may add (default 120)")
    pv.add_argument("--keep", metavar="DIR",
                    help="keep each run's result in DIR and take from it those already there: a proof stopped "
                         "part-way goes on where it stopped, and proofs sharing a run (a seed's null) make it once")
    pv.add_argument("--json", action="store_true")
    pv.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    pv.add_argument("--calibrate", action="store_true",
                    help="find each effect's concealed value (contribution = force noise) and print it")
    pv.add_argument("--jobs", type=number(1, 256, integer=True), default=2,
                    help="recordings made and diagnosed in parallel (default 2)")
    cluster_option(pv)
    pv.set_defaults(command="prove")


def run(args):
    from sim_backend.effects import EFFECTS, scaled
    from sim_backend.options import plain_cell
    from protocols import cluster
    from protocols.proof import ProveTask, calibrate, key, measured_rms_diff, run_tasks, table as proof_table
    _, params, prove = plain_cell()
    say = (lambda s: print(s, file=sys.stderr, flush=True))
    noise = params["sensors"]["force_noise"]
    if args.calibrate:
        with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
            vals = calibrate(noise, say, args.effects.split(",") if args.effects else None, args.forms == "all", pool)
        print("[prove.concealed]")
        for e, v in vals.items():
            print(f'"{e}" = {v:g}' if ":" in e else f"{e} = {v:g}")
        return 0
    if getattr(args, "on", None) is not None:
        from protocols.app import prove_on
        return prove_on.run(args, say)
    if getattr(args, "open", None) is not None:  # an empty EXPR is refused there, not ignored
        return prove_open(args, say)
    concealed = prove.get("concealed", {})
    named = ([n for e in args.effects.split(",") for n in (EFFECTS if e == "ALL" else [e])] if args.effects
             else list(EFFECTS) + ["null"])  # ALL: every effect
    effects = list(dict.fromkeys(e.partition(":")[0] for e in named))  # EFFECT:FORM proves that form only
    variants = list(dict.fromkeys((e.partition(":")[0], e.partition(":")[2] or None) for e in named))
    bad = [f"{e}:{f}" for e, f in variants if f and e in EFFECTS and f not in EFFECTS[e].forms]
    if bad:
        raise UsageError(f"--effects: {bad[0]}: no such form (sim_backend/effects/ FORMS)")
    args.sizes = getattr(args, "sizes", None) or [1.0]
    unknown = [e for e in effects if e != "null" and not set(e.split("+")) <= set(EFFECTS)]
    if unknown:
        raise UsageError(f"--effects: unknown effect {unknown[0]!r} (known: {', '.join(EFFECTS)}, null, and pairs "
                       f"A+B hidden together)")
    if not all(200.0 <= r <= 10000.0 for r in args.rates):
        raise UsageError(f"--rates: the virtual cell runs at 200-10000 Hz, not "
                         f"{', '.join(f'{r:g}' for r in args.rates)}")
    if args.forms == "all":  # each effect also in the plant's other forms (sim_backend/effects/ FORMS)
        variants = [v for e in effects
                    for v in [(e, None)] + [(e, f) for f in (EFFECTS[e].forms if e in EFFECTS else ())]]
    for e, form in variants:  # each form at its own noise floor
        for part in (e.split("+") if e != "null" else ()):
            if key(part, form) not in concealed:
                say(f"dyno: error: no concealed value for {key(part, form)!r} in sim_backend/plain.toml "
                    f"(run dyno prove --calibrate{' --forms all' if form else ''})")
                return 2
    tasks = []
    budget = args.budget if getattr(args, "adaptive", False) else 0.0
    for seed in range(args.seeds):
        for level, rate in [(n, r) for n in args.noise for r in args.rates]:
            for e, form in variants:
                for size in ([1.0] if e == "null" else args.sizes):
                    # a size is a multiple of the noise floor at this noise level
                    values = None if e == "null" else {
                        p: scaled(p, concealed[key(p, form)], size * level) for p in e.split("+")}
                    tasks.append(ProveTask(None if e == "null" else e, form, size, values, seed, level, rate,
                                           budget_s=budget))
            if "null" not in effects:  # the contribution is measured against the null of the same seed
                tasks.append(ProveTask(None, None, 1.0, None, seed, level, rate, budget_s=budget))
    from sim_backend.effects import EffectError, parse
    for t in tasks:  # a size the plant cannot take is refused before any run
        try:
            parse([f"{e}{':' + t.form if t.form else ''}={v}" for e, v in (t.values or {}).items()])
        except EffectError as err:
            raise UsageError(f"--sizes {t.size:g}: {err}") from None
    with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
        results = run_tasks(tasks, pool, "prove", _keep(args), say)
    for t, r in zip(tasks, results):
        say(f"{t.name}: accepted {r['accepted'] or 'nothing'}")
    nulls = {(r["seed"], r["noise"], r["rate"]): r for r in results if r["effect"] is None}
    for r in results:
        if r["effect"]:
            r["contribution"] = measured_rms_diff(r, nulls[r["seed"], r["noise"], r["rate"]])
    table = proof_table(results, effects, concealed)
    doc = {"noise_rms": noise, "seeds": args.seeds, "effects": table, "adaptive_budget_s": budget or None,
           "goals": {"detection": 0.9, "false_positive": 0.05}}
    if args.json:
        print(json.dumps(doc, indent=1))
    else:
        _print(table, args, noise)
    return 0


def prove_open(args, say):
    """`dyno prove --open EXPR`: the user's own physics (sim_backend/extra.py) hidden in the
    plain cell, each seed against the null of the same seed: what the diagnosis names,
    what it depends on, where it lives, and how much of the held-out error above the
    noise it explains."""
    from protocols import cluster
    from protocols.proof import ProveTask, measured_rms_diff, run_tasks
    from sim_backend.effects import EffectError, parse
    try:
        parse([f"extra:{args.open}"])
    except EffectError as e:
        raise UsageError(str(e).replace("--effect extra:", "--open ")) from None
    level, rate = args.noise[0], args.rates[0]
    tasks = [t for seed in range(args.seeds) for t in (ProveTask(None, None, 1.0, None, seed, level, rate),
                                                        ProveTask(None, None, 1.0, None, seed, level, rate, args.open))]
    with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
        results = run_tasks(tasks, pool, "prove --open", _keep(args), say)
    rows = []
    for null, r in zip(results[::2], results[1::2]):
        size = measured_rms_diff(r, null)
        base, final = (e ** 2 for e in r["rmse"])
        explained = 1.0 - max(final - r["noise_sd"] ** 2, 0.0) / max(base - r["noise_sd"] ** 2, 1e-12)
        rows.append({"seed": r["seed"], "contribution_rms": size, "null_claims": null["claims"],
                     "found": r["found"], "explained": explained, "within_noise": r["within_noise"]})
    if args.json:
        print(json.dumps({"expression": args.open, "rate_hz": rate, "noise": level, "runs": rows}, indent=1))
        return 0
    print(f"extra: {args.open}  (x [m], v [m/s], t [s], T [K]; {rate:g} Hz, noise x{level:g})")
    for row in rows:
        found = "; ".join(f"{f['effect']} ({f['nature']}: {', '.join(f['depends_on'] or [])}; {f['region']}; "
                          f"{f['size_rms_n']:.3g} N RMS)" for f in row["found"]) or "nothing"
        print(f"seed {row['seed']}: hidden {row['contribution_rms']:.3g} N RMS; named {found}; "
              f"{100 * row['explained']:.0f} % of the held-out error above the noise explained"
              f"{'' if row['within_noise'] else '; some left unexplained'}"
              f"{'; the null claimed ' + ', '.join(row['null_claims']) if row['null_claims'] else ''}")
    return 0


def _keep(args):
    """--keep's folder, created now (a bad one is refused before any run), or None."""
    from protocols import keep
    return None if getattr(args, "keep", None) is None else keep.folder(args.keep)


HEADER = ("effect", "form", "size", "noise", "rate [Hz]", "hidden value", "force contribution RMS [N]", "detection",
          "named first or in a group of <= 3", "wrong effect", "false positive", "also named: left out / may compensate", "estimate (median)",
          "held-out NRMSE before / after [%]")


def _cells(r):
    f = (lambda v, fmt: format(v, fmt) if v is not None else "-")
    return (r["effect"], f(r["form"], "s"), f"x{r['size']:g}", f"x{r['noise']:g}", f"{r['rate_hz']:g}",
            f(r["value"], ".3g"), f(r["contribution_rms"], ".2f"), f(r["detection"], ".0%"),
            f(r["detection_group"], ".0%"), f(r["wrong_effect"], ".0%"), f(r["false_positive"], ".0%"),
            f"{f(r['extra_left_out'], '.0%')} / {f(r['extra_compensating'], '.0%')}", f(r["estimate"], ".3g"),
            f"{100 * r['heldout_before']:.4f} / {100 * r['heldout_after']:.4f}")


ADAPTIVE = ("detection by the prove plan alone", "rig time added [s] (median)")


def _print(table, args, noise):
    from sim_backend.effects import EFFECTS
    from protocols.discover import MAX_ROUNDS
    header, rows = HEADER, [_cells(r) for r in table]
    if getattr(args, "adaptive", False):  # beside the detection: the opening's, and what the next tests cost
        header = (*HEADER[:7], ADAPTIVE[0], HEADER[7], ADAPTIVE[1], *HEADER[8:])
        rows = [(*c[:7], "-" if r["detection_opening"] is None else f"{r['detection_opening']:.0%}", c[7],
                 f"{r['added_s']:.0f}", *c[8:]) for c, r in zip(rows, table)]
    if not getattr(args, "markdown", False):
        widths = [max(len(c) for c in col) for col in zip(header, *rows)]
        for row in (header, *rows):
            print("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
        return
    from protocols.reports import markdown as md
    from sim_backend.effects import FORMS
    used = sorted({(r["effect"], r["form"]) for r in table if r["form"] not in (None, "default")},
                  key=lambda k: (list(EFFECTS).index(k[0]) if k[0] in EFFECTS else 99, k[1]))
    forms = [(e, "default", EFFECTS[e].form) for e in dict.fromkeys(e for e, _ in used) if e in EFFECTS]
    forms += [(e, f, FORMS[f"{e}:{f}"]) for e, f in used if f"{e}:{f}" in FORMS]
    body = md.table(header, rows)
    if forms:
        body += "\n\nThe forms (sim_backend/effects/):\n\n" + md.table(("effect", "form", "in the plant"),
                                                                       sorted(forms, key=lambda r: (list(EFFECTS).index(r[0]), r[1] != "default", r[1])))
    print(md.document("Proof of the diagnosis (dyno prove)", body,
                      f"{args.seeds} seeds per row on the plain cell through the wires"
                      + (f", each recording followed by the dyno's own next tests (dyno run discover, at most "
                         f"{args.budget:g} s of rig time added, at most {MAX_ROUNDS} rounds)"
                         if getattr(args, "adaptive", False) else "") + f"; force noise {noise:g} N RMS "
                      f"at noise x1 (every sensor's noise times the noise column). Size x1 is the concealed value "
                      f"at that noise (its contribution equals the force noise, each form calibrated on its own); x10 ten times "
                      f"as strong (a bulk modulus divided by ten, a breakaway ratio's excess times ten); forms: "
                      f"sim_backend/effects/ FORMS. Goals: detection >= 90 %, false positives <= 5 %. Method: "
                      f"docs/diagnosis.md."))
