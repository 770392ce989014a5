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
from dataclasses import asdict
import sys

from commands.arguments import cluster_option, number, sizes

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
    from sim_backend.options import plain_cell
    from protocols import cluster
    from proof.on_plant import calibrate, matrix, run_tasks
    from proof.table import paired, table as proof_table
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
        from commands import prove_on
        return prove_on.run(args, say)
    if getattr(args, "open", None) is not None:  # an empty EXPR is refused there, not ignored
        return prove_open(args, say)
    concealed = prove.get("concealed", {})
    budget = args.budget if getattr(args, "adaptive", False) else 0.0
    args.sizes = getattr(args, "sizes", None) or [1.0]
    effects, tasks, beyond = matrix(args.effects, args.forms == "all", args.sizes, args.noise, args.rates,
                                    args.seeds, budget, concealed)
    with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
        results = run_tasks(tasks, pool, "prove", _keep(args), say)
    for t, r in zip(tasks, results):
        say(f"{t.name}: accepted {r.accepted or 'nothing'}")
    table = proof_table(paired(results), effects, concealed)
    doc = {"noise_rms": noise, "seeds": args.seeds, "effects": [asdict(row) for row in table],
           "adaptive_budget_s": budget or None, "not_run": [{"row": r, "why": w} for r, w in beyond],
           "goals": {"detection": 0.9, "false_positive": 0.05}}
    if args.json:
        print(json.dumps(doc, indent=1))
    else:
        _print(table, args, noise, beyond)
    return 0


def prove_open(args, say):
    """`dyno prove --open EXPR`: the user's own physics (sim_backend/extra.py) hidden in the
    plain cell, each seed against the null of the same seed: what the diagnosis names,
    what it depends on, where it lives, and how much of the held-out error above the
    noise it explains."""
    from protocols import cluster
    from proof.on_plant import open_tasks, run_tasks
    from proof.table import open_rows
    level, rate = args.noise[0], args.rates[0]
    tasks = open_tasks(args.open, args.seeds, level, rate)
    with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
        rows = open_rows(run_tasks(tasks, pool, "prove --open", _keep(args), say))
    if args.json:
        print(json.dumps({"expression": args.open, "rate_hz": rate, "noise": level,
                          "runs": [asdict(row) for row in rows]}, indent=1))
        return 0
    print(f"extra: {args.open}  (x [m], v [m/s], t [s], T [K]; {rate:g} Hz, noise x{level:g})")
    for row in rows:
        found = "; ".join(f"{f['effect']} ({f['nature']}: {', '.join(f['depends_on'] or [])}; {f['region']}; "
                          f"{f['size_rms_n']:.3g} N RMS)" for f in row.found) or "nothing"
        print(f"seed {row.seed}: hidden {row.contribution_rms:.3g} N RMS; named {found}; "
              f"{100 * row.explained:.0f} % of the held-out error above the noise explained"
              f"{'' if row.within_noise else '; some left unexplained'}"
              f"{'; the null claimed ' + ', '.join(row.null_claims) if row.null_claims else ''}")
    return 0


def _keep(args):
    """--keep's folder, created now (a bad one is refused before any run), or None."""
    from proof import keep
    return None if getattr(args, "keep", None) is None else keep.folder(args.keep)


def _print(table, args, noise, beyond):
    from proof.table import markdown, rows
    header, cells = rows(table, getattr(args, "adaptive", False))
    if getattr(args, "markdown", False):
        print(markdown(header, cells, table, args.seeds, noise, args.budget if getattr(args, "adaptive", False)
                       else None, beyond))
        return
    widths = [max(len(c) for c in col) for col in zip(header, *cells)]
    for row in (header, *cells):
        print("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
    for row, why in beyond:
        print(f"not run, beyond the plant's range: {row} ({why})")
